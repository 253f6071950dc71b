"""Self-collision: the checker (robots.self_collision) and the planner's hinge
(clamp.factors.SelfCollisionFamily), on both arms.

- the two reproducers of issue 19 (plans main's planner calls successful, with a link deep in
  another) are found, naming both links and the depth; box_closing's default plans pass;
- the checker agrees with an independent brute force (Pinocchio's GeometryModel, every
  non-disabled link pair, coal) at its configurations, and the continuous motion keeps its
  lower bound on a much denser subdivision, on random trajectories of both arms; with the
  planner's tolerance, the same collisions and a clearance within it;
- the disabled-pair rule: adjacent and rigid pairs are in it, pairs that can collide are not,
  a pair always in contact is found by sampling;
- the hinge family: Jacobians against finite differences with the worst configuration inside a
  step and with base spheres, and the pair list.
"""
from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from bad_input import raises_naming
from clamp import PlannerConfig, plan
from clamp.errors import ClampTypeError, InvalidParameterError
from clamp.factors import SelfCollisionFamily, StateWindow
from robots import Robot, SphereModel
from robots.collision_check import CollisionChecker
from robots.errors import CollisionCheckError, InvalidArrayError
from robots.self_collision import (SPHERE_REACH, checked_pairs, disabled_pairs, self_collision_report,
                                   self_collision_spheres)

REPRODUCERS = {"sawyer": [-0.093, 0.107, 0.165], "jaco": [-0.025, -0.05, 0.113]}


@pytest.fixture(scope="module")
def reproducer(prior):
    """name -> the reproducer's plan as the planner made it before it repaired self-collisions
    (no constraint rounds; computed once per module)."""
    plans = {}
    unrepaired = PlannerConfig().with_(constraint_rounds=0)

    def get(robot):
        if robot.name not in plans:
            plans[robot.name] = plan(prior, robot, None, prior.mean[0, :3],
                                     goal=REPRODUCERS[robot.name], config=unrepaired)
        return plans[robot.name]
    return get


# ------------------------------------------------------------------------------- reproducers
@pytest.mark.parametrize("name", ["sawyer", "jaco"])
def test_reproducer_plans_self_collide(name, prior, reproducer, request):
    robot = request.getfixturevalue(name)
    result = reproducer(robot)
    report = self_collision_report(robot, result.q, prior.time)
    assert report.collision and report.min_distance < -0.01
    contact = report.nearest
    assert contact.link_a != contact.link_b
    assert {contact.link_a, contact.link_b} not in [{a, b} for a, b, _ in disabled_pairs(robot)]
    reason = report.reason
    assert contact.link_a in reason and contact.link_b in reason
    assert f"{-1e3 * contact.distance:.1f} mm" in reason and "\n" not in reason
    assert report.states_in_collision.sum() >= 10
    assert contact.time == pytest.approx(np.interp(contact.index, np.arange(prior.T), prior.time))
    summary = json.loads(json.dumps(report.to_dict()))
    assert summary["collision"] and summary["nearest"]["link_a"] == contact.link_a
    assert summary["states_in_collision"] == np.flatnonzero(report.states_in_collision).tolist()


@pytest.mark.parametrize("name", ["sawyer", "jaco"])
def test_box_closing_default_plans_pass(name, prior, request):
    robot = request.getfixturevalue(name)
    result = plan(prior, robot, None, prior.mean[0, :3])
    report = self_collision_report(robot, result.q, prior.time)
    assert not report.collision and report.reason is None
    assert not report.states_in_collision.any()
    assert 0.0 < report.min_distance < 0.1          # links pass close to each other, and that is fine
    assert report.lower_bound == pytest.approx(report.min_distance - report.max_step)


# ------------------------------------------------------------------------------ brute force
def brute_force(robot: Robot, q: np.ndarray, distances: bool) -> np.ndarray:
    """At configurations q (K, n), for every pair of collision objects of non-disabled links,
    Pinocchio's own placements and coal, no pruning: signed distances (K, P') when
    ``distances`` (slow on overlapping meshes), else whether each pair collides (K, P')."""
    off = {frozenset((a, b)) for a, b, _ in disabled_pairs(robot)}
    model, source = robot.model, robot.collision_model
    geometry = pin.GeometryModel()
    for obj in source.geometryObjects:
        geometry.addGeometryObject(pin.GeometryObject(obj))
    links = [model.frames[obj.parentFrame].name for obj in geometry.geometryObjects]
    for a in range(geometry.ngeoms):
        for b in range(a + 1, geometry.ngeoms):
            if frozenset((links[a], links[b])) not in off and links[a] != links[b]:
                geometry.addCollisionPair(pin.CollisionPair(a, b))
    data, gdata = model.createData(), pin.GeometryData(geometry)
    for req in gdata.distanceRequests:
        req.enable_signed_distance = True
    out = np.empty((len(q), len(geometry.collisionPairs)))
    for k, q_pin in enumerate(robot.to_pinocchio(q)):
        if distances:
            pin.computeDistances(model, data, geometry, gdata, q_pin)
            out[k] = [r.min_distance for r in gdata.distanceResults]
        else:
            pin.computeCollisions(model, data, geometry, gdata, q_pin, False)
            out[k] = [r.isCollision() for r in gdata.collisionResults]
    return out if distances else out.astype(bool)


def random_trajectories(robot: Robot, seed: int, count: int, scale: float = 0.25) -> list[np.ndarray]:
    """Short random trajectories (3 states, steps of ~scale rad) from random configurations."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        q0 = robot.random_configuration(rng)
        steps = rng.normal(scale=scale, size=(2, robot.n))
        out.append(robot.clip_to_limits(q0 + np.concatenate([np.zeros((1, robot.n)), np.cumsum(steps, axis=0)])))
    return out


@pytest.mark.parametrize("name, seed", [("sawyer", 1), ("jaco", 2)])
def test_checker_agrees_with_brute_force(name, seed, reproducer, request):
    robot = request.getfixturevalue(name)
    assert len(checked_pairs(robot)) == brute_force(robot, robot.neutral_configuration()[None], False).shape[1]
    checker = CollisionChecker(robot, (), include_fixed=True)
    outcomes = set()
    # random ones (mesh distances cost ~1 ms a pair: fewer, shorter on the Jaco), and a piece of
    # the reproducer (its arm folded into its base), jittered
    rng = np.random.default_rng(seed)
    folded = reproducer(robot).q[[215, 225, 235]] + rng.normal(scale=0.02, size=(3, robot.n))
    random = random_trajectories(robot, seed, 6) if name == "sawyer" else random_trajectories(robot, seed, 2, 0.1)
    for q in random + [folded]:
        report = self_collision_report(robot, q, max_motion=0.02)
        # the planner's tolerant check: the same collisions, a clearance within 1 cm above
        tolerant = self_collision_report(robot, q, max_motion=0.02, tolerance=0.01)
        configurations = checker.configurations(q, 0.02)
        assert report.num_configurations == len(configurations.q)
        colliding = brute_force(robot, configurations.q, False).any(axis=1)
        outcomes.add(report.collision)
        assert report.collision == tolerant.collision == bool(colliding.any())
        np.testing.assert_array_equal(report.states_in_collision, colliding[configurations.support])
        np.testing.assert_array_equal(tolerant.states_in_collision, report.states_in_collision)
        assert tolerant.num_exact <= report.num_exact
        if report.collision:
            k = int(np.argmin(np.abs(configurations.index - report.nearest.index)))
            assert colliding[k] and report.min_distance < 0.0
            continue
        least = brute_force(robot, configurations.q, True).min(axis=1)
        assert report.min_distance == pytest.approx(least.min(), abs=2e-5)
        assert least.min() - 2e-5 <= tolerant.min_distance <= least.min() + 0.01 + 2e-5
        assert tolerant.lower_bound <= report.lower_bound + 2e-5
        # the continuous motion: 8 times denser, nothing closer than the report's lower bound
        dense = np.linspace(0.0, 1.0, 8 * len(configurations.q))[:, None]
        path = np.concatenate([q[i] + dense * (q[i + 1] - q[i]) for i in range(len(q) - 1)])
        if name == "sawyer":          # primitives: distances are cheap
            assert brute_force(robot, path, True).min() >= report.lower_bound - 2e-5
        else:                         # meshes: a distance costs ~1 ms; collisions suffice below 0
            assert report.lower_bound > 0.0 and not brute_force(robot, path, False).any()
    assert outcomes == {True, False}, "the random trajectories should include clear and colliding ones"


# ---------------------------------------------------------------------------- disabled pairs
def test_disabled_pairs_follow_the_rule(sawyer, jaco):
    sawyer_pairs = {(a, b): why for a, b, why in disabled_pairs(sawyer)}
    assert sawyer_pairs[("right_arm_base_link", "right_l0")] == "adjacent"
    assert sawyer_pairs[("right_l0", "right_l1")] == "adjacent"
    assert sawyer_pairs[("right_l1", "right_l1_2")] == "rigid"          # welded by a fixed joint
    assert sawyer_pairs[("right_l1_2", "right_l2")] == "adjacent"      # across the fixed joint
    assert sawyer_pairs[("right_hand", "right_l6")] == "rigid"
    assert ("right_l0", "right_l4_2") not in sawyer_pairs               # they collide in the reproducer
    assert ("right_arm_base_link", "right_l6") not in sawyer_pairs
    jaco_pairs = {(a, b): why for a, b, why in disabled_pairs(jaco)}
    assert jaco_pairs[("j2s6s200_link_1", "j2s6s200_link_base")] == "adjacent"
    assert jaco_pairs[("j2s6s200_link_6", "j2s6s200_link_finger_tip_1")] == "rigid"
    assert ("j2s6s200_link_base", "j2s6s200_link_finger_tip_2") not in jaco_pairs
    assert ("j2s6s200_link_1", "j2s6s200_link_3") not in jaco_pairs
    assert disabled_pairs(jaco) is disabled_pairs(jaco)                   # computed once
    for a, b, why in disabled_pairs(jaco) + disabled_pairs(sawyer):
        assert a < b and why in ("adjacent", "rigid", "always")


ALWAYS_URDF = """<robot name="always">
  <link name="base"/>
  <link name="l1"><collision><geometry><sphere radius="0.2"/></geometry></collision></link>
  <link name="l2"/>
  <link name="l3"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
  <link name="tool"><collision><origin xyz="0 0 0.3"/><geometry><sphere radius="0.05"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="jt" type="fixed"><parent link="l3"/><child link="tool"/></joint>
</robot>
"""


def test_pair_always_in_contact_is_disabled_and_a_reachable_one_is_checked(tmp_path):
    """l3's sphere is never more than 0.1 m from l1's centre (always inside it); the tool's,
    0.3 m out on l3, reaches l1's only with j3 folded beyond ~2.25 rad."""
    path = tmp_path / "always.urdf"
    path.write_text(ALWAYS_URDF)
    spheres = SphereModel(("l1", "l3", "l3"), [[0, 0, 0], [0, 0, 0], [0, 0, 0.3]], [0.2, 0.1, 0.05])
    robot = Robot.from_urdf(path, end_effector="tool", spheres=spheres)
    pairs = {(a, b): why for a, b, why in disabled_pairs(robot)}
    assert pairs == {("l1", "l3"): "always", ("l3", "tool"): "rigid"}       # l2 has no geometry
    assert checked_pairs(robot) == (("l1_0", "tool_0"),)
    # folding j3 from 0 to 3 rad brings the tool's centre to |(0.3 sin 3, 0, 0.1 + 0.3 cos 3)|
    q = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 3.0]])
    report = self_collision_report(robot, q, max_motion=0.01)
    assert report.collision and {report.nearest.link_a, report.nearest.link_b} == {"l1", "tool"}
    assert report.min_distance == pytest.approx(np.sqrt(0.1 + 0.06 * np.cos(3.0)) - 0.25, abs=1e-9)
    assert report.nearest.index == pytest.approx(1.0)


def test_robot_without_collision_geometry_uses_its_spheres(jaco):
    bare = Robot(jaco.model, jaco.end_effector, spheres=jaco.spheres, base_frame=jaco.base_frame)
    q = random_trajectories(jaco, 3, 1)[0]
    report = self_collision_report(bare, q)
    assert report.geometry == "spheres"
    assert all(link in jaco.spheres.link_names for pair in disabled_pairs(bare) for link in pair[:2])
    centres, _ = bare.sphere_centres(CollisionChecker(bare, ()).configurations(q).q)
    links, radii = np.array(jaco.spheres.link_names), jaco.spheres.radii
    off = {frozenset(p[:2]) for p in disabled_pairs(bare)}
    gaps = [np.linalg.norm(centres[:, a] - centres[:, b], axis=1) - radii[a] - radii[b]
            for a in range(len(radii)) for b in range(a + 1, len(radii))
            if links[a] != links[b] and frozenset((links[a], links[b])) not in off]
    assert report.min_distance == pytest.approx(np.min(gaps), abs=1e-6)


def test_bad_input_names_the_argument(jaco):
    q = np.zeros((3, jaco.n))
    with raises_naming(InvalidArrayError, "q"):
        self_collision_report(jaco, np.zeros((3, jaco.n + 1)))
    with raises_naming(CollisionCheckError, "time"):
        self_collision_report(jaco, q, time=[0.0, 1.0, 1.0])
    with raises_naming(CollisionCheckError, "max_motion"):
        self_collision_report(jaco, q, max_motion=-1.0)
    with raises_naming(CollisionCheckError, "tolerance"):
        self_collision_report(jaco, q, tolerance=-0.01)
    with raises_naming(CollisionCheckError, "robot"):
        self_collision_report("jaco", q)
    with raises_naming(InvalidParameterError, "epsilon"):
        SelfCollisionFamily.for_robot(jaco, range(3), epsilon=2 * SPHERE_REACH, sigma=0.01)
    with raises_naming(ClampTypeError, "spheres"):
        SelfCollisionFamily(range(3), jaco.spheres, epsilon=0.01, sigma=0.01)
    with raises_naming(InvalidParameterError, "between"):
        SelfCollisionFamily.for_robot(jaco, range(3), epsilon=0.01, sigma=0.01, between=-1)


# --------------------------------------------------------------------------- hinge family
def dense(family, robot, theta):
    """Residuals (F, P) of all factors, zeros where the kernel leaves a factor out."""
    lin = family.residual(StateWindow(robot, theta), np.arange(len(family)), False)
    out = np.zeros((len(family), family.dim))
    out[lin.rows] = lin.error
    return out


@pytest.mark.parametrize("name, seed", [("sawyer", 4), ("jaco", 5)])
def test_family_jacobians_inside_steps_and_on_the_base(name, seed, reproducer, request):
    robot = request.getfixturevalue(name)
    rng = np.random.default_rng(seed)
    # the reproducer's last states (arm folded back onto its base), jittered, and big steps
    q = reproducer(robot).q[-6:]
    q = q + rng.normal(scale=0.05, size=q.shape) + np.linspace(0, 1, 6)[:, None] * rng.normal(scale=0.3, size=robot.n)
    theta = np.concatenate([q, rng.normal(scale=0.3, size=q.shape)], axis=1)
    family = SelfCollisionFamily.for_robot(robot, range(5), epsilon=0.05, sigma=0.01, between=3)
    spheres = family.spheres
    base = robot.spheres.count
    lin = family.residual(StateWindow(robot, theta), np.arange(5), True)
    active = lin.error > 0
    assert np.any(active[:, (spheres.first >= base) | (spheres.second >= base)]), "a base sphere pair is active"
    # an active pair whose worst configuration is strictly inside its step: both states get a share
    n = robot.n
    left, right = lin.jacobian[:, :, :n], lin.jacobian[:, :, 2 * n:3 * n]
    inside = active & (np.abs(left).sum(axis=2) > 0) & (np.abs(right).sum(axis=2) > 0)
    assert inside.any()
    assert not np.any(lin.jacobian[:, :, n:2 * n]) and not np.any(lin.jacobian[:, :, 3 * n:])   # no qdot
    analytic = np.zeros((5, family.dim, 4 * n))
    analytic[lin.rows] = lin.jacobian
    base_error, step = dense(family, robot, theta), 1e-6
    checked, compared = [], []
    for state in range(6):
        for j in range(n):
            plus, minus = theta.copy(), theta.copy()
            plus[state, j] += step
            minus[state, j] -= step
            e_plus, e_minus = dense(family, robot, plus), dense(family, robot, minus)
            numeric = (e_plus - e_minus) / (2 * step)
            smooth = ((e_plus == 0) == (e_minus == 0)) & ((e_plus == 0) == (base_error == 0))
            # and no kink: the worst configuration of a step can switch sub-samples within
            # +-step, where the one-sided slopes differ (a smooth error's differ by ~f'' step)
            smooth &= np.abs(e_plus + e_minus - 2 * base_error) <= 1e-4 * step
            for f in {state - 1, state} & set(range(5)):
                col = (state - f) * 2 * n + j
                np.testing.assert_allclose(analytic[f, smooth[f], col], numeric[f, smooth[f]], rtol=1e-5, atol=1e-5)
                checked.append(int(np.count_nonzero(smooth[f] & (numeric[f] != 0))))
                compared.append(int(np.count_nonzero(numeric[f] != 0)))
    # the kinks are rare: almost every entry that moves is compared
    assert sum(checked) >= 0.95 * sum(compared) > 0


@pytest.mark.parametrize("name", ["sawyer", "jaco"])
def test_sphere_pairs_exclude_rigid_and_adjacent_links(name, request):
    robot = request.getfixturevalue(name)
    spheres = self_collision_spheres(robot)
    assert spheres is self_collision_spheres(robot)
    joints, _ = robot.sphere_attachments()
    joints = np.concatenate([joints, np.zeros(len(spheres.fixed_centres), dtype=int)])
    a, b = joints[spheres.first], joints[spheres.second]
    parents = np.asarray(robot.model.parents)
    assert not np.any(a == b) and not np.any(parents[np.maximum(a, b)] == np.minimum(a, b))
    assert 0 < len(spheres.first) < 0.5 * len(spheres.radii) ** 2
    assert len(spheres.fixed_centres) > 0 and np.all(spheres.clearance >= 0.0)
