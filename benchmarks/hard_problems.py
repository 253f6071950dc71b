"""Problem families of the fidelity benchmark beyond its default one (issue 27): scenes harder
than :func:`clamp.problem_sets.scene_benchmark` makes, as plain problem dicts
(``bench_fidelity`` plans and judges them; nothing here plans).

- ``hard``: per arm, skill k % 4 of :data:`HARD_SKILLS` (the recorded box_closing, read from
  the shared data sets when present, translated by :data:`SAWYER_SHIFT` for the Sawyer as the
  regression tests do; the synthetic reach_from_above, pick_place, curved_reach; 6 demos, seed
  0, 250 states); start = the demonstrations' mean start moved 5-15 cm in a uniformly random
  direction (drawn again while out of the arm's reach); 1-3 boxes, edges 4-12 cm, each
  centred in the 3 cm neighbourhood of a point of the prior's mean path at 25-90 % of it
  (uniform in the ball: the box overlaps the neighbourhood and mostly covers the path; a
  box is drawn again while it comes within 2 cm of the mean end point: a skill whose end lies
  in a box is impossible by construction and teaches nothing). Boxes may cover the start:
  such problems carry ``meta["start_blocked"]`` (the start configuration, the planner's IK of
  the start position, touches a box on the URDF geometry, Pinocchio + coal) and are reported
  apart, as honest failures.
- ``handwriting``: the 13 LASA shapes of ``lasa_handwriting_dev.npz`` written on a table by
  the Jaco (x = 0.42 + 0.004 u, y = -0.32 + 0.004 v, z = 0.12 m; each demonstration resampled
  to 200 states on its normalised time, the mean duration for the time step), each
  demonstration held out in turn: the prior learned from the 6 others, the start the held-out
  demonstration's first point, a 4 x 4 x 8 cm block standing on the table top (z = 0.08 m,
  4 cm below the writing height, so it spans z 0.08-0.16 m) centred on the held-out
  demonstration's path at half its duration.
- ``pose`` (issue 37): the synthetic orientation skills of ``robots.pose_skills`` (skill k % 2
  of :data:`POSE_SKILLS`, pouring and inserting; 6 joint-space demonstrations through
  keyframes, seed 0, 200 states), learned as a pose prior; the start is a configuration (the
  start pose is the arm's): the hand 5-15 cm from the demonstrations' mean start in a uniformly
  random direction, turned as they start (their mean start rotation turned by up to their
  start spread about a random axis), by pose IK seeded with the first demonstration's start
  configurations of the demonstrations (drawn again while none converges clear of
  self-collision); 1-3 boxes as in ``hard``, the set drawn again (up to 20 times) while it
  touches the start configuration (on the Jaco the arm stays near the skill's short path: 3 of
  the first 4 starts touched a box otherwise). A
  demonstration in self-collision anywhere on its path (URDF geometry, Pinocchio + coal) is
  left out of the skill with a logged warning.

Seed 0, 200 problems per arm, as ``bench_fidelity`` measured them (clamp c3e6427): the start
touches a box in 39 Jaco / 60 Sawyer problems; the Jaco's 161 others are all completable, the
Sawyer's only 24 of 140 (box_closing 5 / 49, reach_from_above 7 / 19, pick_place 10 / 36,
curved_reach 2 / 36: every free plan passes the checks, but no plan of the oracle's 20
restarts around the boxes stays in the skill's tube and completes it). Handwriting: the block
touches 8 of the 91 starts; the 83 others are all completable.

A problem dict: ``id``, ``family``, ``prior`` (a spec :func:`load_skill` reads), ``robot``
``{"name": arm}``, ``scene`` (``scenes.Scene.to_dict``), ``start`` (3,) [m] (``pose``: the
start configuration (n,) [rad]), ``goal`` (3,)
[m] (the prior's last mean position: for the oracle only, the planner gets no goal), ``meta``
(skill, index, start_blocked).
"""
from __future__ import annotations

import logging
import os
from collections.abc import Iterator
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger("benchmarks.hard_problems")

HARD_SKILLS = ("box_closing", "reach_from_above", "pick_place", "curved_reach")
SAWYER_SHIFT = (0.3, 0.0, 0.2)       # tests/regression/cases.py: box_closing on the Sawyer
LASA_FILE = "lasa_handwriting_dev.npz"
LASA_ORIGIN = (0.42, -0.32, 0.12)    # [m] where the set's origin (the shapes' end) is written
LASA_SCALE = 0.004                   # [m per set unit]
LASA_STATES = 200
TABLE_TOP = 0.08                     # [m] the table surface under the writing plane
BLOCK_SIZE = (0.04, 0.04, 0.08)      # [m] the block standing on the table
NEIGHBOURHOOD = 0.03                 # [m] a hard box overlaps this neighbourhood of the path
GOAL_CLEAR = 0.02                    # [m] a hard box keeps this far from the mean end point
POSE_SKILLS = ("pouring", "inserting")
POSE_STATES = 200
BOX_REDRAWS = 20                     # pose: box sets drawn while they touch the start


def datasets_folder() -> Path:
    """$SKILLPLAN_DATASETS, else ../shared/datasets beside this checkout."""
    env = os.environ.get("SKILLPLAN_DATASETS")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "shared" / "datasets"


def has_recorded_box_closing() -> bool:
    return (datasets_folder() / "box_closing.mat").is_file()


# ------------------------------------------------------------------ skills
def lasa_demonstrations(shape: str) -> Any:
    """The 7 demonstrations of a LASA ``shape`` on the Jaco's table (module docstring) as
    ``scenes.Demonstrations`` (7, 200, 3), time step = mean duration / 199 [s]."""
    from scenes import Demonstrations
    with np.load(datasets_folder() / LASA_FILE) as data:
        pos, stamps = np.asarray(data[f"{shape}__pos"], float), np.asarray(data[f"{shape}__t"], float)
    phase = np.linspace(0.0, 1.0, LASA_STATES)
    dt = float(np.mean(stamps[:, -1] - stamps[:, 0])) / (LASA_STATES - 1)
    out = np.empty((len(pos), LASA_STATES, 3))
    for m, (uv, t) in enumerate(zip(pos, stamps)):
        s = (t - t[0]) / (t[-1] - t[0])
        out[m, :, 0] = LASA_ORIGIN[0] + LASA_SCALE * np.interp(phase, s, uv[:, 0])
        out[m, :, 1] = LASA_ORIGIN[1] + LASA_SCALE * np.interp(phase, s, uv[:, 1])
        out[m, :, 2] = LASA_ORIGIN[2]
    velocities = np.gradient(out, dt, axis=1)
    return Demonstrations(out, velocities, np.arange(LASA_STATES) * dt, None, f"lasa_{shape}")


def lasa_shapes() -> list[str]:
    with np.load(datasets_folder() / LASA_FILE) as data:
        return sorted(k[:-5] for k in data.files if k.endswith("__pos"))


@lru_cache(maxsize=None)
def _load_skill(key: str) -> tuple[Any, np.ndarray, np.ndarray]:
    import json

    from clamp import learn_prior
    from scenes import Demonstrations, load_demonstrations, make_demonstrations
    spec = json.loads(key)
    source = spec.get("source", "synthetic")
    if source == "recorded":
        demos = load_demonstrations(datasets_folder() / f"{spec['skill']}.mat")
        if any(spec.get("shift", (0, 0, 0))):
            demos = demos.translated(np.asarray(spec["shift"], float))
        held = None
    elif source == "pose":
        demos = pose_demonstrations(spec)
        held = None
    elif source == "lasa":
        every = lasa_demonstrations(spec["shape"])
        keep = [m for m in range(len(every.positions)) if m != spec["held_out"]]
        held = every.positions[spec["held_out"]]
        demos = Demonstrations(every.positions[keep], every.velocities[keep], every.time, None,
                               every.name)
    else:
        demos = make_demonstrations(spec["skill"], num_demos=spec["num_demos"],
                                    num_points=spec["num_points"], seed=spec["seed"])
        held = None
    return learn_prior(demos), np.asarray(demos.positions), held


def pose_demonstrations(spec: dict[str, Any]) -> Any:
    """The demonstrations of a ``pose`` spec (``robots.pose_skills``; module docstring), those
    in self-collision left out (logged); at least 2 must stay."""
    import json
    return _pose_demonstrations(json.dumps(spec, sort_keys=True))


@lru_cache(maxsize=None)
def _pose_demonstrations(key: str) -> Any:
    import json

    import fidelity_checks as checks
    from robots import load_robot
    from robots.pose_skills import make_pose_demonstrations
    from scenes import Demonstrations
    spec = json.loads(key)
    robot = load_robot(spec["robot"])
    demos = make_pose_demonstrations(robot, spec["skill"], num_demos=spec["num_demos"],
                                     num_points=spec["num_points"], seed=spec["seed"])
    check = checks.GeometryCheck(robot)
    keep = []
    for m, q in enumerate(demos.joint_positions):
        contact = check.first_contacts(q, per_segment=1).get("self")
        if contact is None:
            keep.append(m)
        else:
            log.warning("pose skill %s on the %s: demonstration %d left out, in self-collision "
                        "(%s)", spec["skill"], spec["robot"], m, contact)
    if len(keep) < 2:
        raise RuntimeError(f"pose skill {spec['skill']} on the {spec['robot']}: only {len(keep)} "
                           f"of {demos.M} demonstrations free of self-collision")
    if len(keep) == demos.M:
        return demos
    return Demonstrations(demos.positions[keep], demos.velocities[keep], demos.time, None,
                          demos.name, joint_positions=demos.joint_positions[keep],
                          joint_names=demos.joint_names, orientations=demos.orientations[keep])


def load_skill(spec: dict[str, Any]) -> tuple[Any, np.ndarray]:
    """The prior a problem's ``prior`` spec names and its demonstrations' positions (M, T, 3)
    [m] (learned once per process)."""
    import json
    prior, demos, _ = _load_skill(json.dumps(spec, sort_keys=True))
    return prior, demos


def held_out(spec: dict[str, Any]) -> np.ndarray | None:
    """The held-out LASA demonstration (T, 3) [m] of a handwriting spec, else None."""
    import json
    return _load_skill(json.dumps(spec, sort_keys=True))[2]


# ------------------------------------------------------------------ start checks
def start_configuration(robot: Any, start: np.ndarray) -> tuple[np.ndarray, float]:
    """The planner's start configuration for an end-effector start (its IK, as
    ``clamp.request.make_request`` solves it at the default tolerances) and the IK error [m]."""
    ik = robot.ik(np.asarray(start, float), tol=1e-4)
    return np.asarray(ik.q, float), float(ik.error)


def start_blocked(robot: Any, obstacles: list, q_start: np.ndarray) -> bool:
    """Whether the configuration q_start (n,) touches an obstacle (URDF geometry, coal)."""
    import fidelity_checks as checks
    check = checks.GeometryCheck(robot, obstacles)
    kinds = np.array(check.kinds)
    return bool(np.any(check.colliding_pairs(q_start) & (kinds == "obstacle")))


# ------------------------------------------------------------------ families
def _problem(pid: str, family: str, spec: dict, arm: str, obstacles: list, start: np.ndarray,
             goal: np.ndarray, meta: dict) -> dict[str, Any]:
    from scenes import Scene
    return {"id": pid, "family": family, "prior": spec, "robot": {"name": arm},
            "scene": Scene(obstacles).to_dict(), "start": [float(v) for v in start],
            "goal": [float(v) for v in goal], "meta": meta}


def _hard_spec(skill: str, arm: str) -> dict[str, Any]:
    if skill == "box_closing" and has_recorded_box_closing():
        return {"source": "recorded", "skill": "box_closing",
                "shift": list(SAWYER_SHIFT) if arm == "sawyer" else [0.0, 0.0, 0.0]}
    return {"skill": skill, "seed": 0, "num_demos": 6, "num_points": 250}


def _hard_box(rng: np.random.Generator, path: np.ndarray, goal: np.ndarray) -> Any:
    """A box (edges 4-12 cm) centred within NEIGHBOURHOOD of a point of ``path`` (T, 3) at
    25-90 % of it, GOAL_CLEAR from goal (the point drawn again when its boxes come too near)."""
    from scenes import Box
    T = len(path)
    for attempt in range(1000):
        if attempt % 20 == 0:
            point = path[rng.integers(int(0.25 * T), int(0.9 * T) + 1)]
        size = rng.uniform(0.04, 0.12, size=3)
        direction = rng.normal(size=3)
        centre = point + direction / np.linalg.norm(direction) * NEIGHBOURHOOD * rng.random() ** (1 / 3)
        box = Box(centre, size)
        if box.distance(goal[None])[0] >= GOAL_CLEAR:
            return box
    raise RuntimeError("no box overlaps the path point and keeps the goal clear")


def _arm_and_draws(arm: str, seed: int, family: int) -> tuple[Any, np.random.Generator]:
    """The arm's robot and the family's random draws (seeded by ``seed`` and the family's own
    number, so two families of one seed draw differently)."""
    from robots import load_robot
    return load_robot(arm), np.random.default_rng([seed, family])


def _cycled(skills: tuple[str, ...], count: int) -> Iterator[tuple[int, str]]:
    """(index, skill) of ``count`` problems taking the skills in turn."""
    return ((k, skills[k % len(skills)]) for k in range(count))


def hard_problems(count: int, arm: str, seed: int = 0,
                  skills: tuple[str, ...] = HARD_SKILLS) -> list[dict[str, Any]]:
    """``count`` seeded problems of the ``hard`` family for ``arm`` (module docstring)."""
    robot, rng = _arm_and_draws(arm, seed, 27)
    out = []
    for k, skill in _cycled(skills, count):
        spec = _hard_spec(skill, arm)
        prior, _ = load_skill(spec)
        path = np.asarray(prior.mean)[:, :3]
        goal = path[-1]
        for _ in range(100):              # a start the arm reaches
            direction = rng.normal(size=3)
            start = path[0] + direction / np.linalg.norm(direction) * rng.uniform(0.05, 0.15)
            q_start, error = start_configuration(robot, start)
            if error <= 1e-3:
                break
        boxes = [_hard_box(rng, path, goal) for _ in range(rng.integers(1, 4))]
        meta = {"skill": skill, "index": k, "seed": seed,
                "start_blocked": start_blocked(robot, boxes, q_start)}
        out.append(_problem(f"hard/{arm}/{k:04d}", "hard", spec, arm, boxes, start, goal, meta))
    return out


def handwriting_problems(shapes: list[str] | None = None, arm: str = "jaco"
                         ) -> list[dict[str, Any]]:
    """The ``handwriting`` family (module docstring) for ``shapes`` (None: all 13)."""
    from robots import load_robot
    from scenes import Box
    robot = load_robot(arm)
    out = []
    for shape in shapes or lasa_shapes():
        every = lasa_demonstrations(shape)
        for h in range(len(every.positions)):
            spec = {"source": "lasa", "shape": shape, "held_out": h, "num_points": LASA_STATES}
            prior, _ = load_skill(spec)
            demo = every.positions[h]
            middle = demo[len(demo) // 2]
            block = Box([middle[0], middle[1], TABLE_TOP + BLOCK_SIZE[2] / 2], list(BLOCK_SIZE))
            start = demo[0]
            q_start, _ = start_configuration(robot, start)
            meta = {"skill": f"lasa_{shape}", "index": len(out), "held_out": h,
                    "start_blocked": start_blocked(robot, [block], q_start)}
            out.append(_problem(f"handwriting/{arm}/{shape}/{h}", "handwriting", spec, arm,
                                [block], start, np.asarray(prior.mean)[-1, :3], meta))
    return out


def _pose_start(robot: Any, demos: Any, rng: np.random.Generator) -> np.ndarray:
    """A start configuration of the ``pose`` family (module docstring): the hand 5-15 cm from
    the demonstrations' mean start, turned as they start (their mean start rotation turned by
    up to their start spread)."""
    from scipy.spatial.transform import Rotation

    import fidelity_checks as checks
    import fidelity_orientation as orientation
    from robots.ik import solve_pose_ik
    self_check = checks.GeometryCheck(robot)
    rotations = orientation.hand_rotations(robot, demos.joint_positions[:, 0])     # (M, 3, 3)
    mean = Rotation.from_matrix(rotations).mean()
    spread = float(orientation.geodesic_angle(mean.as_matrix()[None], rotations).max())
    centre = np.asarray(demos.positions)[:, 0].mean(axis=0)
    for _ in range(100):
        direction = rng.normal(size=3)
        position = centre + direction / np.linalg.norm(direction) * rng.uniform(0.05, 0.15)
        axis = rng.normal(size=3)
        turn = Rotation.from_rotvec(axis / np.linalg.norm(axis) * rng.uniform(0.0, spread))
        rotation = (turn * mean).as_matrix()
        for seed in demos.joint_positions[:, 0]:        # the demonstrations' branch
            result = solve_pose_ik(robot, position, rotation, seed, tol=1e-6, angle_tol=1e-5)
            if (result.success and robot.within_limits(result.q)
                    and not self_check.colliding_pairs(result.q).any()):
                return np.asarray(result.q, float)
    raise RuntimeError(f"no start pose of the {robot.name} reached clear of self-collision in "
                       f"100 draws")


def pose_problems(count: int, arm: str, seed: int = 0,
                  skills: tuple[str, ...] = POSE_SKILLS) -> list[dict[str, Any]]:
    """``count`` seeded problems of the ``pose`` family for ``arm`` (module docstring)."""
    robot, rng = _arm_and_draws(arm, seed, 37)
    out = []
    for k, skill in _cycled(skills, count):
        spec = {"source": "pose", "skill": skill, "robot": arm, "seed": 0, "num_demos": 6,
                "num_points": POSE_STATES}
        prior, _ = load_skill(spec)
        path = np.asarray(prior.mean)[:, :3]
        goal = path[-1]
        q_start = _pose_start(robot, pose_demonstrations(spec), rng)
        for _ in range(BOX_REDRAWS):      # boxes that leave the start configuration clear
            boxes = [_hard_box(rng, path, goal) for _ in range(rng.integers(1, 4))]
            blocked = start_blocked(robot, boxes, q_start)
            if not blocked:
                break
        meta = {"skill": skill, "index": k, "seed": seed, "start_blocked": blocked}
        out.append(_problem(f"pose/{arm}/{k:04d}", "pose", spec, arm, boxes, q_start, goal, meta))
    return out
