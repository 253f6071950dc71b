"""A set of M demonstrations sharing one time axis: positions and velocities (M,T,3), time (T,);
optionally the joint trajectories (M,T,n) they were recorded as (kinesthetic teaching)."""
from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

from .alignment import dtw_warp
from .errors import (ScenesTypeError, DemonstrationFileError, InvalidDemonstrationsError,
                     InvalidObstacleError)
from .obstacles import Obstacle, obstacle_from_dict
from .quaternions import (QUATERNION_TOLERANCE, checked_quaternions, continuous_quaternions,  # noqa: F401
                          quaternions_from_matrices, slerp_quaternions, unit_quaternions)
# QUATERNION_TOLERANCE, continuous_quaternions, slerp_quaternions: still importable from here
from skillplan.validation import (MAX_COORDINATE, as_array, as_count, as_file, as_path, as_positive, as_sequence,
                         as_time, as_vector)

#: Duration (s) given to demonstrations recorded without time stamps (e.g. TLGC smoothData).
NOMINAL_DURATION = 10.0

_E = InvalidDemonstrationsError
_SAME = object()


def _check_time(time: Any, name: str, length: int) -> np.ndarray:
    t = as_array(time, name, _E)
    if t.ndim == 2 and 1 in t.shape:
        t = t.reshape(-1)
    if t.shape != (length,):
        raise _E(f"{name}: expected shape ({length},) to match the positions, got {t.shape}")
    return as_time(t, name, length, _E)


def _check_obstacles(obstacles: Any, count: int) -> list[list[Obstacle]] | None:
    if obstacles is None:
        return None
    obstacles = as_sequence(obstacles, "obstacles", "one list of obstacles per demonstration", _E)
    if len(obstacles) != count:
        raise _E(f"obstacles: expected one list per demonstration ({count}), got {len(obstacles)}")
    out = []
    for m, group in enumerate(obstacles):
        group = as_sequence(group, f"obstacles[{m}]", "a list of the obstacles of demonstration "
                            f"{m} (obstacles holds one list per demonstration)", _E)
        for k, ob in enumerate(group):
            if not isinstance(ob, Obstacle):
                raise _E(f"obstacles[{m}][{k}]: expected a Box, Sphere or Cylinder, got {type(ob).__name__}")
        out.append(group)
    return out


def _check_joints(joint_positions: Any, joint_names: Any,
                  shape: tuple[int, int]) -> tuple[np.ndarray | None, tuple[str, ...] | None]:
    if joint_positions is None:
        if joint_names is not None:
            raise _E("joint_names: given without joint_positions")
        return None, None
    q = as_array(joint_positions, "joint_positions", _E, MAX_COORDINATE)
    if q.ndim != 3 or q.shape[:2] != shape or q.shape[2] < 1:
        raise _E(f"joint_positions: expected shape ({shape[0]}, {shape[1]}, n) like the "
                 f"positions (M, T) with n >= 1 joints, got {q.shape}")
    names = as_sequence(joint_names, "joint_names", f"{q.shape[2]} joint names (str)", _E)
    if len(names) != q.shape[2] or not all(isinstance(n, str) for n in names):
        raise _E(f"joint_names: expected {q.shape[2]} joint names (str), one per column of "
                 f"joint_positions, got {list(names)!r:.200}")
    return q, tuple(str(n) for n in names)


def _check_orientations(orientations: Any, shape: tuple[int, int]) -> np.ndarray | None:
    """(M,T,4) unit quaternions (x, y, z, w), normalised and sign-continuous along each
    demonstration (q and -q are one rotation; the one nearer the previous sample is kept)."""
    if orientations is None:
        return None
    o = as_array(orientations, "orientations", _E)
    if o.ndim != 3 or o.shape[:2] != shape or o.shape[2] != 4:
        raise _E(f"orientations: expected shape ({shape[0]}, {shape[1]}, 4) like the positions "
                 f"(M, T) with quaternions (x, y, z, w), got {o.shape}")
    return continuous_quaternions(unit_quaternions(o, "orientations", _E))


class Demonstrations:
    """M demonstrations on a common time axis.

    positions (M,T,3) m, velocities (M,T,3) m/s, time (T,) s strictly increasing,
    obstacles: per demonstration a list of the obstacles present (or None), name: label;
    joint_positions (M,T,n) rad and joint_names (n,): the joint trajectories the
    demonstrations were recorded as (None for end-effector recordings; see
    scenes.joint_demonstrations), kept for the planner's initialisation;
    orientations (M,T,4): the hand's rotation at every sample as unit quaternions
    (x, y, z, w), sign-continuous along each demonstration (None for position-only
    recordings).
    Requires M >= 2 and T >= 2; raises InvalidDemonstrationsError naming what is wrong.
    """

    def __init__(self, positions: Any, velocities: Any, time: Any,
                 obstacles: Sequence[Sequence[Obstacle]] | None = None, name: str = "", *,
                 joint_positions: Any = None, joint_names: Sequence[str] | None = None,
                 orientations: Any = None):
        p = as_array(positions, "positions", _E, MAX_COORDINATE)
        if p.ndim != 3:
            raise _E(f"positions: expected rank 3 (M demonstrations, T steps, 3), got shape {p.shape}")
        if p.shape[-1] != 3:
            raise _E(f"positions: expected last dimension 3 (x, y, z), got shape {p.shape}")
        if p.shape[0] < 2:
            raise _E(f"positions: expected at least 2 demonstrations, got {p.shape[0]}")
        if p.shape[1] < 2:
            raise _E(f"positions: expected at least 2 time steps, got {p.shape[1]}")
        v = as_array(velocities, "velocities", _E, MAX_COORDINATE)
        if v.shape != p.shape:
            raise _E(f"velocities: expected shape {p.shape} like positions, got {v.shape}")
        self.positions = p
        self.velocities = v
        self.time = _check_time(time, "time", p.shape[1])
        self.obstacles = _check_obstacles(obstacles, p.shape[0])
        self.name = str(name)
        self.joint_positions, self.joint_names = _check_joints(joint_positions, joint_names,
                                                               p.shape[:2])
        self.orientations = _check_orientations(orientations, p.shape[:2])

    # -- basic properties -------------------------------------------------------------
    @property
    def M(self) -> int:
        """Number of demonstrations."""
        return self.positions.shape[0]

    @property
    def T(self) -> int:
        """Number of time steps."""
        return self.positions.shape[1]

    @property
    def dt(self) -> float:
        """Median time step (s): the exact step for uniform time, and the nominal step of
        recordings with a few irregular stamps (box_closing.mat: 0.16 s, with nine 0.08 s steps)."""
        return float(np.median(np.diff(self.time)))

    @property
    def duration(self) -> float:
        """time[-1] - time[0] in seconds."""
        return float(self.time[-1] - self.time[0])

    @property
    def states(self) -> np.ndarray:
        """Workspace states (M,T,6) = [position, velocity]."""
        return np.concatenate([self.positions, self.velocities], axis=-1)

    def mean_position(self) -> np.ndarray:
        """Pointwise mean position (T,3) over the demonstrations."""
        return self.positions.mean(axis=0)

    def __len__(self) -> int:
        return self.M

    def __repr__(self) -> str:
        return f"Demonstrations(name={self.name!r}, M={self.M}, T={self.T}, dt={self.dt:.4g})"

    def _replace(self, positions: np.ndarray, velocities: np.ndarray, time: np.ndarray,
                 obstacles: Any = _SAME, joint_positions: Any = _SAME,
                 orientations: Any = _SAME) -> "Demonstrations":
        joints = self.joint_positions if joint_positions is _SAME else joint_positions
        return Demonstrations(positions, velocities, time,
                              self.obstacles if obstacles is _SAME else obstacles, self.name,
                              joint_positions=joints,
                              joint_names=None if joints is None else self.joint_names,
                              orientations=(self.orientations if orientations is _SAME
                                            else orientations))

    # -- transformations ---------------------------------------------------------------
    def resample(self, T: int) -> "Demonstrations":
        """T uniformly spaced steps over the same time span; positions, velocities (and joint
        trajectories) are each interpolated by a cubic spline in time."""
        T = as_count(T, "T", 2, _E)
        new_time = np.linspace(self.time[0], self.time[-1], T)
        pos = CubicSpline(self.time, self.positions, axis=1)(new_time)
        vel = CubicSpline(self.time, self.velocities, axis=1)(new_time)
        joints = (None if self.joint_positions is None
                  else CubicSpline(self.time, self.joint_positions, axis=1)(new_time))
        turns = (None if self.orientations is None else np.stack(
            [slerp_quaternions(self.time, q, new_time) for q in self.orientations]))
        return self._replace(pos, vel, new_time, joint_positions=joints, orientations=turns)

    def align_dtw(self, reference: int = 0) -> "Demonstrations":
        """Warp every demonstration onto demonstration ``reference``'s time axis by DTW.

        Each demonstration is re-sampled (cubic spline over its sample index) at the fractional
        indices matched to the reference's steps (see alignment.dtw_warp); velocities are the
        time derivative of a cubic spline through the warped positions; joint trajectories are
        warped alike. The reference is unchanged.
        """
        if isinstance(reference, bool) or not isinstance(reference, (int, np.integer)) \
                or not -self.M <= reference < self.M:
            raise _E(f"reference: expected a demonstration index in [0, {self.M}), got {reference!r}")
        ref = self.positions[reference]
        index = np.arange(self.T)
        pos = self.positions.copy()
        vel = self.velocities.copy()
        joints = None if self.joint_positions is None else self.joint_positions.copy()
        turns = None if self.orientations is None else self.orientations.copy()
        for m in range(self.M):
            if m == reference % self.M:
                continue
            warp = dtw_warp(ref, self.positions[m])
            pos[m] = CubicSpline(index, self.positions[m], axis=0)(warp)
            vel[m] = CubicSpline(self.time, pos[m], axis=0)(self.time, 1)
            if joints is not None:
                joints[m] = CubicSpline(index, self.joint_positions[m], axis=0)(warp)
            if turns is not None:
                turns[m] = slerp_quaternions(index, self.orientations[m], warp)
        return self._replace(pos, vel, self.time, joint_positions=joints, orientations=turns)

    def translated(self, offset: Any) -> "Demonstrations":
        """Every position and recorded obstacle moved by offset (3,) metres; joint trajectories
        are dropped (the arm did not make the moved paths)."""
        offset = as_vector(offset, "offset", 3, _E)
        obstacles = None if self.obstacles is None else [[ob.translated(offset) for ob in group]
                                                         for group in self.obstacles]
        return self._replace(self.positions + offset, self.velocities, self.time, obstacles,
                             joint_positions=None)

    def transformed(self, rotation: Any, offset: Any) -> "Demonstrations":
        """The whole set moved rigidly: every position p becomes rotation @ p + offset (3,) [m],
        velocities and the hand's rotations turn with it (rotation (3, 3), a proper rotation
        within 1e-2); e.g. to place a recorded set (``wiping_rim``) in an arm's workspace.
        Joint trajectories are dropped (the arm did not make the moved paths); recorded
        obstacles are moved by ``translated`` only (InvalidDemonstrationsError naming
        ``rotation`` for a set with obstacles and a rotation other than the identity)."""
        R = Rotation.from_quat(quaternions_from_matrices(rotation, "rotation", _E)).as_matrix()
        offset = as_vector(offset, "offset", 3, _E)
        if self.obstacles is not None and not np.allclose(R, np.eye(3), atol=1e-12):
            raise _E("rotation: expected the identity for demonstrations with recorded obstacles "
                     "(obstacles are moved by translated(offset) only)")
        turns = None if self.orientations is None else (
            Rotation.from_matrix(R) * Rotation.from_quat(self.orientations.reshape(-1, 4))
        ).as_quat().reshape(self.orientations.shape)
        moved = self._replace(self.positions @ R.T, self.velocities @ R.T, self.time,
                              joint_positions=None, orientations=turns)
        return moved.translated(offset)

    # -- construction ------------------------------------------------------------------
    @classmethod
    def from_trajectories(cls, trajectories: Sequence[Any], times: Sequence[Any] | None = None,
                          num_points: int | None = None, *, velocities: Sequence[Any] | None = None,
                          obstacles: Sequence[Sequence[Obstacle]] | None = None, name: str = "",
                          duration: float | None = None, joint_positions: Sequence[Any] | None = None,
                          joint_names: Sequence[str] | None = None,
                          orientations: Sequence[Any] | None = None) -> "Demonstrations":
        """Demonstrations from M position arrays (T_m,3) of possibly unequal length.

        Each demonstration's time is normalised to its own duration (phase s in [0,1]) and
        resampled by a cubic spline at ``num_points`` (default: the longest T_m) uniform phases.
        The common time axis spans the mean duration. ``times`` (T_m,) per demonstration;
        without them every demonstration lasts ``duration`` (default NOMINAL_DURATION s).
        Velocities: given ones (T_m,3) are spline-resampled and scaled by D_m / D_mean so they
        stay the derivative of the re-timed positions; otherwise the spline's time derivative.
        joint_positions: (T_m, n) per trajectory [rad], resampled like the positions, with
        joint_names (n,). orientations: (T_m, 4) unit quaternions (x, y, z, w) per trajectory,
        checked and repaired as :mod:`scenes.quaternions` says (an error naming
        ``orientations[m][k]`` when not unit, a warning naming it for a turn faster than
        MAX_ANGULAR_SPEED at the recorded times) and resampled by slerp at the same phases.
        """
        trajectories = as_sequence(trajectories, "trajectories", "a list of (T_m, 3) position "
                                   "arrays", ScenesTypeError)
        if len(trajectories) < 2:
            raise _E(f"trajectories: expected at least 2 demonstrations, got {len(trajectories)}")
        paths = []
        for m, traj in enumerate(trajectories):
            p = as_array(traj, f"trajectories[{m}]", _E, MAX_COORDINATE)
            if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 2:
                raise _E(f"trajectories[{m}]: expected shape (T_m >= 2, 3), got {p.shape}")
            paths.append(p)
        if times is not None:
            times = as_sequence(times, "times", "one (T_m,) time array per trajectory", _E)
            if len(times) != len(paths):
                raise _E(f"times: expected {len(paths)} arrays (one per trajectory), got {len(times)}")
            stamps = [_check_time(t, f"times[{m}]", len(p)) for m, (t, p) in enumerate(zip(times, paths))]
        else:
            total = NOMINAL_DURATION if duration is None else as_positive(duration, "duration", _E)
            stamps = [np.linspace(0.0, total, len(p)) for p in paths]
        if velocities is not None:
            velocities = as_sequence(velocities, "velocities", "one (T_m, 3) array per trajectory", _E)
            if len(velocities) != len(paths):
                raise _E(f"velocities: expected {len(paths)} arrays, got {len(velocities)}")
            velocities = [as_array(v, f"velocities[{m}]", _E, MAX_COORDINATE)
                          for m, v in enumerate(velocities)]
            for m, (v, p) in enumerate(zip(velocities, paths)):
                if v.shape != p.shape:
                    raise _E(f"velocities[{m}]: expected shape {p.shape} like trajectories[{m}], got {v.shape}")
        T = max(len(p) for p in paths) if num_points is None else as_count(num_points, "num_points", 2, _E)
        durations = np.array([t[-1] - t[0] for t in stamps])
        mean_duration = float(durations.mean())
        phase = np.linspace(0.0, 1.0, T)
        if joint_positions is not None:
            joint_positions = as_sequence(joint_positions, "joint_positions",
                                          "one (T_m, n) array per trajectory", _E)
            if len(joint_positions) != len(paths) or any(
                    np.shape(q)[:1] != (len(p),) for q, p in zip(joint_positions, paths)):
                raise _E(f"joint_positions: expected {len(paths)} arrays of (T_m, n), one per "
                         "trajectory and as long as it")
        if orientations is not None:
            orientations = as_sequence(orientations, "orientations",
                                       "one (T_m, 4) quaternion array per trajectory", _E)
            if len(orientations) != len(paths):
                raise _E(f"orientations: expected {len(paths)} arrays of (T_m, 4) quaternions "
                         f"(x, y, z, w), one per trajectory, got {len(orientations)}")
            orientations = [checked_quaternions(o, t, f"orientations[{m}]", _E, name)
                            for m, (o, t) in enumerate(zip(orientations, stamps))]
        pos = np.empty((len(paths), T, 3))
        vel = np.empty_like(pos)
        joints, turns = [], []
        for m, (p, t) in enumerate(zip(paths, stamps)):
            s = as_time((t - t[0]) / durations[m], f"times[{m}] / duration", len(t), _E)
            spline = CubicSpline(s, p, axis=0)
            pos[m] = spline(phase)
            if velocities is None:
                vel[m] = spline(phase, 1) / mean_duration
            else:
                vel[m] = CubicSpline(s, velocities[m], axis=0)(phase) * durations[m] / mean_duration
            if joint_positions is not None:
                joints.append(CubicSpline(s, np.asarray(joint_positions[m], float), axis=0)(phase))
            if orientations is not None:
                turns.append(slerp_quaternions(s, orientations[m], phase))
        return cls(pos, vel, phase * mean_duration, obstacles, name,
                   joint_positions=None if joint_positions is None else np.stack(joints),
                   joint_names=joint_names,
                   orientations=None if orientations is None else np.stack(turns))

    # -- storage -----------------------------------------------------------------------
    def save_npz(self, path: str | Path) -> None:
        """Write positions, velocities, time, name, obstacles (JSON text), the joint
        trajectories (joint_positions, joint_names; when recorded) and the orientations
        (M,T,4) quaternions (x, y, z, w; when recorded) to an .npz file."""
        obstacles = "null" if self.obstacles is None else json.dumps(
            [[ob.to_dict() for ob in group] for group in self.obstacles])
        joints = {} if self.joint_positions is None else {
            "joint_positions": self.joint_positions, "joint_names": np.array(self.joint_names)}
        if self.orientations is not None:
            joints["orientations"] = self.orientations
        np.savez_compressed(as_path(path, "path", ScenesTypeError), positions=self.positions, velocities=self.velocities, time=self.time,
                            name=np.array(self.name), obstacles=np.array(obstacles), **joints)

    @classmethod
    def load_npz(cls, path: str | Path) -> "Demonstrations":
        """Read a file written by :meth:`save_npz`: DemonstrationFileError naming the file when
        it is missing, a folder or not a readable .npz; InvalidDemonstrationsError (naming
        the file and the field) when its arrays are malformed."""
        path = as_file(path, "path", DemonstrationFileError, ScenesTypeError)
        try:
            return cls._read_npz(path)
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            if isinstance(exc, InvalidDemonstrationsError):
                raise
            raise DemonstrationFileError(f"{path}: not a readable demonstrations .npz "
                                         f"({exc})") from None

    @classmethod
    def _read_npz(cls, path: Path) -> "Demonstrations":
        with np.load(path, allow_pickle=False) as data:
            missing = {"positions", "velocities", "time"} - set(data.files)
            if missing:
                raise _E(f"{path}: missing array(s) {sorted(missing)}; found {sorted(data.files)}")
            name = str(data["name"]) if "name" in data.files else Path(path).stem
            try:
                raw = json.loads(str(data["obstacles"])) if "obstacles" in data.files else None
            except (json.JSONDecodeError, RecursionError) as exc:
                raise _E(f"{path}: obstacles: expected JSON text of per-demonstration obstacle "
                         f"lists ({exc})") from None
            obstacles = None
            if raw is not None:
                if not isinstance(raw, list) or not all(isinstance(g, list) for g in raw):
                    raise _E(f"{path}: obstacles: expected a list of lists of obstacle objects")
                try:
                    obstacles = [[obstacle_from_dict(d, f"obstacles[{m}][{k}]") for k, d in enumerate(group)]
                                 for m, group in enumerate(raw)]
                except InvalidObstacleError as exc:
                    raise _E(f"{path}: {exc}") from None
            joints = data["joint_positions"] if "joint_positions" in data.files else None
            names = ([str(n) for n in np.atleast_1d(data["joint_names"])]
                     if "joint_names" in data.files else None)
            turns = data["orientations"] if "orientations" in data.files else None
            return cls(data["positions"], data["velocities"], data["time"], obstacles, name,
                       joint_positions=joints, joint_names=names, orientations=turns)
