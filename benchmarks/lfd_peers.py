"""The peers CLAMP is compared with in benchmarks/bench_lfd.py: TLGC, ProMP, DMP and GMR, each
learning from training demonstrations and reproducing the skill from a new start (and to a
new goal) on the training set's time steps.

A peer is given the start and the goal as positions (3,) [m] on position-only data, or as
poses (7,): position then the hand's rotation as a unit quaternion (x, y, z, w), when the
demonstrations have orientations; it returns the reproduction in the same form, (T, 3) or
(T, 7), quaternions unit and sign-continuous.

  TLGC   tlgc.reproduce of a spline cylinder fitted to the training set, the start projected
         onto the first section's plane (position only; start setting only: no goal);
  ProMP  movement_primitives.promp.ProMP, WEIGHTS RBF weights per dimension (position, and
         the four quaternion components on pose data: renormalised afterwards), the weight
         distribution the mean and covariance of the training demonstrations' ridge weights
         plus a weak weight prior PROMP_WEIGHT_PRIOR^2 I (without it 3-5 demonstrations leave
         too few directions to meet both start and goal), conditioned on the start (and the
         goal) with PROMP_NOISE;
  DMP    movement_primitives.dmp.DMP on positions, movement_primitives.dmp.CartesianDMP
         (position and a quaternion DMP) on poses, WEIGHTS weights per dimension, imitating
         the training mean (quaternions: the sign-aligned mean, renormalised), started at the
         start, goal the training mean's end (the given goal in the goal setting);
  GMR    gmr.GMM with GMR_COMPONENTS components (k-means++ start, seed 0) on (phase, position
         [, quaternion]) samples of the training set, regressed on the phase (the quaternion
         renormalised; every coordinate standardised to zero mean and unit spread over the
         samples, since gmr regularises a singular covariance by a fixed 1e-3 I, which is not
         small against positions in metres). GMR reproduces the time-indexed mean and
         cannot itself adapt to a new start or goal (the TLGC paper, section 2): the
         difference to the start (and to the goal) is blended in linearly in phase (rotations:
         along the rotation vector), so the reproduction starts at the start (and ends at the
         goal). A coordinate every sample shares (a planar set's height) is kept constant, not
         modelled (its covariance would be singular).
"""
from __future__ import annotations

import functools

import numpy as np
from scipy.spatial.transform import Rotation

import scenes
from scenes.demonstrations import continuous_quaternions
from skillplan.threads import single_blas_thread

WEIGHTS = 20                                             # ProMP / DMP weights per dimension
PROMP_NOISE = 1e-4                                       # [m] std of ProMP's conditioning
PROMP_WEIGHT_PRIOR = 1e-2                                # [m] std added to every weight
GMR_COMPONENTS = 10                                      # GMR's Gaussians (paper: 2-10)
CONSTANT = 1e-9                                          # [m] spread of a shared coordinate


# ---------------------------------------------------------------------------- poses
def training_poses(train: scenes.Demonstrations) -> np.ndarray:
    """(M, T, 3) positions, or (M, T, 7) poses with every demonstration's quaternions on the
    hemisphere of demonstration 0's first one (the peers average quaternion components)."""
    if train.orientations is None:
        return train.positions
    q = train.orientations
    flip = np.where(np.einsum("mi,i->m", q[:, 0], q[0, 0]) < 0, -1.0, 1.0)
    return np.concatenate([train.positions, q * flip[:, None, None]], axis=2)


def near(quaternion: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """The sign of ``quaternion`` (4,) nearer ``reference`` (4,) (the same rotation)."""
    return -quaternion if float(quaternion @ reference) < 0 else quaternion


def renormalised(y: np.ndarray) -> np.ndarray:
    """(T, 3) unchanged; (T, 7) with its quaternions unit and sign-continuous."""
    if y.shape[1] == 3:
        return y
    q = y[:, 3:] / np.linalg.norm(y[:, 3:], axis=1, keepdims=True)
    return np.column_stack([y[:, :3], continuous_quaternions(q)])


def _target(target: np.ndarray, mean: np.ndarray) -> np.ndarray:
    """A start / goal pose with its quaternion's sign nearest the training mean's there."""
    target = np.asarray(target, float)
    if len(target) == 3:
        return target
    return np.concatenate([target[:3], near(target[3:], mean[3:])])


def _mean_pose(poses: np.ndarray) -> np.ndarray:
    """(T, d) mean over demonstrations, the quaternion part renormalised."""
    return renormalised(poses.mean(axis=0))


def _phase(train: scenes.Demonstrations) -> np.ndarray:
    return (train.time - train.time[0]) / train.duration


# ---------------------------------------------------------------------------- peers
def _one_blas_thread(peer):
    """Run ``peer`` with every BLAS on one thread: its products are tiny, and threads only
    wait on each other (GMR's EM: 9.0 s -> 0.57 s CPU a fit on box_closing at load ~10)."""
    @functools.wraps(peer)
    def run(*args, **kwargs):
        with single_blas_thread():
            return peer(*args, **kwargs)
    return run


@_one_blas_thread
def tlgc(train: scenes.Demonstrations, start: np.ndarray) -> np.ndarray:
    """TLGC's fixed-ratio reproduction (T', 3) from start[:3] (position only)."""
    import tlgc as tlgc_
    cylinder = tlgc_.fit_cylinder(train, "spline")
    return tlgc_.reproduce(cylinder, np.asarray(start)[:3], plane_tolerance=np.inf,
                           allow_outside=True)


@_one_blas_thread
def promp(train: scenes.Demonstrations, start: np.ndarray,
          goal: np.ndarray | None) -> np.ndarray:
    """ProMP conditioned on the start (and the goal): (T, 3) or (T, 7)."""
    from movement_primitives.promp import ProMP
    poses, phase = training_poses(train), _phase(train)
    d = poses.shape[2]
    model = ProMP(n_dims=d, n_weights_per_dim=WEIGHTS)
    # ProMP.weights normalises its time argument in place: hand it copies
    weights = np.array([model.weights(phase.copy(), y) for y in poses])
    cov = np.cov(weights, rowvar=False) + PROMP_WEIGHT_PRIOR ** 2 * np.eye(weights.shape[1])
    model.from_weight_distribution(weights.mean(axis=0), cov)
    mean = _mean_pose(poses)
    noise = PROMP_NOISE ** 2 * np.eye(d)
    model = model.condition_position(_target(start, mean[0]), noise, t=0.0, t_max=1.0)
    if goal is not None:
        model = model.condition_position(_target(goal, mean[-1]), noise, t=1.0, t_max=1.0)
    return renormalised(model.mean_trajectory(phase.copy()))


def _wxyz(pose: np.ndarray) -> np.ndarray:
    """A pose (7,) with its quaternion in pytransform3d's order (w, x, y, z)."""
    return np.concatenate([pose[:3], pose[[6, 3, 4, 5]]])


@_one_blas_thread
def dmp(train: scenes.Demonstrations, start: np.ndarray,
        goal: np.ndarray | None) -> np.ndarray:
    """DMP (CartesianDMP on poses) imitating the training mean from the start to the goal
    (the mean's end without one): (T, 3) or (T, 7)."""
    from movement_primitives.dmp import DMP, CartesianDMP
    time_ = train.time - train.time[0]
    mean = _mean_pose(training_poses(train))
    d = mean.shape[1]
    start, goal = _target(start, mean[0]), _target(mean[-1] if goal is None else goal, mean[-1])
    options = dict(execution_time=float(time_[-1]), dt=float(np.median(np.diff(time_))),
                   n_weights_per_dim=WEIGHTS)
    if d == 3:
        model = DMP(n_dims=3, **options)
        model.imitate(time_, mean)
        model.configure(start_y=start, goal_y=goal)
        t_out, y = model.open_loop()
    else:
        model = CartesianDMP(**options)
        model.imitate(time_, _wxyz_path(mean))
        model.configure(start_y=_wxyz(start), goal_y=_wxyz(goal))
        t_out, y = model.open_loop()
        y = np.column_stack([y[:, :3], y[:, [4, 5, 6, 3]]])            # back to (x, y, z, w)
    if len(t_out) != len(time_):
        y = np.column_stack([np.interp(time_, t_out, y[:, k]) for k in range(d)])
    return renormalised(y)


def _wxyz_path(poses: np.ndarray) -> np.ndarray:
    return np.column_stack([poses[:, :3], poses[:, [6, 3, 4, 5]]])


@_one_blas_thread
def gmr(train: scenes.Demonstrations, start: np.ndarray,
        goal: np.ndarray | None) -> np.ndarray:
    """GMR on the phase, blended to the start (and the goal): (T, 3) or (T, 7)."""
    from gmr import GMM
    poses, phase = training_poses(train), _phase(train)
    M, T, d = poses.shape
    samples = poses.reshape(M * T, d)
    centre, spread = samples.mean(axis=0), samples.std(axis=0)
    varying = spread > CONSTANT
    scaled = (samples[:, varying] - centre[varying]) / spread[varying]
    features = np.column_stack([np.tile(phase, M), scaled])
    model = GMM(n_components=GMR_COMPONENTS, random_state=0)
    model.from_samples(features, init_params="kmeans++")
    y = np.tile(centre, (T, 1))
    y[:, varying] += model.predict(np.array([0]), phase[:, None]) * spread[varying]
    y = renormalised(y)
    return _blended(y, phase, _target(start, y[0]),
                    None if goal is None else _target(goal, y[-1]))


def _blended(y: np.ndarray, phase: np.ndarray, start: np.ndarray,
             goal: np.ndarray | None) -> np.ndarray:
    """y (T, d) moved by its difference to the start fading linearly in phase (and to the
    goal growing linearly); rotations composed on the left along the rotation vector."""
    weights = [(1.0 - phase, 0, start)] + ([] if goal is None else [(phase, -1, goal)])
    out = y.copy()
    for weight, at, target in weights:
        out[:, :3] += weight[:, None] * (target[:3] - y[at, :3])
    if y.shape[1] == 7:
        turn = np.zeros((len(phase), 3))
        for weight, at, target in weights:
            difference = Rotation.from_quat(target[3:]) * Rotation.from_quat(y[at, 3:]).inv()
            turn += weight[:, None] * difference.as_rotvec()[None]
        out[:, 3:] = (Rotation.from_rotvec(turn) * Rotation.from_quat(y[:, 3:])).as_quat()
    return renormalised(out)
