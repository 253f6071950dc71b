"""The independent checks of the skill-fidelity benchmark (benchmarks/fidelity_checks.py):
obstacle and self-collision on the URDF geometry at a dense subdivision, completion, staying
with the skill, hand rotation."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import fidelity_checks as fc  # noqa: E402

from clamp import PlannerConfig, learn_prior, plan  # noqa: E402
from scenes import Box, Sphere, make_demonstrations  # noqa: E402

# the self-collision reproducer of issue 19: box_closing on the Sawyer to a goal near its base
REPRODUCER_GOAL = [-0.093, 0.107, 0.165]
# issue 9's probe: a Jaco fingertip mesh ~2 mm inside a 4 cm box
PROBE_Q = np.array([0.8342, 2.7134, 4.9144, 0.894, 2.2859, 0.0])
PROBE_BOX = Box([0.2271, -0.3773, 0.1763], [0.04, 0.04, 0.04])
WRIST = {"jaco": "j2s6s200_link_5", "sawyer": "right_l5"}   # a link origin inside its geometry


@pytest.fixture(scope="module")
def box_closing():
    demos = make_demonstrations("box_closing", num_demos=6, seed=0)
    return demos, learn_prior(demos)


@pytest.fixture(scope="module")
def arms(jaco, sawyer):
    return {"jaco": jaco, "sawyer": sawyer}


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_base_placement_maps_the_base_frame_to_pinocchio_world(arms, name):
    robot = arms[name]
    rng = np.random.default_rng(3)
    data = robot.model.createData()
    base = fc.base_placement(robot)
    frame = [f.name for f in robot.model.frames].index(robot.end_effector)
    for _ in range(3):
        q = robot.random_configuration(rng)
        pin.framesForwardKinematics(robot.model, data, robot.to_pinocchio(q))
        np.testing.assert_allclose(base.act(robot.fk(q)), data.oMf[frame].translation, atol=1e-9)


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_obstacle_between_states_is_found_by_the_subdivision(arms, name):
    """A sphere on the wrist at the midpoint of a segment, clear of both support states."""
    robot = arms[name]
    q0 = PROBE_Q if name == "jaco" else robot.neutral_configuration()   # wrist off the z axis
    q1 = q0.copy()
    q1[0] += 1.0                                   # swing about the first (vertical) axis
    q = np.stack([q0, q1])
    wrist = WRIST[name]
    centre = robot.frame_position(0.5 * (q0 + q1), wrist)
    check = fc.GeometryCheck(robot, [Sphere(centre, 0.03)])
    assert check.first_contacts(q, 1) == {}
    found = check.first_contacts(q)
    assert set(found) == {"obstacle"}
    assert 0.0 < found["obstacle"].state < 1.0
    assert found["obstacle"].second == "sphere_0"


def test_finds_the_jaco_fingertip_probe(jaco):
    found = fc.GeometryCheck(jaco, [PROBE_BOX]).first_contacts(PROBE_Q[None])
    assert "finger_tip" in found["obstacle"].first
    lowered = PROBE_BOX.translated([0.0, 0.0, -0.005])       # 5 mm lower: ~3 mm clear
    assert fc.GeometryCheck(jaco, [lowered]).first_contacts(PROBE_Q[None]) == {}


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_self_collision_pairs_follow_the_rule(arms, name):
    robot = arms[name]
    objects = robot.collision_model.geometryObjects
    pairs = fc.self_collision_pairs(robot)
    assert pairs
    for i, j in pairs:
        a, b = objects[i].parentJoint, objects[j].parentJoint
        assert a != b and robot.model.parents[a] != b and robot.model.parents[b] != a
    # none collides at the neutral configuration
    assert "self" not in fc.GeometryCheck(robot).first_contacts(robot.neutral_configuration()[None])


def test_finds_the_sawyer_self_collision_reproducer(sawyer, box_closing):
    _, prior = box_closing
    # as the planner made it before it repaired self-collisions (no constraint rounds)
    result = plan(prior, sawyer, None, prior.mean[0, :3], goal=REPRODUCER_GOAL, covariance=False,
                  config=PlannerConfig().with_(constraint_rounds=0))
    found = fc.GeometryCheck(sawyer).first_contacts(result.q)
    assert any(r.startswith("self-collision") for r in result.reasons)    # the verdict agrees
    first, second = (name.rsplit("_", 1)[0] for name in (found["self"].first,
                                                         found["self"].second))
    frames = {frame.name for frame in sawyer.model.frames}
    assert first != second and first in frames and second in frames
    free = plan(prior, sawyer, None, prior.mean[0, :3], covariance=False)
    assert fc.GeometryCheck(sawyer).first_contacts(free.q) == {}


def test_completion_and_staying_with_the_skill(jaco, box_closing):
    demos, prior = box_closing
    start = prior.mean[0, :3] + [0.05, 0.03, 0.0]
    free = plan(prior, jaco, None, start, covariance=False)
    ends = demos.positions[:, -1]
    distance, tolerance = fc.end_error(free.ee_path, ends)
    assert distance <= tolerance
    assert fc.END_SPREAD_FACTOR * fc.END_SPREAD_FLOOR <= tolerance
    off = free.ee_path + np.linspace(0.0, 1.0, prior.T)[:, None] * [0.0, 0.1, 0.0]
    distance, tolerance = fc.end_error(off, ends)
    assert distance > tolerance
    assert fc.skill_deviation(prior, demos.positions, free.ee_path, start).max() < fc.TIGHT_SIGMA
    # a 10 cm bump where the demonstrations agree most leaves the skill
    spread = np.linalg.norm(demos.positions - demos.positions.mean(0), axis=2).max(0)
    k = int(np.argmin(spread))
    bump = np.exp(-0.5 * ((np.arange(prior.T) - k) / 5.0) ** 2)[:, None] * [0.0, 0.0, 0.1]
    assert fc.skill_deviation(prior, demos.positions, free.ee_path + bump,
                              start).max() > fc.TIGHT_SIGMA


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_rotation_from_start_of_a_wrist_roll(arms, name):
    """Turning only the last joint by a turns the hand by |a| about that joint's axis."""
    robot = arms[name]
    q = np.repeat(robot.random_configuration(np.random.default_rng(5))[None], 8, axis=0)
    q[:, -1] += np.linspace(0.0, -0.7, 8)
    np.testing.assert_allclose(fc.rotation_from_start(robot, q), np.linspace(0.0, 0.7, 8), atol=1e-9)
    assert fc.joint_path_length(q) == pytest.approx(0.7)


# ------------------------------------------------------------------ the benchmark's tally
def _plan_record(success: bool, failed: dict | None = None, joint_path: float = 2.0,
                 rotation: float = 30.0, duration: float = 4.0, seconds: float = 0.1) -> dict:
    return {"success": success, "failed": failed or {}, "joint_path": joint_path,
            "rotation_deg": rotation, "toppra_s": duration, "plan_s": seconds,
            "mean_end_error_m": 0.001, "leaves_skill": False}


def test_summary_counts_completable_completed_and_false_successes():
    import bench_fidelity as bench
    free = _plan_record(True)
    records = [
        {"id": "a", "obstacle": _plan_record(True, joint_path=3.0, rotation=40.0), "free": free,
         "oracle": None},                                              # completed
        {"id": "b", "obstacle": _plan_record(True, {"completion": "end 90 mm"}, joint_path=5.0,
                                             rotation=70.0, duration=8.0, seconds=0.4),
         "free": free, "oracle": {"completable": True}},               # false success
        {"id": "c", "obstacle": _plan_record(False), "free": free,
         "oracle": {"completable": False}},                            # not completable
        {"id": "d", "obstacle": _plan_record(False), "free": free,
         "oracle": {"completable": True}},                             # completable, missed
    ]
    s = bench.summarize(records)
    assert (s["problems"], s["completable"], s["completed"], s["false"]) == (4, 3, 1, 1)
    assert s["false_kinds"] == {"completion": 1} and s["scored"] == 2
    assert s["joint_path"][0] == pytest.approx(2.0)          # median of 1.5x and 2.5x
    assert s["added_rotation"][0] == pytest.approx(25.0)     # median of 10 and 40 deg
    assert s["plan_time"][0] == pytest.approx(2.5)
    # completed 1/3 with a false success; path 2.0x; rotation 25 deg; TOPP-RA 1.5x; time 2.5x
    assert [ok for _, ok in bench.targets(s)] == [False, False, False, True, True]
    good = bench.summarize(records[:1])                      # 1/1, path 1.5x, 10 deg, 1x, 1x
    assert [ok for _, ok in bench.targets(good)] == [True] * 5


def test_problem_key_ignores_the_id_and_the_command_line_refuses_bad_options(capsys):
    import bench_fidelity as bench
    data = {"id": "x", "meta": {"index": 1}, "start": [0.1, 0.2, 0.3], "goal": None}
    assert bench.problem_key(data) == bench.problem_key({**data, "id": "y", "meta": {}})
    assert bench.problem_key(data) != bench.problem_key({**data, "start": [0.1, 0.2, 0.31]})
    assert bench.main(["--workers", "0"]) == 2
    assert bench.main(["--arms", "ur5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "--workers" in err[0] and "--arms" in err[1]


def test_the_demonstrations_stay_with_the_skill(box_closing):
    """Each demonstration, judged from its own start, stays with the skill and completes it."""
    demos, prior = box_closing
    largest = [fc.skill_deviation(prior, demos.positions, path, path[0]).max()
               for path in demos.positions]
    assert max(largest) < fc.TIGHT_SIGMA
    assert np.median(largest) > 0.2          # the unit is the demonstrations' spread
    for path in demos.positions:
        distance, tolerance = fc.end_error(path, demos.positions[:, -1])
        assert distance <= tolerance
