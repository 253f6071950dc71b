"""Leave-one-out reproduction of demonstrated skills: CLAMP against TLGC, ProMP, DMP and GMR
(issues 28 and 37), of positions and, where the demonstrations have them, hand orientations.

For every data set and every demonstration k: learn from all demonstrations but k, reproduce
from demonstration k's start ("start" setting) or from its start to its end ("goal" setting)
on k's time steps, and compare with demonstration k. Figures are means over the folds. On
data with orientations the start and the end are poses (position and quaternion).

Methods
  CLAMP arm   clamp.plan(clamp.learn_prior(train), robots.load_robot("jaco"), None, start,
              goal=end or None) with default settings: the end-effector path the arm makes
              (its rotation by forward kinematics, where the prior is a pose prior);
  CLAMP mean  the prior's own conditional mean (clamp.condition_prior on the start, and the
              end in the goal setting): the model without the arm; its rotation
              ``prior.mean_quaternions()`` of the prior conditioned on the start (end) pose,
              where the installed clamp learns pose priors (n/a otherwise);
  TLGC, ProMP, DMP, GMR: the peers, benchmarks/lfd_peers.py (TLGC: position and start
              setting only; on pose data ProMP and GMR model the quaternion's components,
              renormalised, and DMP is movement_primitives' CartesianDMP).

Data (every set expressed in the Jaco2's workspace, metres; figures in that frame)
  box_closing.mat      as recorded (6 demonstrations, T = 250, dt = 0.16 s);
  needle_threading,    TLGC sets without time stamps: scenes.load_demonstrations gives them
  pick_place,          10 s (NOMINAL_DURATION); resampled to 200 states, then scaled by
  synthetic0 .mat      s = min(1, 0.3 m / largest bounding-box side) and centred in the
                       synthetic skills' region (0.30, -0.40, 0.25) (scale printed);
  synthetic skills     scenes.make_demonstrations(skill, 6 demos, 250 states, seed 0);
  LASA (13 shapes)     x = 0.42 + 0.004 u, y = -0.32 + 0.004 v, z = 0.12, each demonstration
                       resampled to 200 states on its normalised time, mean duration
                       (datasets README);
  wiping_rim.npz       6 real demonstrations with position and quaternion, 9-51 s at ~100 Hz,
                       each resampled to 250 states on its normalised time (positions by
                       cubic spline, rotations by slerp), the mean duration; placed by a
                       rigid transform (180 deg about z, the bounding box centred on
                       (0.35, -0.30, 0.30)): every sampled position is in the Jaco's reach;
  pose skills          synthetic skills with orientation (pouring, inserting) demonstrated
                       on the Jaco, robots.pose_skills.make_pose_demonstrations(jaco, skill,
                       6 demos, seed 0) where the installed robots has it (a note otherwise);
                       any Demonstrations with orientations fit (load_sets).

Metrics (reproduction against the held-out demonstration, both on its T time steps;
benchmarks/lfd_metrics.py)
  dtw    mean point distance along the optimal DTW alignment [mm];
  sea    swept error area [cm^2]: the area between the two curves on equal-time points (sum of
         the quadrilaterals' two triangles; planar sets only);
  end    end error [mm];
  vel    velocity RMSE [mm/s], velocities by central differences in time of both paths;
  ori    orientation error [deg]: the mean geodesic angle 2 arccos |<q1, q2>| between the
         rotations of the pairs of the position DTW alignment (pose data only; the target's);
  oeq    the mean geodesic angle at equal times [deg] (pose data only): where the hand turns
         without moving (a pour's tilt: the last 60 of pouring's 200 states turn 69 deg within
         0.1 mm) the position alignment's pairs there are arbitrary, and ori with them
         (ProMP, pouring, fold 0, goal: ori 23.3 deg, oeq 2.2 deg);
  oend   end orientation error [deg] (pose data only);
  fail   CLAMP arm plans with success False (their paths are scored all the same).

Targets printed at the end: whether CLAMP (arm, and its mean) has the lowest orientation error
in every pose cell (set x setting), and, with --anchor FILE (a --record FILE of an earlier
run, e.g. of main), whether every position cell's CLAMP arm DTW is at most 2 % above it.

Run: python benchmarks/bench_lfd.py [--quick] [--sets box_closing lasa wiping_rim ...]
[--workers N] [--record FILE] [--anchor FILE]
(--quick: 2 folds per set, 4 LASA shapes, 2 synthetic skills).

Full run (2 cores, ~170 s CPU), CLAMP arm mean DTW [mm], plain chain -> start shrinkage "auto":
LASA 5.40 -> 4.79 (ProMP 4.90, DMP 5.47), best on 2 -> 6 of 13 shapes per setting; pick_place
start 28.2 -> 31.1, goal 34.5 -> 32.2 (DMP 33.8: now won); box_closing 11.8 / 9.1 -> 12.0 / 9.4,
needle_threading 12.6 / 8.9 -> 13.0 / 10.1 (still won); synthetic0 unchanged (2 training demos:
TLGC 4.4 and DMP 5.7 still win); 0 unsuccessful plans either way.
Then the weight chosen on the leave-one-out error normal to the mean path, w = 1 for 2 demos
and a variance floor on a coordinate the demonstrations share (commit eadd57d): LASA 4.79 / 4.80
-> 4.70 / 4.72, best on 6 -> 9 of 13 shapes per setting (lost: CShape, NShape, Sshape, Zshape
by 0.02-0.45 mm); synthetic0 7.51 / 7.39 -> 5.81 / 5.67 (goal now won, DMP 5.67; start still
TLGC 4.37, whose start is off by up to 6 cm); box_closing 12.07 / 9.45, needle 13.03 / 10.20,
pick_place 31.14 / 32.05, synthetic skills all won; 0 unsuccessful plans; wall 600 s on 2
workers at load 6-9.
Then the response shrunk towards a blend of the spread fade and the demonstrations' own start
gain ("regressed"), weights chosen together by the same leave-one-out error: CLAMP mean LASA
4.65 -> 4.60, best on 9 -> 12 of 13 shapes; CLAMP arm LASA 4.70 / 4.72 -> 4.67 / 4.67, best on
9 -> 9 / 10 of 13 (lost: CShape both, JShape_2 6.37 / 6.36 vs ProMP 6.35, Sshape 4.59 / 4.62
vs DMP 4.55, NShape start 4.51 vs 4.37: the arm's path is 0.05-0.3 mm worse than the prior's
mean there); synthetic skills 0.1-1.1 mm lower (syn:reach_from_above 9.30 -> 8.23,
syn:needle_threading 25.63 -> 24.49); box_closing 12.26 / 9.62, needle 12.90 / 9.74,
pick_place 31.14 / 32.05 (still won); synthetic0 unchanged (5.81 start lost to TLGC 4.37;
goal 5.67 won by < 0.01); 0 unsuccessful plans; wall 481 s on 2 workers at load 5-7.
Then (2026-11-27, second session) the start factor's velocity conditioned on the start (the
graph's optimum is the conditioned prior) and the initial velocity's response to the start
shrunk with the path's, towards none: pick_place 31.14 / 32.05 -> 35.87 / 33.54 (still won:
ProMP 36.30, DMP 33.75; the conditioning alone gave 39.47 at the start, lost: a +0.45 m/s
initial velocity for a 1 cm offset, learned from 3 demonstrations, the arm could not follow);
box_closing 12.26 / 9.62, needle 12.10 / 9.77, synthetic skills all won (within 0.1 mm of
before); LASA 4.67 / 4.67 -> 4.66 / 4.66, best on 9 / 10 -> 9 / 9 of 13 (lost: CShape, JShape_2,
NShape by 0.01 mm, Sshape; the prior's own mean is best on 11: the arm's joint GP keeps its
path 0.05-0.2 mm of DTW off the mean); synthetic0 start still TLGC's (4.37 vs 5.68); 0
unsuccessful plans; wall 578 s on 1 worker at load 3-5.
Then (2026-11-29, issue 37) GMR and the pose sets. --quick on the position sets (load 10-13):
GMR wins syn:box_closing goal (6.25 vs CLAMP arm 7.04 mm) and syn:reach_from_above goal (6.64
vs 6.90), CLAMP arm the other 10 non-LASA cells and 5 of 8 LASA cells; its DTW recorded as
anchors/bench_lfd_quick_5c9c49f.json (clamp as on main f76333e): 1.000x in all 20 cells again,
also with branch pose's clamp. The full run (CPU 427 s): CLAMP arm as before and best in all
20 non-LASA cells, GMR best on 3 / 2 of the 13 LASA shapes (CLAMP arm 11 / 11 -> 8 / 9),
recorded as anchors/bench_lfd_5c9c49f.json. wiping_rim, 6 folds, position-only clamp: orientation error
start / goal ProMP 48.67 / 24.75 deg, CartesianDMP 62.01 / 33.01, GMR 43.17 / 29.89; every
method 100+ mm of DTW (strokes of unequal count on a normalised phase). With branch pose's
clamp (previews, not merged): wiping_rim (6 folds) CLAMP arm 35.13 / 29.26 deg, CLAMP mean
32.12 / 27.37, lowest at the start, ProMP's 24.75 lowest at the goal; posedata's pouring / inserting (6 folds) CLAMP mean lowest at equal times
in all 4 cells, on the DTW pairs all but pouring goal (9.17 vs CartesianDMP 5.80: the tilt
in place); CLAMP arm lowest in 1 of 4 (4 inserting plans start in self-collision by 0.3-0.4
mm at the demonstrations' own recorded start, 4 pouring plans leave the skill's tube).
Then (2026-11-29, issue 37, branch lfdpose) `--sets pose_synthetic wiping_rim`, ori start / goal
[deg], CLAMP arm and mean against the best peer. The pose skills' draws that touch the arm
itself are redrawn (robots.pose_skills; main's set: pouring arm 2.8 / 13.0, inserting arm 7.0 /
7.0: two plans started in self-collision); on the redrawn set, main's clamp -> after: a held pour is learned holding
(the mean drifted 1-6 mm through it, which made the DTW pairs of the tilt arbitrary: 23-25 deg
on 2 of 6 folds); the arm is planned to the goal pose on joint-recorded sets (it was given the
goal position only); a goal rotation's response is capped like a goal position's. pouring
arm 2.33 / 9.84 -> 2.31 / 2.34, mean 2.05 / 10.10 -> 2.31 / 1.94 (CartesianDMP 5.17 / 8.24),
0 of 12 plans unsuccessful (was 2); inserting arm and mean 0.37 / 0.37 (ProMP 1.86 / 1.85; the
arm had 7.0 deg before the redraw); wiping_rim start arm 36.15, mean 32.12 (GMR 43.17), goal
arm 28.74 -> 27.81, mean 27.37 -> 26.02 against ProMP 24.75: the one cell lost (module note in
docs/benchmarks.md). Position cells: priors bit-identical (no held step in those sets).
Then (2026-11-29, issue 37, branch wipegoal) the orientation chain's states follow one branch
of the log map in time (a wiping_rim demonstration passes pi from the others' mean: its 2 pi
jump had cut the chain's start and goal responses) and its start shrinkage judges errors
normal to the mean turn: ori start / goal [deg]: wiping_rim mean 32.12 / 26.02 -> 29.49 /
24.08 (ProMP 48.67 / 24.75: the mean now lowest in every pose cell), arm 36.15 / 27.81 ->
34.87 / 25.66 (the goal cell still ProMP's: the arm's plan is 8-34 deg and 70-106 mm from the
prior's mean per fold, the arm's own tracking; at equal times the arm is lowest, 26.89 vs
27.45); pouring arm 2.31 / 2.34 -> 2.16 / 1.92, mean 2.31 / 1.94 -> 2.16 /
1.56; inserting 0.37 / 0.37 -> 0.33 / 0.32 (arm and mean). Position-only priors bit-identical.
"""
from __future__ import annotations

import argparse
import json
import os
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

import clamp
import lfd_peers
import robots
import scenes
from harness import exit_with_parent, print_environment, shared_demonstrations
from lfd_metrics import dtw_mean, geodesic_angle, orientation_error, swept_area
from scenes.demonstrations import continuous_quaternions, slerp_quaternions

METHODS = ("CLAMP arm", "CLAMP mean", "TLGC", "ProMP", "DMP", "GMR")
RIVALS = ("CLAMP arm", "TLGC", "ProMP", "DMP", "GMR")    # who wins: CLAMP as users run it
PEERS = ("TLGC", "ProMP", "DMP", "GMR")
SETTINGS = ("start", "goal")
METRICS = ("dtw", "sea", "end", "vel", "ori", "oeq", "oend")
SHARED = ("box_closing", "needle_threading", "pick_place", "synthetic0")
POSE_SETS = ("wiping_rim", "pose_synthetic")
REGION_CENTRE = np.array([0.30, -0.40, 0.25])            # the synthetic skills' region
REGION_SIZE = 0.30                                       # largest side of an embedded set [m]
LASA_ORIGIN, LASA_SCALE, LASA_HEIGHT, LASA_STATES = np.array([0.42, -0.32]), 0.004, 0.12, 200
TLGC_STATES = 200
WIPING_STATES = 250
WIPING_TURN = Rotation.from_euler("z", 180.0, degrees=True)   # recording base -> Jaco base
WIPING_CENTRE = np.array([0.35, -0.30, 0.30])            # [m] the placed set's box centre
# where the synthetic skills with orientation are looked for: (module, function), called as
# function(robot, skill, num_demos=6, seed=0) -> Demonstrations with orientations
POSE_SKILLS_SOURCE = ("robots.pose_skills", "make_pose_demonstrations")
POSE_SKILLS = ("pouring", "inserting")
DTW_TOLERANCE = 0.02                                     # target: arm DTW <= 1.02 x anchor
POSE_IK_SEEDS = 4                                        # position IK answers pose_ik starts from


@dataclass
class DataSet:
    """Demonstrations in the Jaco's workspace; group "shared", "synthetic", "lasa" or "pose"."""

    name: str
    demos: scenes.Demonstrations
    group: str
    planar: bool = False
    note: str = ""

    @property
    def pose(self) -> bool:
        """Whether the demonstrations have orientations (the pose cells)."""
        return self.demos.orientations is not None


# ---------------------------------------------------------------------------- data
def _datasets_dir() -> Path:
    if os.environ.get("SKILLPLAN_DATASETS"):
        return Path(os.environ["SKILLPLAN_DATASETS"])
    return Path(__file__).resolve().parents[2] / "shared" / "datasets"


def _embedded(demos: scenes.Demonstrations, name: str) -> tuple[scenes.Demonstrations, str]:
    """A TLGC set resampled to TLGC_STATES and scaled/centred into the workspace region."""
    demos = demos.resample(TLGC_STATES)
    p = demos.positions
    low, high = p.min(axis=(0, 1)), p.max(axis=(0, 1))
    scale = min(1.0, REGION_SIZE / float((high - low).max()))
    moved = (p - 0.5 * (low + high)) * scale + REGION_CENTRE
    out = scenes.Demonstrations(moved, demos.velocities * scale, demos.time, name=name)
    return out, f"scaled x{scale:.3g}, T={TLGC_STATES}, {demos.duration:.3g} s"


def lasa_shapes() -> dict[str, scenes.Demonstrations]:
    """The 13 LASA shapes embedded on the table (datasets README)."""
    path = _datasets_dir() / "lasa_handwriting_dev.npz"
    if not path.is_file():
        print(f"# {path.name} not found: LASA skipped")
        return {}
    out = {}
    with np.load(path) as data:
        for key in sorted(k for k in data.files if k.endswith("__pos")):
            shape = key[:-5]
            pos, stamps = data[key], data[f"{shape}__t"]
            trajectories = [np.column_stack([LASA_ORIGIN + LASA_SCALE * uv,
                                             np.full(len(uv), LASA_HEIGHT)]) for uv in pos]
            out[shape] = scenes.Demonstrations.from_trajectories(
                trajectories, list(stamps), num_points=LASA_STATES, name=shape)
    return out


def wiping_rim() -> scenes.Demonstrations | None:
    """wiping_rim.npz's 6 demonstrations with orientations, resampled to WIPING_STATES on
    their normalised time and placed in the Jaco's workspace (module doc), or None with a
    printed note when the file is absent."""
    path = _datasets_dir() / "wiping_rim.npz"
    if not path.is_file():
        print(f"# {path.name} not found: wiping_rim skipped")
        return None
    with np.load(path) as data:
        count = sum(k.endswith("__pos") for k in data.files)
        recorded = [(data[f"demo{k}__pos"], data[f"demo{k}__quat_xyzw"], data[f"demo{k}__t"])
                    for k in range(count)]
    positions = [WIPING_TURN.apply(p) for p, _, _ in recorded]
    low = np.min([p.min(axis=0) for p in positions], axis=0)
    high = np.max([p.max(axis=0) for p in positions], axis=0)
    positions = [p - 0.5 * (low + high) + WIPING_CENTRE for p in positions]
    duration = float(np.mean([t[-1] - t[0] for _, _, t in recorded]))
    phase = np.linspace(0.0, 1.0, WIPING_STATES)
    time_ = duration * phase
    pos, vel, turns = [], [], []
    for p, (_, q, t) in zip(positions, recorded):
        s = (t - t[0]) / (t[-1] - t[0])
        spline = CubicSpline(s, p, axis=0)
        pos.append(spline(phase))
        vel.append(spline(phase, 1) / duration)
        turns.append(slerp_quaternions(
            s, (WIPING_TURN * Rotation.from_quat(q)).as_quat(), phase))
    return scenes.Demonstrations(np.array(pos), np.array(vel), time_, name="wiping_rim",
                                 orientations=np.array(turns))


def pose_skills() -> dict[str, scenes.Demonstrations]:
    """The synthetic skills with orientation demonstrated on the Jaco, from
    POSE_SKILLS_SOURCE, or none with a note when the installed robots has no such function."""
    import importlib
    module, function = POSE_SKILLS_SOURCE
    try:
        make = getattr(importlib.import_module(module), function)
    except (ImportError, AttributeError):
        print(f"# {module}.{function} not installed: the synthetic pose skills skipped")
        return {}
    jaco = robots.load_robot("jaco")
    return {skill: make(jaco, skill, num_demos=6, seed=0) for skill in POSE_SKILLS}


def load_sets(selected: list[str], quick: bool) -> list[DataSet]:
    sets: list[DataSet] = []
    for name in SHARED:
        if name not in selected:
            continue
        demos = shared_demonstrations(name)
        if demos is None:
            continue
        if name == "box_closing":
            sets.append(DataSet(name, demos, "shared", note="as recorded"))
        else:
            embedded, note = _embedded(demos, name)
            sets.append(DataSet(name, embedded, "shared", note=note))
    if "synthetic" in selected:
        for skill in scenes.SKILLS[:2] if quick else scenes.SKILLS:
            demos = scenes.make_demonstrations(skill, num_demos=6, num_points=250, seed=0)
            sets.append(DataSet(f"syn:{skill}", demos, "synthetic", note="6 demos, T=250"))
    if "lasa" in selected:
        shapes = lasa_shapes()
        for shape in list(shapes)[:4] if quick else shapes:
            sets.append(DataSet(f"lasa:{shape}", shapes[shape], "lasa", planar=True,
                                note=f"T={LASA_STATES}"))
    if "wiping_rim" in selected:
        demos = wiping_rim()
        if demos is not None:
            sets.append(DataSet("wiping_rim", demos, "pose",
                                note=f"T={WIPING_STATES}, {demos.duration:.3g} s, placed"))
    if "pose_synthetic" in selected:
        for skill, demos in pose_skills().items():
            sets.append(DataSet(f"pose:{skill}", demos, "pose",
                                note=f"{demos.M} demos, T={demos.T}"))
    return sets


def subset(demos: scenes.Demonstrations, keep: np.ndarray) -> scenes.Demonstrations:
    """The demonstrations ``keep`` (a mask or indices) with all they recorded (rotations,
    joint trajectories; obstacles are not kept)."""
    def kept(values):
        return None if values is None else values[keep]
    return scenes.Demonstrations(
        demos.positions[keep], demos.velocities[keep], demos.time, name=demos.name,
        joint_positions=kept(demos.joint_positions),
        joint_names=None if demos.joint_positions is None else demos.joint_names,
        orientations=kept(demos.orientations))


# ---------------------------------------------------------------------------- CLAMP
def is_pose_prior(prior) -> bool:
    """Whether the installed clamp learned ``prior`` with the hand's orientation (a pose
    prior: an orientation chain beside the positions' and ``mean_quaternions()``)."""
    return (getattr(prior, "orientation", None) is not None
            and hasattr(prior, "mean_quaternions"))


def pose_ik(robot, pose: np.ndarray) -> tuple[np.ndarray, float, float]:
    """A configuration (n,) [rad] of ``robot`` whose hand is at ``pose`` (7,) (position [m],
    quaternion x, y, z, w), by least squares (1 mm weighs as 1 deg) within the joint limits
    from up to POSE_IK_SEEDS position IK answers; with its position [m] and rotation [rad]
    errors."""
    from scipy.optimize import least_squares
    target, turn = pose[:3], Rotation.from_quat(pose[3:])
    millimetre, degree = 1e-3, np.radians(1.0)

    def residual(q: np.ndarray) -> np.ndarray:
        rotation, _ = robot.ee_rotation(q)
        angle = (turn.inv() * Rotation.from_matrix(rotation)).as_rotvec()
        return np.concatenate([(robot.fk(q) - target) / millimetre, angle / degree])
    best = None
    for attempt in range(POSE_IK_SEEDS):
        seed = np.clip(np.asarray(robot.ik(target, rng=attempt).q, float), robot.lower_limits,
                       robot.upper_limits)
        fit = least_squares(residual, seed, bounds=(robot.lower_limits, robot.upper_limits))
        if best is None or fit.cost < best.cost:
            best = fit
        if best.cost < 1e-6:                         # within ~1 um and ~1e-3 deg
            break
    r = residual(best.x)
    return best.x, float(np.linalg.norm(r[:3]) * millimetre), \
        float(np.linalg.norm(r[3:]) * degree)


def clamp_methods(train: scenes.Demonstrations, start: np.ndarray, goal: np.ndarray | None,
                  robot, start_q: np.ndarray | None = None
                  ) -> tuple[dict[str, np.ndarray], bool, float, list[str]]:
    """(reproductions of "CLAMP arm" and "CLAMP mean": (T, 3), or (T, 7) poses from a pose
    prior; the plan's success; planning seconds; notes: a start out of reach, a failed plan's
    reasons).

    From a pose prior the arm starts at the start pose (the start pose is the arm's): at
    ``start_q`` (n,) [rad], the held-out demonstration's recorded start configuration where
    it was recorded in joint space, else by pose_ik; it plans to the goal pose, and the
    mean's orientation chain is conditioned on the start (and goal) rotation."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clamp.ClampWarning)   # 2-demo training sets warn
        prior = clamp.learn_prior(train)
    T = prior.T
    observations = [(0, start[:3])] + ([] if goal is None else [(T - 1, goal[:3])])
    conditioned = clamp.condition_prior(prior, observations)
    mean = np.asarray(conditioned.mean)[:, :3]
    notes: list[str] = []
    pose = len(start) == 7 and is_pose_prior(prior)
    arm_start, arm_goal = start[:3], None if goal is None else goal[:3]
    if pose:
        # the goal pose, as the peers and the mean are given it (also when the start is the
        # recorded joint start)
        arm_goal = None if goal is None else (goal[:3], goal[3:])
    if pose and start_q is not None:
        arm_start = start_q
    elif pose:
        arm_start, position_error, angle_error = pose_ik(robot, start)
        if position_error > 1e-3 or angle_error > np.radians(1.0):
            notes.append(f"CLAMP arm start pose out of reach: pose IK {1e3 * position_error:.1f}"
                         f" mm, {np.degrees(angle_error):.1f} deg off")
    began = time.perf_counter()
    result = clamp.plan(prior, robot, None, arm_start, goal=arm_goal)
    seconds = time.perf_counter() - began
    if not result.success:
        notes.append("CLAMP arm unsuccessful: " + "; ".join(result.reasons)[:160])
    out = {"CLAMP arm": np.asarray(result.ee_path), "CLAMP mean": mean}
    if pose:
        rotations, _ = robot.ee_rotation(np.asarray(result.q))
        out["CLAMP arm"] = np.column_stack([out["CLAMP arm"], continuous_quaternions(
            Rotation.from_matrix(rotations).as_quat())])
        out["CLAMP mean"] = np.column_stack([mean, _mean_quaternions(conditioned, prior,
                                                                     start, goal)])
    return out, bool(result.success), seconds, notes


def _mean_quaternions(conditioned, prior, start: np.ndarray,
                      goal: np.ndarray | None) -> np.ndarray:
    """(T, 4) ``mean_quaternions()`` of ``conditioned`` (a pose prior conditioned on positions)
    with ``prior``'s orientation chain conditioned on the start (and goal) rotation, as the
    planner conditions it (clamp.prior.conditioning.conditioned_orientation, the planner's
    conditioning sigma; the chain's noise floored when a goal rotation conditions it,
    clamp.planning.reference.noise_floored)."""
    from clamp.prior.conditioning import conditioned_orientation
    from clamp.planning.reference import CONDITIONING_SIGMA, noise_floored
    T = prior.T
    orientation = prior.orientation
    rotations = [(0, Rotation.from_quat(start[3:]).as_matrix())]
    if goal is not None:
        rotations.append((T - 1, Rotation.from_quat(goal[3:]).as_matrix()))
        orientation = noise_floored(orientation)
    chain = conditioned_orientation(orientation, rotations, CONDITIONING_SIGMA)
    return np.asarray(conditioned.with_orientation(chain).mean_quaternions())


# ---------------------------------------------------------------------------- metrics
def metrics(reproduction: np.ndarray, demo: np.ndarray, time_: np.ndarray, planar: bool,
            demo_quaternions: np.ndarray | None = None) -> dict:
    """The metrics (module doc) of a reproduction (T, 3) or (T, 7) against a demonstration's
    positions (T, 3) (and quaternions (T, 4)); ori / oeq / oend NaN without both rotations."""
    path = reproduction[:, :3]
    vel = np.gradient(path, time_, axis=0) - np.gradient(demo, time_, axis=0)
    rotated = reproduction.shape[1] == 7 and demo_quaternions is not None
    return {"dtw": 1e3 * dtw_mean(path, demo),
            "sea": 1e4 * swept_area(path, demo) if planar else np.nan,
            "end": 1e3 * float(np.linalg.norm(path[-1] - demo[-1])),
            "vel": 1e3 * float(np.sqrt(np.mean(np.sum(vel ** 2, axis=1)))),
            "ori": (np.degrees(orientation_error(path, reproduction[:, 3:], demo,
                                                 demo_quaternions)) if rotated else np.nan),
            "oeq": (float(np.degrees(np.mean(geodesic_angle(reproduction[:, 3:],
                                                            demo_quaternions))))
                    if rotated else np.nan),
            "oend": (float(np.degrees(geodesic_angle(reproduction[-1, 3:],
                                                     demo_quaternions[-1])))
                     if rotated else np.nan)}


# ---------------------------------------------------------------------------- one fold
def run_fold(task: tuple[DataSet, int]) -> dict:
    """Both settings of fold k of a data set: {setting: {method: metrics}}, failures, seconds."""
    data, k = task
    demos = data.demos
    robot = robots.load_robot("jaco")
    held = demos.positions[k]
    held_turns = None if demos.orientations is None else demos.orientations[k]
    held_poses = held if held_turns is None else np.column_stack([held, held_turns])
    start_q = None if demos.joint_positions is None else demos.joint_positions[k][0]
    train = subset(demos, np.arange(demos.M) != k)
    out: dict = {"failures": {s: 0 for s in SETTINGS}, "plan_seconds": 0.0, "errors": []}
    for setting in SETTINGS:
        start, goal = held_poses[0], (held_poses[-1] if setting == "goal" else None)
        paths: dict[str, np.ndarray] = {}
        try:
            clamp_paths, success, seconds, notes = clamp_methods(train, start, goal, robot,
                                                                 start_q)
            paths.update(clamp_paths)
            out["failures"][setting] += not success
            out["plan_seconds"] += seconds
            out["errors"].extend(f"{data.name} fold {k} {setting}: {note}" for note in notes)
        except Exception as exc:                     # noqa: BLE001 - reported, not hidden
            out["errors"].append(f"{data.name} fold {k} {setting} CLAMP: {exc!r:.120}")
            out["failures"][setting] += 1
        for method, make in (("TLGC", lambda: lfd_peers.tlgc(train, start) if goal is None
                              else None),
                             ("ProMP", lambda: lfd_peers.promp(train, start, goal)),
                             ("DMP", lambda: lfd_peers.dmp(train, start, goal)),
                             ("GMR", lambda: lfd_peers.gmr(train, start, goal))):
            try:
                path = make()
            except Exception as exc:                 # noqa: BLE001
                out["errors"].append(f"{data.name} fold {k} {setting} {method}: {exc!r:.120}")
                continue
            if path is not None:
                paths[method] = path
        out[setting] = {m: metrics(p, held, demos.time, data.planar, held_turns)
                        for m, p in paths.items()}
    return out


# ---------------------------------------------------------------------------- report
def mean_over_folds(folds: list[dict], setting: str) -> dict[str, dict[str, float]]:
    table = {}
    for method in METHODS:
        rows = [f[setting][method] for f in folds if method in f[setting]]
        if rows:
            table[method] = {m: float(np.mean([r[m] for r in rows])) for m in METRICS}
    return table


def winner(table: dict[str, dict[str, float]], metric: str = "dtw",
           rivals: tuple[str, ...] = RIVALS) -> str:
    """The rival with the lowest ``metric`` (NaN: not a contender), or "-"."""
    present = [m for m in rivals if m in table and not np.isnan(table[m][metric])]
    return min(present, key=lambda m: table[m][metric]) if present else "-"


def _cell(value: float, width: int, digits: int = 2) -> str:
    return f"{'n/a' if np.isnan(value) else f'{value:.{digits}f}':>{width}}"


def print_set(data: DataSet, folds: list[dict]) -> dict[str, dict]:
    summary = {}
    print(f"\n{data.name} (M={data.demos.M}, {data.note}; {len(folds)} folds)")
    print(f"  {'setting':<6} {'method':<11} {'dtw mm':>8} {'sea cm2':>8} {'end mm':>8} "
          f"{'vel mm/s':>9}" + (f" {'ori deg':>8} {'oeq deg':>8} {'oend deg':>8}"
                                if data.pose else "")
          + f" {'fail':>5}")
    for setting in SETTINGS:
        table = mean_over_folds(folds, setting)
        fails = sum(f["failures"][setting] for f in folds)
        for method, row in table.items():
            sea = "-" if np.isnan(row["sea"]) else f"{row['sea']:8.2f}"
            fail = f"{fails:5d}" if method == "CLAMP arm" else ""
            turn = (f" {_cell(row['ori'], 8)} {_cell(row['oeq'], 8)} {_cell(row['oend'], 8)}"
                    if data.pose else "")
            print(f"  {setting:<6} {method:<11} {row['dtw']:8.2f} {sea:>8} {row['end']:8.2f} "
                  f"{row['vel']:9.2f}{turn} {fail}")
        best = winner(table)
        mean_best = ("CLAMP mean" in table and
                     all(table["CLAMP mean"]["dtw"] <= table[m]["dtw"]
                         for m in RIVALS if m in table and m != "CLAMP arm"))
        print(f"  {setting:<6} best: {best}" + ("   (CLAMP mean also beats the peers)"
                                                 if mean_best else ""))
        if data.pose:
            print(f"  {setting:<6} lowest orientation error: "
                  f"{winner(table, 'ori', ('CLAMP arm', 'CLAMP mean', *PEERS))}"
                  + ("   (CLAMP's n/a: the installed clamp learned no pose prior)"
                     if "CLAMP arm" in table and np.isnan(table["CLAMP arm"]["ori"]) else ""))
        summary[setting] = {"table": table, "best": best, "fails": fails}
    for line in sorted({e for f in folds for e in f["errors"]}):
        print(f"  ! {line}")
    return summary


def print_overview(sets: list[DataSet], summaries: list[dict]) -> None:
    print("\nOverview: mean DTW [mm] (" + " / ".join(METHODS) + "), winner")
    for data, summary in zip(sets, summaries):
        if data.group == "lasa":
            continue
        for setting in SETTINGS:
            table = summary[setting]["table"]
            cells = " / ".join(f"{table[m]['dtw']:.2f}" if m in table else "-" for m in METHODS)
            print(f"  {data.name:<26} {setting:<6} {cells:<56} {summary[setting]['best']}"
                  f"  (fail {summary[setting]['fails']})")
    lasa = [(d, s) for d, s in zip(sets, summaries) if d.group == "lasa"]
    if not lasa:
        return
    print(f"\nLASA summary over {len(lasa)} shapes (mean over shapes of the fold means)")
    for setting in SETTINGS:
        print(f"  {setting}:")
        for method in METHODS:
            rows = [s[setting]["table"][method] for _, s in lasa if method in s[setting]["table"]]
            if not rows:
                continue
            row = {m: np.mean([r[m] for r in rows]) for m in METRICS}
            print(f"    {method:<11} dtw {row['dtw']:7.2f} mm  sea {row['sea']:7.2f} cm2  "
                  f"end {row['end']:7.2f} mm  vel {row['vel']:7.2f} mm/s")
        wins = sum(s[setting]["best"] == "CLAMP arm" for _, s in lasa)
        mean_wins = sum(min((m for m in METHODS if m != "CLAMP arm" and m in s[setting]["table"]),
                            key=lambda m: s[setting]["table"][m]["dtw"]) == "CLAMP mean"
                        for _, s in lasa)
        fails = sum(s[setting]["fails"] for _, s in lasa)
        print(f"    CLAMP arm best on {wins} of {len(lasa)} shapes; CLAMP mean (against the "
              f"peers) on {mean_wins}; unsuccessful arm plans {fails}")
    both = sum(s[st]["best"] == "CLAMP arm" for _, s in lasa for st in SETTINGS)
    print(f"  CLAMP arm best in {both} of {2 * len(lasa)} shape x setting cells")


def print_pose_targets(sets: list[DataSet], summaries: list[dict]) -> None:
    """Orientation errors [deg] of every pose cell and whether CLAMP's is the lowest in all:
    the target's (ori, on the position DTW pairs) and at equal times (oeq: the DTW pairs are
    arbitrary where the hand turns in place, like a pour's tilt)."""
    cells = [(d, st, s[st]["table"]) for d, s in zip(sets, summaries) if d.pose
             for st in SETTINGS]
    if not cells:
        return
    for metric, label in (("ori", "on the position DTW pairs (the target's)"),
                          ("oeq", "at equal times")):
        print(f"\nPose cells: mean orientation error [deg] {label} ("
              + " / ".join(METHODS) + ")")
        for data, setting, table in cells:
            row = " / ".join(_cell(table[m][metric], 1) if m in table else "-"
                             for m in METHODS)
            print(f"  {data.name:<26} {setting:<6} {row}")
        for clamp_cell in ("CLAMP arm", "CLAMP mean"):
            lost = [f"{d.name} {st} ({winner(t, metric, (clamp_cell, *PEERS))})"
                    for d, st, t in cells
                    if winner(t, metric, (clamp_cell, *PEERS)) != clamp_cell]
            unmeasured = sum(clamp_cell not in t or np.isnan(t[clamp_cell][metric])
                             for _, _, t in cells)
            verdict = (f"n/a (no CLAMP orientation in {unmeasured} of {len(cells)} cells)"
                       if unmeasured else ("yes" if not lost else "no: " + ", ".join(lost)))
            print(f"  {'target' if metric == 'ori' else 'also'}: {clamp_cell} has the lowest "
                  f"orientation error ({metric}) in every pose cell: {verdict}")


def position_cells(sets: list[DataSet], summaries: list[dict]) -> dict[str, float]:
    """{"set setting": CLAMP arm mean DTW [mm]} of every position-only cell."""
    return {f"{d.name} {st}": s[st]["table"]["CLAMP arm"]["dtw"]
            for d, s in zip(sets, summaries) if not d.pose for st in SETTINGS
            if "CLAMP arm" in s[st]["table"]}


def print_anchor_target(cells: dict[str, float], anchor_path: Path) -> None:
    """Each position cell's CLAMP arm DTW against the anchor run's, and the 2 % target."""
    anchor = json.loads(anchor_path.read_text())
    common = [c for c in cells if c in anchor["cells"]]
    print(f"\nPosition DTW against the anchor {anchor_path.name} ({anchor.get('label', '')}): "
          f"CLAMP arm [mm], now / anchor")
    worse = []
    for cell in common:
        ratio = cells[cell] / anchor["cells"][cell]
        print(f"  {cell:<34} {cells[cell]:8.2f} / {anchor['cells'][cell]:8.2f}  {ratio:6.3f}x")
        if ratio > 1.0 + DTW_TOLERANCE:
            worse.append(f"{cell} {100 * (ratio - 1):+.1f} %")
    missing = len(set(anchor["cells"]) - set(cells))
    print(f"  target: position DTW at most {100 * DTW_TOLERANCE:.0f} % above the anchor in all "
          f"{len(common)} common cells: {'yes' if not worse else 'no: ' + ', '.join(worse)}"
          + (f" ({missing} anchor cells not run)" if missing else ""))


def main() -> None:
    choices = [*SHARED, "synthetic", "lasa", *POSE_SETS]
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="2 folds per set, 4 LASA shapes, 2 synthetic skills")
    parser.add_argument("--sets", nargs="+", default=choices, choices=choices, metavar="SET",
                        help=f"any of {choices}")
    parser.add_argument("--workers", type=int, default=1, help="processes (the machine is shared)")
    parser.add_argument("--record", type=Path, metavar="FILE",
                        help="write the position cells' CLAMP arm DTW to FILE (JSON)")
    parser.add_argument("--anchor", type=Path, metavar="FILE",
                        help="a --record FILE of an earlier run: print the 2 %% DTW target")
    args = parser.parse_args()
    if args.anchor is not None and not args.anchor.is_file():
        parser.error(f"--anchor: expected a JSON file written by --record, got {args.anchor} "
                     "(not a file)")
    print_environment()
    began = time.perf_counter()
    cpu = time.process_time()
    sets = load_sets(args.sets, args.quick)
    tasks = [(data, k) for data in sets for k in range(data.demos.M)[:2 if args.quick else None]]
    if args.workers > 1:
        with ProcessPoolExecutor(args.workers, initializer=exit_with_parent) as pool:
            results = list(pool.map(run_fold, tasks, chunksize=1))
    else:
        results = [run_fold(task) for task in tasks]
    summaries = []
    for data in sets:
        folds = [r for (d, _), r in zip(tasks, results) if d is data]
        summaries.append(print_set(data, folds))
    print_overview(sets, summaries)
    print_pose_targets(sets, summaries)
    cells = position_cells(sets, summaries)
    if args.anchor is not None:
        print_anchor_target(cells, args.anchor)
    if args.record is not None:
        record = {"label": f"bench_lfd{' --quick' if args.quick else ''} "
                           f"--sets {' '.join(args.sets)}", "cells": cells}
        partial = args.record.with_name(args.record.name + ".partial")
        partial.write_text(json.dumps(record, indent=1) + "\n")
        partial.replace(args.record)
        print(f"\nrecorded {len(cells)} position cells to {args.record}")
    plans = sum(r["plan_seconds"] for r in results)
    print(f"\n{len(tasks)} folds, {2 * len(tasks)} arm plans ({plans:.1f} s planning); wall "
          f"{time.perf_counter() - began:.1f} s, this process's CPU {time.process_time() - cpu:.1f} s")


if __name__ == "__main__":
    main()
