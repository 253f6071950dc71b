"""Retiming: make a joint trajectory executable under velocity, acceleration and jerk limits.

Velocity limits come from the URDF (``robot.velocity_limits``, rad/s). URDFs carry no
acceleration limits, so they are an argument: a scalar or one per joint (rad/s^2), default
:data:`DEFAULT_ACCELERATION_LIMIT`; pass the arm's data-sheet values (or MoveIt's
``joint_limits.yaml``) for real use.

A trajectory is *within limits* when at every sample (tolerance ``1e-6`` relative)
- its velocity samples and the difference quotients of its positions are within the velocity
  limits, and
- its stored accelerations and the difference quotients of its velocity samples (the mean
  acceleration over each sample interval; they bound the export's finite differences,
  :func:`robots.trajectory.finite_difference`) are within the acceleration limits, and
- when jerk limits are given (rad/s^3; none by default), the difference quotients of its stored
  accelerations (the mean jerk over each sample interval, what a controller differencing the
  written accelerations sees) are within the jerk limits.

Two methods keep the geometric path and change only the timing:
- ``"uniform"``: one time-scaling factor k (time * k, velocity / k, acceleration / k^2), the
  smallest that meets both limits (:func:`uniform_scaling`); the samples stay the same, so it
  starts and ends at rest only if the input does.
- ``"toppra"``: time-optimal path parameterisation (TOPP-RA, the ``toppra`` package) of the
  C2 cubic spline through the samples, parameterised by their cumulative joint-space chord
  length (end tangents along the given end velocities), from rest to rest: a jerk-limited
  ramp at each end (path acceleration rising linearly from zero over ``ramp_time`` s, to half
  of what the limits allow there) and TOPP-RA's constant-path-acceleration profile between
  the ramps. The profile is sampled every ``sample_period`` s with its exact velocities and
  accelerations (zero at both ends: no jump when a controller starts or stops it), and if
  sampling between TOPP-RA's grid points leaves a violation, a final uniform stretch
  (reported) removes it.
  The chord length keeps |dq/ds| near 1 along the whole path: parameterised by the plan's own
  time, a plan that creeps out of its start (the demonstrations' timing: 1e-7 .. 1e-3 rad/s
  over the first seconds) gives TOPP-RA's solver path speeds and coefficients far outside its
  fixed numerical range, and it reports the path "not controllable" although it is.
- ``"ruckig"``: jerk-limited path timing (the ``ruckig`` package, as MoveIt 2 smooths its
  trajectories) along the same chord-length spline q(s), from rest to rest. Ruckig times the
  path position s itself, so the motion never leaves the path: each piece of the spline gets
  bounds on the path speed, acceleration and jerk derived from the joint limits and the exact
  maxima of |q'|, |q''|, |q'''| on the piece (:func:`_path_bounds`); pieces with alike bounds
  form windows, the path speeds at the window boundaries come from a forward and a backward
  pass (path acceleration zero there), and each window is a 1-DOF ruckig problem between its
  boundary states within its bounds. The fastest of a few ways to split the limits and group
  the pieces is kept. Every joint's velocity, acceleration and jerk then stay within limits;
  the sampled result is checked (jerk: difference quotients of the written accelerations) and
  if a check still fails the bounds shrink and the timing is redone: a trajectory outside the
  limits is never returned (RetimingError instead).
``"auto"`` uses ruckig when jerk limits are given, else toppra when it is installed, else
uniform scaling.

The report measures how far the retimed motion leaves the original path: both trajectories
are interpolated as a joint trajectory controller would (cubic Hermite through positions and
velocities); each point of the retimed motion on a dense grid (``substeps`` points per retimed
sample interval) is measured to the original path near its corresponding path position, in
joint space (Euclidean, rad) and at the end effector (``robot.fk``, m).
"""
from __future__ import annotations

import importlib
import importlib.util
import logging
import math
import sys
import types
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import RetimingError
from .trajectory import JointTrajectory

logger = logging.getLogger(__name__)

#: Default acceleration limit [rad/s^2] for every joint when none is given. URDFs carry none;
#: 1 rad/s^2 is conservative for table-top arms (the Jaco reaches its 0.63 rad/s velocity
#: limit in 0.63 s, the Sawyer its 1.74 rad/s shoulder limit in 1.7 s).
DEFAULT_ACCELERATION_LIMIT = 1.0
#: Default spacing [s] of the retimed samples (100 Hz).
DEFAULT_SAMPLE_PERIOD = 0.01
#: Default duration [s] of the jerk-limited ramps at both ends of a TOPP-RA retiming: the path
#: acceleration rises linearly from zero at the start (falls to zero at the end) over this time.
DEFAULT_RAMP_TIME = 0.1
#: The ramps reach this fraction of the largest path acceleration the limits allow at rest.
RAMP_FRACTION = 0.5
#: Relative tolerance of limit checks (|value| <= limit * (1 + tolerance)).
LIMIT_TOLERANCE = 1e-6
#: Stand-in for an infinite velocity limit inside TOPP-RA [rad/s].
_UNBOUNDED_VELOCITY = 1e6
#: Relative margin kept from every path bound handed to ruckig (its profiles meet a bound up
#: to round-off).
_RUCKIG_MARGIN = 1e-3
#: (centripetal, similarity) settings of the ruckig retiming; the fastest result is kept:
#: centripetal = share of the acceleration limit the path's curvature may take at full speed,
#: similarity = how alike (factor) the bounds of the pieces grouped into one window must be.
_RUCKIG_SETTINGS = ((0.5, 0.4), (0.5, 0.55), (0.5, 0.7), (0.7, 0.4), (0.7, 0.55), (0.7, 0.7))
#: A sampled violation multiplies every limit the ruckig bounds come from by this, then retries.
_RUCKIG_SHRINK = 0.9
_RUCKIG_ATTEMPTS = 5
METHODS = ("auto", "uniform", "toppra", "ruckig")


# --------------------------------------------------------------------------- limits
def _as_limits(value: Any, name: str, n: int) -> np.ndarray:
    """Positive limits (n,) from a scalar or an (n,) array; +inf means unlimited."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise RetimingError(f"{name}: expected a positive number or an array ({n},), "
                            f"got {type(value).__name__}") from exc
    if array.ndim == 0:
        array = np.full(n, float(array))
    if array.shape != (n,):
        raise RetimingError(f"{name}: expected a positive number or shape ({n},), got shape {array.shape}")
    if np.any(np.isnan(array)) or np.any(array <= 0.0):
        raise RetimingError(f"{name}: expected positive limits (inf = unlimited), got {array.tolist()}")
    return array


def acceleration_limits_for(n: int, acceleration_limits: Any = None) -> np.ndarray:
    """Acceleration limits (n,) [rad/s^2]: the given scalar / array, or the default."""
    return _as_limits(DEFAULT_ACCELERATION_LIMIT if acceleration_limits is None else acceleration_limits,
                      "acceleration_limits", n)


def jerk_limits_for(n: int, jerk_limits: Any = None) -> np.ndarray:
    """Jerk limits (n,) [rad/s^3]: the given scalar / array, or +inf (unlimited) for None."""
    return np.full(n, np.inf) if jerk_limits is None else _as_limits(jerk_limits, "jerk_limits", n)


@dataclass(frozen=True)
class LimitCheck:
    """Peaks of a trajectory against its limits, per joint (n,).

    peak_velocity: max of |velocity samples| and |position difference quotients| [rad/s];
    peak_acceleration: max of |stored accelerations| and |velocity difference quotients|
    [rad/s^2]; peak_jerk: max of |acceleration difference quotients| [rad/s^3] (measured
    always, limited only where jerk_limits is finite; +inf = no jerk limit); ratios = peak /
    limit (0 for unlimited joints).
    """

    joint_names: tuple[str, ...]
    velocity_limits: np.ndarray
    acceleration_limits: np.ndarray
    peak_velocity: np.ndarray
    peak_acceleration: np.ndarray
    tolerance: float = LIMIT_TOLERANCE
    jerk_limits: np.ndarray | None = None
    peak_jerk: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.joint_names)
        if self.jerk_limits is None:
            object.__setattr__(self, "jerk_limits", np.full(n, np.inf))
        if self.peak_jerk is None:
            object.__setattr__(self, "peak_jerk", np.zeros(n))

    @property
    def velocity_ratio(self) -> np.ndarray:
        """peak_velocity / velocity_limits (n,)."""
        return self.peak_velocity / self.velocity_limits

    @property
    def acceleration_ratio(self) -> np.ndarray:
        """peak_acceleration / acceleration_limits (n,)."""
        return self.peak_acceleration / self.acceleration_limits

    @property
    def jerk_ratio(self) -> np.ndarray:
        """peak_jerk / jerk_limits (n,); 0 where the jerk is not limited."""
        return self.peak_jerk / self.jerk_limits

    @property
    def jerk_limited(self) -> bool:
        """Whether any joint has a (finite) jerk limit."""
        return bool(np.any(np.isfinite(self.jerk_limits)))

    @property
    def velocity_ok(self) -> bool:
        """Every velocity within its limit (up to the tolerance)."""
        return bool(np.all(self.velocity_ratio <= 1.0 + self.tolerance))

    @property
    def acceleration_ok(self) -> bool:
        """Every acceleration within its limit (up to the tolerance)."""
        return bool(np.all(self.acceleration_ratio <= 1.0 + self.tolerance))

    @property
    def jerk_ok(self) -> bool:
        """Every jerk within its limit (up to the tolerance); True without jerk limits."""
        return bool(np.all(self.jerk_ratio <= 1.0 + self.tolerance))

    @property
    def within_limits(self) -> bool:
        """Velocities, accelerations and (where limited) jerks within limits at every sample."""
        return self.velocity_ok and self.acceleration_ok and self.jerk_ok

    def violations(self) -> list[str]:
        """Readable list of the violated limits (empty when within limits)."""
        out = []
        for j, name in enumerate(self.joint_names):
            if self.velocity_ratio[j] > 1.0 + self.tolerance:
                out.append(f"{name}: velocity {self.peak_velocity[j]:.4g} rad/s > {self.velocity_limits[j]:.4g}")
            if self.acceleration_ratio[j] > 1.0 + self.tolerance:
                out.append(f"{name}: acceleration {self.peak_acceleration[j]:.4g} rad/s^2 > "
                           f"{self.acceleration_limits[j]:.4g}")
            if self.jerk_ratio[j] > 1.0 + self.tolerance:
                out.append(f"{name}: jerk {self.peak_jerk[j]:.4g} rad/s^3 > {self.jerk_limits[j]:.4g}")
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (max_jerk_ratio: None without jerk limits)."""
        return {"within_limits": self.within_limits,
                "max_velocity_ratio": float(self.velocity_ratio.max()),
                "max_acceleration_ratio": float(self.acceleration_ratio.max()),
                "max_jerk_ratio": float(self.jerk_ratio.max()) if self.jerk_limited else None,
                "peak_velocity": self.peak_velocity.tolist(), "peak_acceleration": self.peak_acceleration.tolist(),
                "peak_jerk": self.peak_jerk.tolist(), "violations": self.violations()}


def _peaks(traj: JointTrajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Peak velocity [rad/s], acceleration [rad/s^2] and jerk [rad/s^3] per joint (n,) of the
    samples (see LimitCheck)."""
    t = traj.time_from_start
    quotients = np.diff(traj.positions, axis=0) / np.diff(t)[:, None]
    velocity = np.maximum(np.abs(traj.velocities).max(axis=0), np.abs(quotients).max(axis=0))
    differenced = np.diff(traj.velocities, axis=0) / np.diff(t)[:, None]
    acceleration = np.maximum(np.abs(traj.accelerations).max(axis=0), np.abs(differenced).max(axis=0))
    jerk = np.abs(np.diff(traj.accelerations, axis=0) / np.diff(t)[:, None]).max(axis=0)
    return velocity, acceleration, jerk


def check_limits(traj: JointTrajectory, velocity_limits: Any, acceleration_limits: Any = None,
                 tolerance: float = LIMIT_TOLERANCE, *, jerk_limits: Any = None) -> LimitCheck:
    """Check `traj` against velocity limits (n,) rad/s, acceleration limits (scalar or (n,)
    rad/s^2, None = DEFAULT_ACCELERATION_LIMIT) and jerk limits (scalar or (n,) rad/s^3, None =
    not limited; the peak jerk is measured anyway); see the module docstring for what is
    checked."""
    traj = _as_trajectory(traj)
    vlim = _as_limits(velocity_limits, "velocity_limits", traj.n)
    alim = acceleration_limits_for(traj.n, acceleration_limits)
    jlim = jerk_limits_for(traj.n, jerk_limits)
    velocity, acceleration, jerk = _peaks(traj)
    return LimitCheck(traj.joint_names, vlim, alim, velocity, acceleration, float(tolerance), jlim, jerk)


def uniform_scaling(traj: JointTrajectory, velocity_limits: Any, acceleration_limits: Any = None) -> float:
    """Smallest time-scaling factor k >= 0 such that the trajectory with time * k meets both
    limits: k = max(max velocity ratio, sqrt(max acceleration ratio)). k > 1 slows down,
    k < 1 means the limits allow a faster execution; 0 for a motionless trajectory."""
    check = check_limits(traj, velocity_limits, acceleration_limits)
    return float(max(check.velocity_ratio.max(), math.sqrt(check.acceleration_ratio.max())))


def scale_time(traj: JointTrajectory, factor: float) -> JointTrajectory:
    """The same samples executed `factor` times slower: time * factor, velocities / factor,
    accelerations / factor^2 (the finite differences of the new velocities when the old ones
    were the finite differences of the old velocities)."""
    traj = _as_trajectory(traj)
    if not isinstance(factor, (int, float, np.floating, np.integer)) or not math.isfinite(factor) or factor <= 0:
        raise RetimingError(f"factor: expected a positive finite number, got {factor!r}")
    time = traj.time_from_start * float(factor)
    velocities = traj.velocities / float(factor)
    return traj.replace(time_from_start=time, velocities=velocities,
                        accelerations=traj.accelerations / float(factor) ** 2)


def toppra_available() -> bool:
    """Whether the optional ``toppra`` package can be imported."""
    return importlib.util.find_spec("toppra") is not None


# --------------------------------------------------------------------------- report
@dataclass(frozen=True)
class RetimingReport:
    """What retime did. Durations [s]; deviations from the original path: joint space [rad],
    end effector [m].

    scaling_factor: for "uniform" the time factor applied; for "toppra" the final uniform
    stretch that removed violations left between TOPP-RA grid points, or kept the duration
    with allow_faster=False (1.0 when none was needed); for "ruckig" the stretch that kept the
    duration with allow_faster=False (else 1.0). within_position_limits: every retimed
    sample inside the robot's joint position limits (the spline between the input samples can
    overshoot a limit the samples touch).
    """

    method: str
    duration_before: float
    duration_after: float
    before: LimitCheck
    after: LimitCheck
    scaling_factor: float
    max_joint_deviation: float
    max_ee_deviation: float
    num_points_before: int
    num_points_after: int
    within_position_limits: bool = True

    @property
    def violated_before(self) -> bool:
        """Whether the input trajectory violated a limit."""
        return not self.before.within_limits

    @property
    def within_limits(self) -> bool:
        """Whether the retimed trajectory is within limits."""
        return self.after.within_limits

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (also stored as verdict["retiming"] in the retimed trajectory)."""
        return {"method": self.method, "duration_before": self.duration_before,
                "duration_after": self.duration_after, "violated_before": self.violated_before,
                "within_limits": self.within_limits, "scaling_factor": self.scaling_factor,
                "max_joint_deviation": self.max_joint_deviation, "max_ee_deviation": self.max_ee_deviation,
                "num_points_before": self.num_points_before, "num_points_after": self.num_points_after,
                "within_position_limits": self.within_position_limits,
                "velocity_limits": self.after.velocity_limits.tolist(),
                "acceleration_limits": self.after.acceleration_limits.tolist(),
                "jerk_limits": self.after.jerk_limits.tolist() if self.after.jerk_limited else None,
                "before": self.before.to_dict(), "after": self.after.to_dict()}


# --------------------------------------------------------------------------- retiming
def _as_trajectory(traj: Any) -> JointTrajectory:
    if not isinstance(traj, JointTrajectory):
        raise RetimingError(f"traj: expected a robots.trajectory.JointTrajectory, got {type(traj).__name__}")
    return traj


def _moving(positions: np.ndarray) -> np.ndarray:
    """Which sample intervals (T-1,) move: joint-space step > 1e-12 of the path length (the
    others are a pause)."""
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    return steps > 1e-12 * steps.sum()


def _chord_knots(traj: JointTrajectory) -> tuple[np.ndarray, np.ndarray]:
    """Path knots for TOPP-RA: (cumulative joint-space chord length [rad] of the kept samples (K,),
    indices of the kept samples (K,)). Samples of a pause (:func:`_moving`) are dropped, so the
    knots increase strictly."""
    moving = _moving(traj.positions)
    kept = np.concatenate(([0], 1 + np.flatnonzero(moving)))
    if not moving[-1]:  # end on the last sample (the one the trajectory ends at)
        kept[-1] = traj.num_points - 1
    knots = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(traj.positions[kept], axis=0), axis=1))))
    return knots, kept


class _ChordPath:
    """The path the retimers follow: the C2 cubic spline q(s) (n joints) through the moving
    samples of a trajectory (:func:`_chord_knots`), s the cumulative joint-space chord length
    [rad], with end tangents dq/ds along the input's end velocities (zero where the input rests).

    ``path(s, order)``: q (order 0, rad) or its derivative dq/ds, d2q/ds2 (orders 1, 2) at path
    positions s (K,) -> (K, n); ``spline``: the scipy CubicSpline itself (piecewise cubic
    coefficients per knot interval); ``knots`` (K,) [rad] and ``knot_times`` (K,) [s]: the
    chord length and the input's time at each kept sample; ``length`` [rad]; ``dof`` = n.
    Raises RetimingError when the positions do not move."""

    def __init__(self, traj: JointTrajectory):
        s_knots, kept = _chord_knots(traj)
        if len(kept) < 2:
            raise RetimingError("traj: the positions do not move (velocities without motion)")
        t_knots = traj.time_from_start[kept]
        # end tangents dq/ds = qdot dt/ds, dt/ds of the end intervals
        bc = ((1, traj.velocities[0] * (t_knots[1] - t_knots[0]) / s_knots[1]),
              (1, traj.velocities[-1] * (t_knots[-1] - t_knots[-2]) / (s_knots[-1] - s_knots[-2])))
        from scipy.interpolate import CubicSpline   # deferred: importing the limits stays light
        self.spline = CubicSpline(s_knots, traj.positions[kept], bc_type=bc)
        self._orders = [self.spline, self.spline.derivative()]
        self._orders.append(self._orders[1].derivative())
        self.knots, self.knot_times = s_knots, t_knots
        self.length, self.dof = float(s_knots[-1]), traj.n

    def __call__(self, positions: Any, order: int = 0) -> np.ndarray:
        return self._orders[order](positions)

    def input_time(self, positions: Any) -> np.ndarray:
        """The input's time [s] at path positions s (piecewise linear between the knots)."""
        return np.interp(positions, self.knots, self.knot_times)


class _SubPath:
    """The part [start, stop] of a path q(s) for TOPP-RA (its grid must span its path's interval);
    ``path(s, order)`` is q or its derivative of that order."""

    def __init__(self, path: _ChordPath, start: float, stop: float):
        self.path, self.path_interval, self.dof = path, np.array([start, stop]), path.dof

    def __call__(self, positions: Any, order: int = 0) -> np.ndarray:
        return self.path(positions, order)


def _ramp_jerk(path: _ChordPath, end: float, direction: float, vlim: np.ndarray, alim: np.ndarray,
               ramp_time: float, length: float, reach: float) -> float:
    """Path jerk j [rad/s^3] of the ramp at one end of the path (``direction`` +1: leaving the
    start, -1: arriving at the end): path acceleration j t over its ``ramp_time`` s, from
    (or, time-reversed, to) rest, up to RAMP_FRACTION of the largest path acceleration the
    limits allow at rest near there (the largest tangent over ``reach`` [rad] of path), halved until every joint stays within its limits along the
    ramp (checked at 32 instants) and the ramp covers at most a quarter of the path."""
    nearby = end + direction * np.linspace(0.0, min(reach, length / 4.0), 16)
    tangent = np.abs(path(nearby, 1)).max(axis=0)     # the end tangent is zero when the input rests
    moving = tangent > 0.0
    jerk = RAMP_FRACTION * float(np.min(alim[moving] / tangent[moving])) / ramp_time
    jerk = min(jerk, 1.5 * length / ramp_time**3)       # j tau^3 / 6 <= length / 4
    t = np.linspace(0.0, ramp_time, 32)
    for _ in range(20):
        s = end + direction * jerk * t**3 / 6.0
        speed, acceleration = jerk * t**2 / 2.0, direction * jerk * t
        dq, ddq = path(s, 1), path(s, 2)
        if np.all(np.abs(dq * speed[:, None]) <= vlim) and \
                np.all(np.abs(dq * acceleration[:, None] + ddq * speed[:, None] ** 2) <= alim):
            return jerk
        jerk /= 2.0
    raise RetimingError("traj: no jerk-limited start or stop within the limits (the path turns too sharply "
                        "at its ends)")


class _RestToRestProfile:
    """Path position s(t) [rad of chord] from rest to rest: a jerk-limited ramp (path
    acceleration j0 t) over ``ramp`` s, TOPP-RA's time-optimal profile (constant path
    acceleration per grid interval s_i .. s_i+1, speeds sd_i) in between, and the mirrored
    ramp (j1) into the end. Path speed and acceleration are exactly zero at both ends and the
    acceleration rises from and falls to zero continuously."""

    def __init__(self, start: float, stop: float, jerks: tuple[float, float], ramp: float,
                 s: np.ndarray, sd: np.ndarray, times: np.ndarray):
        self.start, self.stop, self.jerks, self.ramp = start, stop, jerks, ramp
        self.s, self.sd, self.times = s, sd, times
        self.u = (sd[1:] ** 2 - sd[:-1] ** 2) / (2.0 * np.diff(s))   # path acceleration per interval

    @property
    def duration(self) -> float:
        """Length [s] of the profile: both ramps and TOPP-RA's part."""
        return float(2.0 * self.ramp + self.times[-1])

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Path position, speed [/s] and acceleration [/s^2] at times t (K,) in [0, duration]."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        s, sd, times, u = self.s, self.sd, self.times, self.u
        middle = t - self.ramp
        i = np.clip(np.searchsorted(times, middle, side="right") - 1, 0, len(s) - 2)
        tau = np.clip(middle - times[i], 0.0, times[i + 1] - times[i])
        position = np.clip(s[i] + sd[i] * tau + 0.5 * u[i] * tau**2, s[i], s[i + 1])
        speed, acceleration = np.maximum(sd[i] + u[i] * tau, 0.0), u[i]
        j0, j1 = self.jerks
        rising, falling = t < self.ramp, t > self.ramp + times[-1]
        left = self.duration - t
        position = np.where(rising, self.start + j0 * t**3 / 6.0,
                            np.where(falling, self.stop - j1 * left**3 / 6.0, position))
        speed = np.where(rising, j0 * t**2 / 2.0, np.where(falling, j1 * left**2 / 2.0, speed))
        acceleration = np.where(rising, j0 * t, np.where(falling, -j1 * left, acceleration))
        return position, speed, acceleration


class _DeferredModule(types.ModuleType):
    """A stand-in for module ``name`` while another package loads: any attribute read from it
    imports the real module then (once the stand-in has left ``sys.modules``) and reads it
    there, so code holding the stand-in behaves as with the real module."""

    def __getattr__(self, attribute: str) -> Any:
        if attribute.startswith("__") or sys.modules.get(self.__name__) is self:
            raise AttributeError(attribute)      # still standing in: `import a.b as c` reads c there
        return getattr(importlib.import_module(self.__name__), attribute)


def import_toppra() -> Any:
    """The ``toppra`` package with its ``algorithm`` and ``constraint`` modules, imported without
    matplotlib: toppra imports ``matplotlib.pyplot`` at load (about a second, most of a
    command's import time) for plotting helpers this project never calls. While toppra loads,
    ``matplotlib`` and ``matplotlib.pyplot`` (those not imported yet) are :class:`_DeferredModule`
    stand-ins, removed from ``sys.modules`` afterwards: toppra's plotting helpers, if called,
    import the real pyplot then; every other import of matplotlib is untouched."""
    if "toppra.algorithm" in sys.modules:
        return sys.modules["toppra"]
    stand_ins = {name: _DeferredModule(name) for name in ("matplotlib", "matplotlib.pyplot")
                 if name not in sys.modules}
    sys.modules.update(stand_ins)
    try:
        import toppra
        import toppra.algorithm
        import toppra.constraint
    finally:
        for name, stand_in in stand_ins.items():
            if sys.modules.get(name) is stand_in:
                del sys.modules[name]
    return toppra


def _toppra_profile(traj: JointTrajectory, vlim: np.ndarray, alim: np.ndarray, grid_per_interval: int,
                    ramp_time: float) -> tuple[_ChordPath, _RestToRestProfile, Callable[[np.ndarray], np.ndarray]]:
    """Rest-to-rest profile on the C2 spline through the samples, parameterised by chord length
    s [rad]: (path, profile, the map from s to the input's time [s] (piecewise linear between
    the knots)). Jerk-limited ramps at both ends, TOPP-RA between them starting and ending at
    the ramps' path speeds. Raises RetimingError when TOPP-RA fails."""
    toppra = import_toppra()

    path = _ChordPath(traj)
    s_knots, length = path.knots, path.length
    jerks = [_ramp_jerk(path, 0.0, 1.0, vlim, alim, ramp_time, length, float(s_knots[1])),
             _ramp_jerk(path, length, -1.0, vlim, alim, ramp_time, length, float(length - s_knots[-2]))]
    fractions = np.arange(grid_per_interval) / grid_per_interval
    grid = (s_knots[:-1, None] + np.diff(s_knots)[:, None] * fractions).ravel()
    v = np.where(np.isfinite(vlim), vlim, _UNBOUNDED_VELOCITY)
    a = np.where(np.isfinite(alim), alim, _UNBOUNDED_VELOCITY)
    constraints = [toppra.constraint.JointVelocityConstraint(np.column_stack((-v, v))),
                   toppra.constraint.JointAccelerationConstraint(
                       np.column_stack((-a, a)),
                       discretization_scheme=toppra.constraint.DiscretizationType.Interpolation)]
    for _ in range(6):  # a ramp too fast to continue from: slower ramps
        start, stop = jerks[0] * ramp_time**3 / 6.0, length - jerks[1] * ramp_time**3 / 6.0
        inner = grid[(grid > start) & (grid < stop)]
        instance = toppra.algorithm.TOPPRA(constraints, _SubPath(path, start, stop),
                                           gridpoints=np.concatenate(([start], inner, [stop])),
                                           solver_wrapper="seidel")
        instance.compute_parameterization(jerks[0] * ramp_time**2 / 2.0, jerks[1] * ramp_time**2 / 2.0)
        data = instance.problem_data
        if data.return_code == toppra.algorithm.ParameterizationReturnCode.Ok and data.sd_vec is not None:
            break
        jerks = [j / 2.0 for j in jerks]
    else:
        raise RetimingError(f"traj: TOPP-RA could not parameterise the path ({data.return_code})")
    s = np.asarray(data.gridpoints, dtype=float)
    sd = np.maximum(np.asarray(data.sd_vec, dtype=float), 0.0)
    speed_sum = sd[:-1] + sd[1:]
    if np.any(speed_sum <= 0.0) or not np.all(np.isfinite(sd)):
        raise RetimingError("traj: TOPP-RA returned a path speed of zero inside the path")
    times = np.concatenate(([0.0], np.cumsum(2.0 * np.diff(s) / speed_sum)))
    profile = _RestToRestProfile(0.0, length, (jerks[0], jerks[1]), ramp_time, s, sd, times)
    return path, profile, path.input_time


# --------------------------------------------------------------------------- ruckig
def _piece_maxima(path: _ChordPath) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact maxima of |q'|, |q''| [rad/rad^2], |q'''| over each knot interval of the path
    spline: three arrays (P, n), P = K - 1 pieces. On a piece q = c0 h^3 + c1 h^2 + c2 h + c3
    (h from the piece's start), q''' = 6 c0 is constant, q'' linear (largest at an end) and q'
    quadratic (largest at an end or at its vertex inside the piece)."""
    c = path.spline.c                                     # (4, P, n)
    h = np.diff(path.spline.x)[:, None]                   # (P, 1)
    m3 = np.abs(6.0 * c[0])
    m2 = np.maximum(np.abs(2.0 * c[1]), np.abs(6.0 * c[0] * h + 2.0 * c[1]))
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.where(c[0] != 0.0, -c[1] / (3.0 * c[0]), -1.0)
    inside = (vertex > 0.0) & (vertex < h)
    at_vertex = np.where(inside, np.abs(3.0 * c[0] * vertex**2 + 2.0 * c[1] * vertex + c[2]), 0.0)
    m1 = np.maximum(np.maximum(np.abs(c[2]), np.abs(3.0 * c[0] * h**2 + 2.0 * c[1] * h + c[2])), at_vertex)
    return m1, m2, m3


def _path_bounds(maxima: tuple[np.ndarray, np.ndarray, np.ndarray], vlim: np.ndarray, alim: np.ndarray,
                 jlim: np.ndarray, centripetal: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bounds (V, A, J) on the path speed, acceleration and jerk (each (P,), rad/s, rad/s^2,
    rad/s^3 of chord) under which every joint keeps its limits on a piece whose derivative
    maxima are M1, M2, M3 (P, n) (:func:`_piece_maxima`). With |s'| <= V, |s''| <= A,
    |s'''| <= J, on the piece
        |qdot|   = |q' s'|                          <= M1 V,
        |qddot|  = |q' s'' + q'' s'^2|              <= M1 A + M2 V^2,
        |qdddot| = |q' s''' + 3 q'' s' s'' + q''' s'^3| <= M1 J + 3 M2 V A + M3 V^3.
    V is the largest speed with M1 V <= vlim, M2 V^2 <= ``centripetal`` alim and M3 V^3 <= jlim/3;
    A takes the rest of the acceleration limit and at most jlim/3 for 3 M2 V A; J the rest of
    the jerk limit. Infinite bounds are capped at 1e6."""
    m1, m2, m3 = maxima
    with np.errstate(divide="ignore", invalid="ignore"):
        speed = np.minimum(np.minimum(vlim / m1, np.sqrt(centripetal * alim / m2)), np.cbrt(jlim / (3.0 * m3)))
        V = np.minimum(speed.min(axis=1), _UNBOUNDED_VELOCITY)[:, None]
        accel = np.minimum((alim - m2 * V**2) / m1, jlim / (9.0 * m2 * V))
        A = np.minimum(accel.min(axis=1), _UNBOUNDED_VELOCITY)[:, None]
        J = np.minimum(((jlim - 3.0 * m2 * V * A - m3 * V**3) / m1).min(axis=1), _UNBOUNDED_VELOCITY)
    return V[:, 0], A[:, 0], J


def _windows(V: np.ndarray, A: np.ndarray, J: np.ndarray, similarity: float) -> np.ndarray:
    """Breaks (W + 1,) that cut the pieces (P,) into W windows of consecutive pieces whose
    bounds each stay within a factor ``similarity`` (0 < similarity < 1) of one another; the
    window's bounds are then the smallest of its pieces'."""
    breaks = [0]
    low = high = np.array([V[0], A[0], J[0]])
    for i in range(1, len(V)):
        here = np.array([V[i], A[i], J[i]])
        lower, higher = np.minimum(low, here), np.maximum(high, here)
        if np.all(lower >= similarity * higher):
            low, high = lower, higher
        else:
            breaks.append(i)
            low = high = here
    return np.array(breaks + [len(V)])


def _s_curve_distance(v0: float, v1: float, A: float, J: float) -> float:
    """Distance covered by the jerk-limited change of speed from v0 to v1 (acceleration zero
    at both ends, |acceleration| <= A, |jerk| <= J): mean speed (v0 + v1) / 2 times its
    duration, 2 sqrt(dv / J) or dv / A + A / J."""
    dv = abs(v1 - v0)
    duration = 2.0 * math.sqrt(dv / J) if dv <= A * A / J else dv / A + A / J
    return 0.5 * (v0 + v1) * duration


def _reachable_speed(v0: float, length: float, V: float, A: float, J: float) -> float:
    """Largest speed v1 <= V [/s] that a window of ``length`` reaches from speed v0 (either
    way: the distance is symmetric in v0, v1), by bisection on :func:`_s_curve_distance`
    with a relative margin of 1e-6 on the length."""
    room = length * (1.0 - 1e-6)
    if _s_curve_distance(v0, V, A, J) <= room:
        return V
    low, high = min(v0, V), V          # the reachable speeds: an interval around v0
    for _ in range(80):
        middle = 0.5 * (low + high)
        if _s_curve_distance(v0, middle, A, J) <= room:
            low = middle
        else:
            high = middle
    return low


def _boundary_speeds(lengths: np.ndarray, V: np.ndarray, A: np.ndarray, J: np.ndarray) -> np.ndarray:
    """Path speeds (W + 1,) at the window boundaries: zero at both ends, at most both adjacent
    windows' V, and each window able to join its two (a forward and a backward pass)."""
    count = len(lengths)
    speed = np.concatenate(([0.0], np.minimum(V[:-1], V[1:]), [0.0]))
    for k in range(count):
        speed[k + 1] = min(speed[k + 1], _reachable_speed(speed[k], lengths[k], V[k], A[k], J[k]))
    for k in range(count - 1, -1, -1):
        speed[k] = min(speed[k], _reachable_speed(speed[k + 1], lengths[k], V[k], A[k], J[k]))
    return speed


class _PathTiming:
    """Path position s(t) [rad of chord] from rest at 0 to rest at ``stop``: one ruckig
    trajectory per window of the path, from (s_k, speed v_k, acceleration 0) to
    (s_k+1, v_k+1, 0) within the window's bounds; the same interface as _RestToRestProfile."""

    def __init__(self, stop: float, trajectories: list[Any]):
        self.start, self.stop, self.trajectories = 0.0, stop, trajectories
        self.starts = np.concatenate(([0.0], np.cumsum([tr.duration for tr in trajectories])))

    @property
    def duration(self) -> float:
        """Length [s] of the timing."""
        return float(self.starts[-1])

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Path position, speed [/s] and acceleration [/s^2] at times t (K,) in [0, duration];
        exactly at rest at both ends."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        window = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.trajectories) - 1)
        out = np.zeros((3, len(t)))
        for i, (k, time) in enumerate(zip(window.tolist(), (t - self.starts[window]).tolist())):
            position, speed, acceleration = self.trajectories[k].at_time(time)
            out[:, i] = position[0], speed[0], acceleration[0]
        rest = (t <= 0.0) | (t >= self.duration)
        out[0] = np.clip(out[0], self.start, self.stop)
        out[0, t <= 0.0], out[0, t >= self.duration] = self.start, self.stop
        out[1:, rest] = 0.0
        return out[0], out[1], out[2]


def _ruckig_timing(path: _ChordPath, maxima: tuple[np.ndarray, np.ndarray, np.ndarray], vlim: np.ndarray,
                   alim: np.ndarray, jlim: np.ndarray, centripetal: float, similarity: float) -> _PathTiming:
    """Jerk-limited timing of the path by ruckig: bounds per piece (:func:`_path_bounds`, less
    the relative margin _RUCKIG_MARGIN), pieces grouped into windows (:func:`_windows`), speeds
    at the window boundaries (:func:`_boundary_speeds`), then a 1-DOF ruckig problem per
    window (time-optimal within its bounds, never moving backwards). Raises RetimingError when
    ruckig finds no trajectory."""
    import ruckig           # deferred: ruckig loads only for a jerk-limited retiming

    V, A, J = _path_bounds(maxima, vlim, alim, jlim, centripetal)
    breaks = _windows(V, A, J, similarity)
    V, A, J = (np.minimum.reduceat(bound, breaks[:-1]) * (1.0 - _RUCKIG_MARGIN) for bound in (V, A, J))
    edges = path.knots[breaks]
    edges[-1] = path.length
    speeds = _boundary_speeds(np.diff(edges), V, A, J)
    generator = ruckig.Ruckig(1)
    trajectories = []
    for k in range(len(V)):
        problem = ruckig.InputParameter(1)
        problem.current_position, problem.target_position = [float(edges[k])], [float(edges[k + 1])]
        problem.current_velocity, problem.target_velocity = [float(speeds[k])], [float(speeds[k + 1])]
        problem.current_acceleration, problem.target_acceleration = [0.0], [0.0]
        problem.max_velocity, problem.min_velocity = [float(V[k])], [0.0]
        problem.max_acceleration, problem.max_jerk = [float(A[k])], [float(J[k])]
        trajectory = ruckig.Trajectory(1)
        try:
            result = generator.calculate(problem, trajectory)
        except RuntimeError as exc:
            raise RetimingError(f"traj: ruckig rejected the timing of path window {k}: {exc}") from None
        if result not in (ruckig.Result.Working, ruckig.Result.Finished):
            raise RetimingError(f"traj: ruckig found no timing for path window {k} ({result})")
        trajectories.append(trajectory)
    return _PathTiming(path.length, trajectories)


def _jerk_limited(traj: JointTrajectory, vlim: np.ndarray, alim: np.ndarray, jlim: np.ndarray,
                  sample_period: float, stretch_to: float) -> tuple[_ChordPath, _PathTiming, JointTrajectory, float]:
    """Jerk-limited rest-to-rest retiming along the path: the fastest of the ruckig timings for
    the settings _RUCKIG_SETTINGS, sampled every <= ``sample_period`` s and checked
    (:func:`check_limits` with the jerk limits); a sampled violation shrinks every limit the
    bounds are derived from by _RUCKIG_SHRINK and starts again (at most _RUCKIG_ATTEMPTS
    times, then RetimingError). Returns (path, timing, sampled trajectory before stretching,
    uniform stretch >= 1 that makes it last at least ``stretch_to`` s)."""
    path = _ChordPath(traj)
    maxima = _piece_maxima(path)
    factor = 1.0
    for attempt in range(_RUCKIG_ATTEMPTS):
        timings = [_ruckig_timing(path, maxima, factor * vlim, factor * alim, factor * jlim, centripetal, similarity)
                   for centripetal, similarity in _RUCKIG_SETTINGS]
        timing = min(timings, key=lambda candidate: candidate.duration)
        stretch = max(1.0, stretch_to / timing.duration)
        count = max(int(math.ceil(timing.duration * stretch / sample_period)), 1) + 1
        sampled = _sampled_profile(traj, path, timing, count)
        check = check_limits(sampled, vlim, alim, jerk_limits=jlim)
        if check.within_limits:
            return path, timing, sampled, stretch
        logger.info("retime: ruckig timing attempt %d violates %s; shrinking the path bounds",
                    attempt + 1, "; ".join(check.violations()))
        factor *= _RUCKIG_SHRINK
    raise RetimingError(f"traj: no jerk-limited timing within the limits after {_RUCKIG_ATTEMPTS} attempts "
                        f"({'; '.join(check.violations())})")


def _sampled_profile(traj: JointTrajectory, path: _ChordPath, profile: _RestToRestProfile | _PathTiming,
                     count: int) -> JointTrajectory:
    """The smoothed profile sampled at `count` equally spaced times, from the input's first
    position to its last, at rest at both ends; velocities and accelerations are the exact
    derivatives of the spline path under the profile (path' sd, path'' sd^2 + path' sdd)."""
    t = np.linspace(0.0, profile.duration, count)
    position, speed, acceleration = profile(t)
    position[0], position[-1] = profile.start, profile.stop
    tangent = path(position, 1)
    q = path(position)
    qdot = tangent * speed[:, None]
    qddot = path(position, 2) * speed[:, None] ** 2 + tangent * acceleration[:, None]
    q[0], q[-1] = traj.positions[0], traj.positions[-1]
    return traj.replace(time_from_start=t, positions=q, velocities=qdot, accelerations=qddot)


def _distance_to_polyline(points: np.ndarray, vertices: np.ndarray, first: np.ndarray, last: np.ndarray) -> np.ndarray:
    """Distance (P,) from each point (P, d) to the polyline through vertices (M, d), over the
    segments first[p] .. last[p] (inclusive) of that point."""
    count = int((last - first).max()) + 1
    j = np.minimum(first[:, None] + np.arange(count), last[:, None])
    a, ab = vertices[j], vertices[j + 1] - vertices[j]                       # (P, count, d)
    w = np.clip(np.einsum("pcd,pcd->pc", points[:, None] - a, ab)
                / np.maximum(np.einsum("pcd,pcd->pc", ab, ab), 1e-300), 0.0, 1.0)
    return np.linalg.norm(points[:, None] - (a + w[..., None] * ab), axis=-1).min(axis=1)


def _deviation(robot, original: JointTrajectory, retimed: JointTrajectory,
               path_position: Callable[[np.ndarray], np.ndarray], substeps: int,
               density: int = 16) -> tuple[float, float]:
    """Max joint-space (rad, Euclidean) and end-effector (m) distance from the retimed motion to
    the original path, both cubic-Hermite interpolated: the retimed motion on a dense grid
    (``substeps`` points per retimed interval), each point's distance to the original at its
    corresponding path position or, if nearer, to the original path sampled ``density`` points
    per input interval, from the moving input interval before that position to the one after
    (the retimed path may pass a sample at a slightly different time than the original, and
    skips pauses: a distance to the path, not a timing error)."""
    from scipy.interpolate import CubicHermiteSpline
    t = retimed.time_from_start
    fractions = np.arange(substeps) / substeps
    dense = np.append((t[:-1, None] + np.diff(t)[:, None] * fractions).ravel(), t[-1])
    q_new = CubicHermiteSpline(t, retimed.positions, retimed.velocities)(dense)
    t0 = original.time_from_start
    s = np.clip(path_position(dense), t0[0], t0[-1])
    hermite = CubicHermiteSpline(t0, original.positions, original.velocities)
    reference = hermite(s)
    t_path = np.append((t0[:-1, None] + np.diff(t0)[:, None] * (np.arange(density) / density)).ravel(), t0[-1])
    q_path = hermite(t_path)
    interval = np.clip(np.searchsorted(t0, s, side="right") - 1, 0, len(t0) - 2)
    moving = np.flatnonzero(_moving(original.positions))
    if len(moving) == 0:
        moving = np.arange(len(t0) - 1)
    before = moving[np.maximum(np.searchsorted(moving, interval) - 1, 0)]
    after = moving[np.minimum(np.searchsorted(moving, interval, side="right"), len(moving) - 1)]
    first = np.minimum(before, interval) * density
    last = (np.maximum(after, interval) + 1) * density - 1
    joint = np.minimum(np.linalg.norm(q_new - reference, axis=-1),
                       _distance_to_polyline(q_new, q_path, first, last))
    ee_new = robot.fk(q_new)
    ee = np.minimum(np.linalg.norm(ee_new - robot.fk(reference), axis=-1),
                    _distance_to_polyline(ee_new, robot.fk(q_path), first, last))
    return float(joint.max()), float(ee.max())


def retime(traj: JointTrajectory, robot, acceleration_limits: Any = None, method: str = "auto", *,
           velocity_limits: Any = None, sample_period: float = DEFAULT_SAMPLE_PERIOD,
           allow_faster: bool = True, ramp_time: float = DEFAULT_RAMP_TIME, grid_per_interval: int = 4,
           substeps: int = 4, jerk_limits: Any = None) -> tuple[JointTrajectory, RetimingReport]:
    """Retime `traj` for `robot` so that it respects velocity, acceleration (and jerk) limits.

    traj: JointTrajectory with robot.joint_names; acceleration_limits: scalar or (n,) rad/s^2
    (None = DEFAULT_ACCELERATION_LIMIT); velocity_limits: (n,) rad/s (None = robot.velocity_limits);
    method: "auto" | "uniform" | "toppra" | "ruckig" (see the module docstring); jerk_limits:
    scalar or (n,) rad/s^3, required by "ruckig" and only taken by it ("auto" with jerk limits
    is "ruckig"); sample_period: max spacing [s] of the toppra / ruckig output samples;
    allow_faster: if False the result never takes less time than the input (stretched
    uniformly when it would); ramp_time: duration [s] of the toppra profile's jerk-limited
    ramps at both ends; grid_per_interval: TOPP-RA grid points per input interval; substeps:
    interpolation points per output interval for the deviation.
    Returns (retimed trajectory starting at 0 s, RetimingReport); the retimed verdict is the
    input's plus "retiming": report.to_dict(). "ruckig" raises RetimingError rather than
    return a trajectory outside the limits.
    """
    traj = _as_trajectory(traj)
    if method not in METHODS:
        raise RetimingError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    if tuple(traj.joint_names) != tuple(robot.joint_names):
        raise RetimingError(f"traj: joint_names {list(traj.joint_names)} do not match the robot's "
                            f"{list(robot.joint_names)}")
    if not isinstance(sample_period, (int, float)) or isinstance(sample_period, bool) or \
            not math.isfinite(sample_period) or sample_period <= 0:
        raise RetimingError(f"sample_period: expected a positive number of seconds, got {sample_period!r}")
    if not isinstance(ramp_time, (int, float)) or isinstance(ramp_time, bool) or \
            not math.isfinite(ramp_time) or ramp_time <= 0:
        raise RetimingError(f"ramp_time: expected a positive number of seconds, got {ramp_time!r}")
    for name, value in (("grid_per_interval", grid_per_interval), ("substeps", substeps)):
        if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < 1:
            raise RetimingError(f"{name}: expected a positive int, got {value!r}")
    vlim = _as_limits(robot.velocity_limits if velocity_limits is None else velocity_limits, "velocity_limits", traj.n)
    alim = acceleration_limits_for(traj.n, acceleration_limits)
    jlim = jerk_limits_for(traj.n, jerk_limits)
    if method == "auto" and jerk_limits is not None:
        method = "ruckig"
    if method == "ruckig" and jerk_limits is None:
        raise RetimingError("jerk_limits: method 'ruckig' needs jerk limits [rad/s^3], a positive number or "
                            "one per joint")
    if method not in ("ruckig", "auto") and jerk_limits is not None:
        raise RetimingError(f"jerk_limits: only method 'ruckig' (or 'auto') limits the jerk, got method {method!r}")
    automatic = method == "auto"
    if automatic:
        method = "toppra" if toppra_available() else "uniform"
        if method == "uniform":
            logger.warning("retime: toppra is not installed; using uniform time scaling")
    if method == "toppra" and not toppra_available():
        raise RetimingError("method: 'toppra' needs the toppra package (pip install toppra)")

    start = traj.time_from_start[0]
    zeroed = traj.replace(time_from_start=traj.time_from_start - start) if start != 0.0 else traj
    before = check_limits(zeroed, vlim, alim, jerk_limits=jlim)
    k_uniform = uniform_scaling(zeroed, vlim, alim)
    stretch = 1.0
    if k_uniform == 0.0:  # motionless: nothing to time
        retimed, path_position = zeroed, (lambda t: t)
    elif method == "uniform":
        stretch = k_uniform if allow_faster else max(k_uniform, 1.0)
        retimed = scale_time(zeroed, stretch)
        path_position = (lambda t, k=stretch: t / k)
    elif method == "ruckig":
        path, timing, candidate, stretch = _jerk_limited(zeroed, vlim, alim, jlim, float(sample_period),
                                                         0.0 if allow_faster else zeroed.duration)
        retimed = scale_time(candidate, stretch) if stretch != 1.0 else candidate
        if stretch != 1.0:
            logger.info("retime: stretched the ruckig result uniformly by %.6g to the input's duration", stretch)
        path_position = (lambda tt, k=stretch: path.input_time(timing(tt / k)[0]))
    else:
        try:
            path, profile, input_time = _toppra_profile(zeroed, vlim, alim, int(grid_per_interval),
                                                        float(ramp_time))
        except RetimingError as exc:
            if not automatic:
                raise
            logger.warning("retime: %s; falling back to uniform time scaling", exc)
            return retime(traj, robot, acceleration_limits, "uniform", velocity_limits=velocity_limits,
                          sample_period=sample_period, allow_faster=allow_faster, ramp_time=ramp_time,
                          grid_per_interval=grid_per_interval, substeps=substeps)
        # sample the profile; a final uniform stretch removes violations left between TOPP-RA's
        # grid points; resample densely enough that the stretched spacing stays <= sample_period
        for _ in range(4):
            count = max(int(math.ceil(profile.duration * stretch / sample_period)), 1) + 1
            candidate = _sampled_profile(zeroed, path, profile, count)
            stretch = max(uniform_scaling(candidate, vlim, alim), 1.0)
            if not allow_faster and candidate.duration * stretch < zeroed.duration:
                stretch = zeroed.duration / candidate.duration
            if profile.duration / (count - 1) * stretch <= sample_period * (1.0 + 1e-12):
                break
        retimed = scale_time(candidate, stretch) if stretch != 1.0 else candidate
        if stretch != 1.0:
            logger.info("retime: stretched the TOPP-RA result uniformly by %.6g", stretch)
        path_position = (lambda tt, k=stretch: input_time(profile(tt / k)[0]))
    joint_dev, ee_dev = _deviation(robot, zeroed, retimed, path_position, int(substeps))
    report = RetimingReport(method=method, duration_before=zeroed.duration, duration_after=retimed.duration,
                            before=before, after=check_limits(retimed, vlim, alim, jerk_limits=jlim),
                            scaling_factor=float(stretch),
                            max_joint_deviation=joint_dev, max_ee_deviation=ee_dev,
                            num_points_before=traj.num_points, num_points_after=retimed.num_points,
                            within_position_limits=bool(np.all(robot.within_limits(retimed.positions))))
    verdict = dict(traj.verdict)
    verdict["retiming"] = report.to_dict()
    retimed = retimed.replace(verdict=verdict)
    if not report.within_limits:  # cannot happen short of round-off; say so loudly
        logger.warning("retime: result still violates limits: %s", "; ".join(report.after.violations()))
    return retimed, report
