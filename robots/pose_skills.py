"""Seeded synthetic skills whose orientation is the skill, demonstrated in joint space on any arm.

A skill is a few joint-space keyframes of the arm, found by pose inverse kinematics
(:func:`robots.ik.solve_pose_ik`) from end-effector poses placed in the arm's own workspace:

* ``"pouring"``: reach from a start beside and above the cup to above it, the wrist's last
  joint axis horizontal and pointing away from the base, then tilt the wrist 90 degrees about
  that axis (the last joint turns a quarter turn): the pour.
* ``"inserting"``: reach to a pre-insertion pose 12 cm above the hole with the last joint axis
  (the flange's normal) pointing straight down, then insert 10 cm along that fixed tool axis
  without turning (keyframes every 2 cm of the insertion).

The place of the skill (the cup or the hole) is 45 degrees to the right of the base's x axis,
at the first of :data:`PLACES` (distances and heights in fractions of the arm's stretched
length) where the arm reaches the skill's nominal keyframes; the start and midway keyframes
are solved by continuation from the place (one branch of the arm). Each demonstration perturbs
the start (3 cm, 10 degrees), the place (pouring 5 mm, inserting 1 mm) and the tilt (pouring
90 +- 4 degrees) with seeded Gaussian noise, solved from the nominal keyframes, passes a
shape-preserving cubic (PCHIP) through its keyframes in joint space (knots at fixed phases) and
traverses it with the minimum-jerk timing of :func:`scenes.synthetic.minimum_jerk_phase`,
warped per demonstration (warp uniform in [-0.1, 0.1]). A draw that branch cannot reach, or whose motion leaves the joint limits or
touches the arm itself at any state or between states (the robot's self-collision check,
:func:`robots.self_collision.self_collision_report`), is drawn again: every demonstration is
one the arm can make, from a start the planner accepts, and the same seed gives the same set.
The hand's positions, velocities and rotations are the arm's forward kinematics of that joint
motion (velocities J(q) qdot, exact).
"""
from __future__ import annotations

from typing import Any

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.spatial.transform import Rotation

from scenes import Demonstrations, UnknownSkillError
from scenes.quaternions import quaternions_from_matrices
from scenes.synthetic import minimum_jerk_phase
from skillplan.validation import as_count, as_positive, as_seed

from .errors import RobotError
from .ik import solve_pose_ik
from .robot import Robot
from .self_collision import self_collision_report

#: Names of the synthetic pose skills.
POSE_SKILLS: tuple[str, ...] = ("pouring", "inserting")

#: largest timing warp (dimensionless) of a demonstration
TIMING = 0.1
#: steps of the continuation from the place to the start (_SkillFrame.start)
CONTINUATION = 6
#: random starts of the pose IK of a nominal keyframe
RESTARTS = 8
#: draws of a demonstration's variation before giving up (a draw the arm cannot reach on
#: the nominal keyframes' branch, or whose motion leaves the limits or touches itself, is
#: drawn again)
REDRAWS = 20
#: where a skill may happen: (horizontal distance, height) as fractions of the arm's stretched
#: length, tried in this order (45 degrees to the right of the base's x axis)
PLACES = ((0.4, 0.25), (0.3, 0.2), (0.45, 0.15), (0.35, 0.1), (0.25, 0.25), (0.45, 0.3))
#: the insertion's depth and its pre-insertion height above the hole [m]
INSERT_DEPTH, INSERT_HEIGHT = 0.10, 0.12


def make_pose_demonstrations(robot: Robot, skill: str, num_demos: int = 6, num_points: int = 200,
                             dt: float = 0.05, seed: int = 0) -> Demonstrations:
    """``num_demos`` seeded demonstrations of ``skill`` (one of POSE_SKILLS) by ``robot``, each
    ``num_points`` steps of ``dt`` s: positions, velocities (M,T,3), orientations (M,T,4)
    quaternions (x, y, z, w) and joint_positions (M,T,n), named ``<skill>_<robot name>``.
    RobotError when the arm cannot reach a keyframe pose (the message names it)."""
    if not isinstance(robot, Robot):
        raise RobotError(f"robot: expected a robots.Robot (robots.load_robot('jaco') or "
                         f"Robot.from_urdf(...)), got {type(robot).__name__}")
    if not isinstance(skill, str) or skill not in POSE_SKILLS:
        raise UnknownSkillError(f"skill: unknown {skill!r}; expected one of {list(POSE_SKILLS)}")
    M = as_count(num_demos, "num_demos", 2, RobotError)
    T = as_count(num_points, "num_points", 4, RobotError)
    step = as_positive(dt, "dt", RobotError)
    rng = np.random.default_rng(as_seed(seed, "seed", RobotError))
    frame = _SkillFrame(robot, skill)
    tau = np.linspace(0.0, 1.0, T)
    duration = (T - 1) * step
    q = np.empty((M, T, robot.n))
    qdot = np.empty_like(q)
    for m in range(M):
        problem = None
        for _ in range(REDRAWS):          # a draw the arm cannot make is drawn again
            try:
                q[m], qdot[m] = _motion(frame, rng, tau, duration)
                break
            except RobotError as exc:
                problem = exc
        else:
            raise RobotError(f"{robot.name} {skill}: demonstration {m}: {REDRAWS} draws out of "
                             f"reach, out of the joint limits or in self-collision; the last: "
                             f"{problem}")
    kinematics = robot.ee_kinematics(q, qdot, jacobians=False)
    rotations, _ = robot.ee_rotation(q)
    return Demonstrations(kinematics.position, kinematics.velocity, tau * duration, None,
                          f"{skill}_{robot.name}", joint_positions=q, joint_names=robot.joint_names,
                          orientations=quaternions_from_matrices(rotations, "rotations", RobotError))


def _motion(frame: _SkillFrame, rng: np.random.Generator, tau: np.ndarray,
            duration: float) -> tuple[np.ndarray, np.ndarray]:
    """One demonstration's joint positions and velocities (T, n) at phases ``tau`` (T,) over
    ``duration`` [s]: seeded keyframes through a PCHIP path, timed by a warped minimum-jerk
    phase. RobotError when a keyframe is out of reach, or when the motion leaves the joint
    limits or touches itself anywhere (:func:`robots.self_collision.self_collision_report`,
    continuous between samples; the message names the state and the links)."""
    knots, keyframes = frame.keyframes(frame, rng)
    path = PchipInterpolator(knots, keyframes, axis=0)
    s, ds = minimum_jerk_phase(tau, rng.uniform(-TIMING, TIMING))
    q = path(s)
    robot = frame.robot
    outside = ~np.asarray(robot.within_limits(q))
    if outside.any():
        raise RobotError(f"{robot.name}: the motion leaves the joint limits at state "
                         f"{int(np.argmax(outside))}")
    # collision and depth are exact at any tolerance; 1 cm spares the exact mesh queries of a
    # clear motion (robots.self_collision_report)
    own = self_collision_report(robot, q, tolerance=0.01)
    if own.collision:
        raise RobotError(f"{robot.name}: the motion is in {own.reason}")
    return q, path(s, 1) * (ds / duration)[:, None]


def _noise(rng: np.random.Generator | None, sigma: float, size: int | None = 3) -> Any:
    """Seeded Gaussian noise of ``sigma``, zero for the nominal demonstration (rng None)."""
    if rng is None:
        return 0.0 if size is None else np.zeros(size)
    return rng.normal(0.0, sigma, size)


class _SkillFrame:
    """Where ``skill`` happens on ``robot``: the place (3,) [m] (the first of PLACES the arm
    reaches the skill's nominal keyframes at), the unit vectors ``out`` (horizontal, from the
    base towards the place) and ``up``, the last joint's axis in the tool frame (``roll``), a
    tool axis across it (``across``), and the nominal keyframes (K, n) that seed every
    demonstration's (one branch of the arm for all)."""

    def __init__(self, robot: Robot, skill: str):
        self.robot = robot
        self.home = robot.neutral_configuration()
        points = robot.frame_positions(self.home)
        length = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
        self.out = np.array([np.cos(-np.pi / 4), np.sin(-np.pi / 4), 0.0])
        self.up = np.array([0.0, 0.0, 1.0])
        rotation, axes = robot.ee_rotation(self.home, jacobians=True)
        self.roll = rotation.T @ axes[:, -1]
        self.roll /= np.linalg.norm(self.roll)
        other = np.eye(3)[int(np.argmin(np.abs(self.roll)))]
        self.across = np.cross(self.roll, other)
        self.across /= np.linalg.norm(self.across)
        self.keyframes = _KEYFRAMES[skill]
        problems = []
        for radius, height in PLACES:
            self.place = length * (radius * self.out + height * self.up)
            try:
                self.knots, self.nominal = self.keyframes(self, None)
                return
            except RobotError as exc:
                problems.append(str(exc))
        raise RobotError(f"{robot.name}: no place for {skill!r} in its reach; tried {len(PLACES)}: "
                         f"{problems[0]} ...")

    def turned(self, roll_to: np.ndarray, across_to: np.ndarray) -> np.ndarray:
        """The hand's rotation (3, 3) taking the tool's roll axis to ``roll_to`` and its
        ``across`` axis to ``across_to`` (base frame; made perpendicular)."""
        rotation, _ = Rotation.align_vectors([roll_to, across_to], [self.roll, self.across],
                                             weights=[np.inf, 1.0])
        return rotation.as_matrix()

    def solve(self, position: np.ndarray, rotation: np.ndarray, k: int | None, rng: Any,
              what: str, seed: np.ndarray | None = None) -> np.ndarray:
        """Joint values (n,) of keyframe ``k``'s pose, from the first seed that reaches it: for a
        demonstration (``rng`` given) the nominal keyframe k, then ``seed`` (its branch); for
        the nominal keyframes ``seed`` (the neighbouring keyframe) or, for the first one solved
        (no seed), the position IK's solution and RESTARTS configurations drawn with seed 0.
        RobotError naming ``what`` if none does."""
        seeds = [] if rng is None or k is None else [self.nominal[k]]
        if seed is not None:
            seeds.append(seed)
        if rng is None and seed is None:
            draws = np.random.default_rng(0)
            seeds.extend([self.robot.ik(position, seed=self.home).q] + [
                self.robot.random_configuration(draws) for _ in range(RESTARTS)])
        for start in seeds:
            result = solve_pose_ik(self.robot, position, rotation, start, tol=1e-6, angle_tol=1e-5)
            if result.success:
                return result.q
        raise RobotError(f"{self.robot.name}: the {what} pose at {np.round(position, 3).tolist()} m "
                         f"is out of reach ({result.position_error * 1e3:.1f} mm, "
                         f"{np.degrees(result.angle_error):.1f} deg from it)")

    def start(self, rotation: np.ndarray, place: np.ndarray, rng: Any,
              seed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Keyframes 0 and 1, a start and a midway configuration: the start 15 cm in from the
        place, 15 cm to the side and 12 cm up (3 cm noise), the hand turned 30 degrees about the
        vertical (10 degrees noise); midway halfway, lifted 5 cm. Solved by continuation from
        ``seed`` (the configuration at the place) along CONTINUATION poses from the place to the
        start, so the arm stays on the seed's branch (a 7-joint arm's elbow would drift)."""
        side = np.cross(self.up, self.out)
        position = place - 0.15 * self.out + 0.15 * side + 0.12 * self.up + _noise(rng, 0.03)
        turn = Rotation.from_rotvec(np.radians(30.0) * self.up + _noise(rng, np.radians(10.0)))
        ends = Rotation.from_matrix(np.stack([rotation, (turn * Rotation.from_matrix(rotation)).as_matrix()]))
        q, solved = seed, {}
        for s in np.linspace(0.0, 1.0, CONTINUATION + 1)[1:]:
            target = place + s * (position - place) + 0.2 * s * (1.0 - s) * self.up
            turned = (ends[0] * (ends[0].inv() * ends[1]) ** s).as_matrix()
            q = self.solve(target, turned, None, None, f"start ({s:.0%} of the way)", q)
            solved[float(s)] = q
        return solved[1.0], solved[0.5]


def _pouring(frame: _SkillFrame, rng: Any) -> tuple[np.ndarray, np.ndarray]:
    """Knots (K,) and joint keyframes (K, n) of one pouring demonstration (rng None: nominal)."""
    place = frame.place + _noise(rng, 0.005)
    upright = frame.turned(frame.out, -frame.up)
    q_pre = frame.solve(place, upright, 2, rng, "pre-pour")
    q_start, q_middle = frame.start(upright, place, rng, q_pre)
    tilt = np.radians(90.0 + _noise(rng, 4.0, None))
    q_pour = q_pre.copy()
    q_pour[-1] += tilt if q_pre[-1] + tilt <= frame.robot.upper_limits[-1] else -tilt
    if not frame.robot.within_limits(q_pour):
        raise RobotError(f"{frame.robot.name}: the wrist cannot tilt 90 deg from the pre-pour pose "
                         f"(last joint {q_pre[-1]:.2f} rad, limits {frame.robot.lower_limits[-1]:.2f}"
                         f"..{frame.robot.upper_limits[-1]:.2f})")
    return np.array([0.0, 0.35, 0.7, 1.0]), np.stack([q_start, q_middle, q_pre, q_pour])


def _inserting(frame: _SkillFrame, rng: Any) -> tuple[np.ndarray, np.ndarray]:
    """Knots (K,) and joint keyframes (K, n) of one inserting demonstration (rng None: nominal)."""
    hole = frame.place + _noise(rng, 0.001)
    down = frame.turned(-frame.up, frame.out)
    q_pre = frame.solve(hole + INSERT_HEIGHT * frame.up, down, 2, rng, "pre-insertion")
    q_start, q_middle = frame.start(down, hole + INSERT_HEIGHT * frame.up, rng, q_pre)
    keyframes = [q_start, q_middle, q_pre]
    depths = np.linspace(0.0, INSERT_DEPTH, 6)[1:]
    for k, depth in enumerate(depths, start=3):
        keyframes.append(frame.solve(hole + (INSERT_HEIGHT - depth) * frame.up, down, k, rng,
                                     f"insertion ({depth * 100:.0f} cm)", keyframes[-1]))
    knots = np.concatenate([[0.0, 0.3, 0.6], 0.6 + 0.4 * depths / INSERT_DEPTH])
    return knots, np.stack(keyframes)


_KEYFRAMES: dict[str, Any] = {"pouring": _pouring, "inserting": _inserting}
