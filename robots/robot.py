"""The Robot: a Pinocchio model of an arm with its planning joints, end effector and collision spheres."""
from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from skillplan.command_line import native_stderr_logged

from .collision_geometry import load_geometry, moves
from .errors import InvalidArrayError, RobotError, UnknownFrameError, URDFParseError
from .kinematics import CONTINUOUS, EndEffectorKinematics, SerialChain, frame_index, frame_names
from .sphere_model import SphereModel, load_sphere_file
from .validation import as_file, as_joint_array, as_scalar
from robots.sphere_cache import cached_fit
from robots.spheres import INFLATION, MAX_SPHERES
from robots.ik import solve_ik
from robots.ik import solve_ik_trajectory

log = logging.getLogger(__name__)


def _chain_to(model: pin.Model, frame_id: int) -> list[int]:
    """Joint ids from the root to the parent joint of frame `frame_id` (universe excluded)."""
    joints = []
    joint = model.frames[frame_id].parentJoint
    while joint > 0:
        joints.append(joint)
        joint = model.parents[joint]
    return joints[::-1]


def _as_sphere_model(spheres) -> SphereModel | None:
    """A SphereModel, a path to a sphere JSON file, or None (fit on first use)."""
    if spheres is None or isinstance(spheres, SphereModel):
        return spheres
    if isinstance(spheres, (str, Path)):
        return load_sphere_file(spheres)
    raise RobotError(f"spheres: expected a SphereModel, a sphere file path or None, got {type(spheres).__name__}")


def _is_xacro(path: Path) -> bool:
    """Whether a robot description file is an unexpanded xacro file (.xacro, or xacro: elements)."""
    if path.suffix == ".xacro":
        return True
    try:
        return "<xacro:" in path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return False


class Robot:
    """A serial arm for planning: joint angles in, end-effector and sphere kinematics out.

    Planning variables are n joint values (angles in rad for revolute and continuous joints,
    metres for prismatic ones). Kinematics are expressed in `base_frame` (None = the URDF root).
    Movable joints that are not on the chain from the root to the end effector are locked at
    their neutral value. Continuous joints (Pinocchio's cos/sin pairs) appear only in
    `to_pinocchio` / `from_pinocchio`.
    """

    def __init__(self, model: pin.Model, end_effector: str, spheres: SphereModel | str | Path | None = None,
                 name: str | None = None, base_frame: str | None = None, urdf_path: str | Path | None = None,
                 package_dirs: Sequence[str | Path] = ()):
        if not isinstance(model, pin.Model):
            raise RobotError(f"model: expected a pinocchio.Model, got {type(model).__name__}")
        if not isinstance(end_effector, str):
            raise RobotError(f"end_effector: expected a frame name (str), got {type(end_effector).__name__}")
        ee_id = frame_index(model, end_effector)
        if ee_id < 0:
            raise UnknownFrameError("end_effector", end_effector, frame_names(model))
        if base_frame is not None and frame_index(model, base_frame) < 0:
            raise UnknownFrameError("base_frame", base_frame, frame_names(model))
        chain = _chain_to(model, ee_id)
        locked = [j for j in range(1, model.njoints) if j not in chain]
        if locked:
            model = pin.buildReducedModel(model, locked, pin.neutral(model))
        self.model: pin.Model = model
        self.chain = SerialChain(model, base_frame)
        self.name: str = name or model.name
        self.end_effector: str = end_effector
        self.base_frame: str | None = base_frame
        self.urdf_path: Path | None = Path(urdf_path) if urdf_path is not None else None
        self.package_dirs: tuple[str, ...] = tuple(str(p) for p in package_dirs)
        self.n: int = self.chain.n
        self.joint_names: tuple[str, ...] = self.chain.joint_names
        lower = np.array([model.lowerPositionLimit[i] for i in self.chain.idx_q])
        upper = np.array([model.upperPositionLimit[i] for i in self.chain.idx_q])
        continuous = np.array([kind == CONTINUOUS for kind in self.chain.kinds])
        self.lower_limits: np.ndarray = np.where(continuous, -np.inf, lower)
        self.upper_limits: np.ndarray = np.where(continuous, np.inf, upper)
        self.velocity_limits: np.ndarray = np.array(model.velocityLimit[:self.n], dtype=float)
        self._ee = self.chain.attachment(end_effector)
        self._spheres = _as_sphere_model(spheres)
        self._sphere_cache: tuple[object, np.ndarray, np.ndarray] | None = None
        self._collision_model = None
        self._pin_data: pin.Data | None = None

    # ------------------------------------------------------------ construction
    @classmethod
    def from_urdf(cls, path: str | Path, end_effector: str, package_dirs: Sequence[str | Path] | None = None,
                  spheres: SphereModel | str | Path | None = None, name: str | None = None,
                  base_frame: str | None = None) -> "Robot":
        """Load an arm from a URDF file; `package_dirs` resolve package:// mesh URIs (only needed
        for the collision geometry). Raises URDFParseError when the file is missing or invalid."""
        path = as_file(path, "path", URDFParseError)
        if _is_xacro(path):
            raise URDFParseError(f"path: {str(path)!r} is a xacro file (URDF macros), not a URDF; expand it "
                                 f"first: xacro {path.name} > robot.urdf (the ROS xacro tool)")
        try:
            with native_stderr_logged():  # urdfdom prints parse errors on fd 2
                model = pin.buildModelFromUrdf(str(path))
        except Exception as exc:  # Pinocchio raises bare RuntimeErrors on malformed URDF
            raise URDFParseError(f"path: cannot parse URDF {str(path)!r}: {exc}") from exc
        return cls(model, end_effector, spheres=spheres, name=name or model.name or path.stem,
                   base_frame=base_frame, urdf_path=path, package_dirs=package_dirs or ())

    @property
    def frame_names(self) -> tuple[str, ...]:
        """All frame names of the model (links, joints and fixed frames)."""
        return self.chain.frame_names

    @property
    def collision_model(self) -> pin.GeometryModel:
        """Pinocchio collision geometry of the URDF (built on first use; needs `urdf_path`)."""
        if self._collision_model is None:
            if self.urdf_path is None:
                raise RobotError("collision_model: this robot was not loaded from a URDF file")
            self._collision_model = load_geometry(self.model, self.urdf_path, self.package_dirs)
        return self._collision_model

    @property
    def spheres(self) -> SphereModel:
        """Collision spheres: given at construction (a SphereModel or a sphere JSON file),
        else :meth:`fit_spheres` with its defaults on first use (seconds the first time for a
        URDF, then read from the sphere cache)."""
        if self._spheres is None:
            self._spheres = self.fit_spheres()
        return self._spheres

    def fit_spheres(self, links: Sequence[str] | None = None, max_spheres: int = MAX_SPHERES,
                    inflation: float = INFLATION, seed: int = 0) -> SphereModel:
        """Collision spheres fitted to the URDF's ``<collision>`` geometry of the planning chain
        (a URDF without it on its moving links: its ``<visual>`` geometry, with a warning), by
        :func:`robots.spheres.fit_spheres` with these settings (``links``: frames to cover, None
        all moving ones; ``inflation`` [m]); the same fit made before, in this process or another,
        is read from :mod:`robots.sphere_cache`. The one fit of the planner and of
        ``python -m robots.sphere_cli``."""
        geometry, kind = self.fitting_geometry()
        if kind == "visual":
            log.warning("robot %s: the URDF has no collision geometry on its moving links; collision "
                        "spheres fitted to its visual geometry", self.name)
        return cached_fit(self.urdf_path, self.model, geometry, kind, links, max_spheres, inflation, seed)

    def fitting_geometry(self) -> tuple[pin.GeometryModel, str]:
        """The geometry collision spheres are fitted to and its kind: the URDF's ``<collision>``
        geometry ("collision"), or its ``<visual>`` geometry ("visual") when no collision geometry
        moves; RobotError when neither does."""
        geometry = self.collision_model
        if moves(geometry):
            return geometry, "collision"
        geometry = load_geometry(self.model, self.urdf_path, self.package_dirs, "visual")
        if not moves(geometry):
            raise RobotError(f"spheres: the URDF {str(self.urdf_path)!r} has neither collision nor "
                             "visual geometry on its moving links; pass spheres= (a SphereModel or a "
                             "sphere JSON file)")
        return geometry, "visual"

    @spheres.setter
    def spheres(self, value: SphereModel | str | Path | None) -> None:
        self._spheres = _as_sphere_model(value)
        self._sphere_cache = None

    def attachment(self, frame: str, argument: str = "frame"):
        """Chain joint index of `frame` and its placement in that joint's axis-aligned frame
        (see robots.kinematics.FrameAttachment); UnknownFrameError lists the valid names."""
        try:
            return self.chain.attachment(frame)
        except KeyError:
            raise UnknownFrameError(argument, frame, self.frame_names) from None

    # ------------------------------------------------------- joint conventions
    def to_pinocchio(self, q) -> np.ndarray:
        """Joint values (..., n) -> Pinocchio configuration (..., nq) (cos/sin for continuous joints)."""
        return self.chain.to_pinocchio(as_joint_array(q, "q", self.n))

    def from_pinocchio(self, q_pin) -> np.ndarray:
        """Pinocchio configuration (..., nq) -> joint values (..., n)."""
        return self.chain.from_pinocchio(as_joint_array(q_pin, "q_pin", self.model.nq))

    def within_limits(self, q, tolerance: float = 0.0) -> np.ndarray | bool:
        """Whether each configuration (..., n) lies inside the position limits (bool (...))."""
        q = as_joint_array(q, "q", self.n)
        tolerance = as_scalar(tolerance, "tolerance", minimum=0.0, error=RobotError)
        inside = np.all((q >= self.lower_limits - tolerance) & (q <= self.upper_limits + tolerance), axis=-1)
        return bool(inside) if inside.ndim == 0 else inside

    def clip_to_limits(self, q) -> np.ndarray:
        """Project configurations (..., n) onto the position limits."""
        return np.clip(as_joint_array(q, "q", self.n), self.lower_limits, self.upper_limits)

    def random_configuration(self, rng: np.random.Generator) -> np.ndarray:
        """Uniform random configuration (n,) within the limits; continuous joints in [-pi, pi]."""
        if not isinstance(rng, np.random.Generator):
            raise RobotError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}")
        lower = np.where(np.isfinite(self.lower_limits), self.lower_limits, -np.pi)
        upper = np.where(np.isfinite(self.upper_limits), self.upper_limits, np.pi)
        return rng.uniform(lower, upper)

    def neutral_configuration(self) -> np.ndarray:
        """Middle of the limits (n,); 0 for continuous joints."""
        finite = np.isfinite(self.lower_limits) & np.isfinite(self.upper_limits)
        lower = np.where(finite, self.lower_limits, 0.0)
        upper = np.where(finite, self.upper_limits, 0.0)
        return 0.5 * (lower + upper)

    # -------------------------------------------------------------- kinematics
    def _batch(self, q, name: str) -> tuple[np.ndarray, tuple[int, ...]]:
        q = as_joint_array(q, name, self.n)
        return q.reshape(-1, self.n), q.shape[:-1]

    def fk(self, q) -> np.ndarray:
        """End-effector position (..., 3) [m] in the base frame for q (..., n)."""
        flat, lead = self._batch(q, "q")
        frames = self.chain.joint_frames(flat)
        pos, _, _ = self.chain.point(frames, self._ee.joint, self._ee.translation, False)
        return pos.reshape(lead + (3,))

    def ee_kinematics(self, q, qdot=None, jacobians: bool = True) -> EndEffectorKinematics:
        """End-effector position, linear velocity J(q) qdot and their Jacobians, for q (..., n).

        qdot (..., n) or None (velocity zero, and with ``jacobians`` its Jacobian zero, neither
        computed). Returns EndEffectorKinematics with position, velocity (..., 3), jacobian and
        velocity_jacobian (..., 3, n) (None if not jacobians).
        """
        flat, lead = self._batch(q, "q")
        if qdot is None:
            qdot_flat = None
        else:
            qdot_flat, lead_dot = self._batch(qdot, "qdot")
            if lead_dot != lead:
                raise InvalidArrayError(f"qdot: expected shape {lead + (self.n,)} like q, got "
                                        f"{lead_dot + (self.n,)}")
        frames = self.chain.joint_frames(flat)
        pos, columns, angular = self.chain.point(frames, self._ee.joint, self._ee.translation, True)
        shape3, shape3n = lead + (3,), lead + (3, self.n)
        if qdot_flat is None:  # at rest: the velocity and its derivative vanish
            jacobian = columns.transpose(0, 2, 1).reshape(shape3n) if jacobians else None
            return EndEffectorKinematics(pos.reshape(shape3), np.zeros(shape3), jacobian,
                                         np.zeros(shape3n) if jacobians else None)
        if not jacobians:  # J qdot only: no derivative of the velocity
            velocity = np.einsum("bnk,bn->bk", columns, qdot_flat)
            return EndEffectorKinematics(pos.reshape(shape3), velocity.reshape(shape3), None, None)
        velocity, velocity_jacobian = self.chain.velocity_and_derivative(columns, angular, qdot_flat)
        return EndEffectorKinematics(pos.reshape(shape3), velocity.reshape(shape3),
                                     columns.transpose(0, 2, 1).reshape(shape3n),
                                     velocity_jacobian.reshape(shape3n))

    def ee_poses(self, q) -> tuple[np.ndarray, np.ndarray]:
        """End-effector positions (..., 3) [m] and rotations (..., 3, 3) (columns: the tool's x,
        y, z axes) in the base frame for q (..., n), from one pass of the chain."""
        flat, lead = self._batch(q, "q")
        frames = self.chain.joint_frames(flat)
        pos, _, _ = self.chain.point(frames, self._ee.joint, self._ee.translation, False)
        rotation = frames.rotations[:, self._ee.joint] @ self._ee.rotation
        return pos.reshape(lead + (3,)), rotation.reshape(lead + (3, 3))

    def ee_rotation(self, q, jacobians: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
        """End-effector rotation (..., 3, 3) (columns: the tool's x, y, z axes in the base
        frame) for q (..., n) and, if asked, its angular Jacobian (..., 3, n): the base-frame
        angular velocity is ``jacobian @ qdot`` (column j: joint j's axis if revolute and
        upstream of the end effector, else 0), so d (R a) / d q_j = column_j x (R a)."""
        flat, lead = self._batch(q, "q")
        frames = self.chain.joint_frames(flat)
        rotation = (frames.rotations[:, self._ee.joint] @ self._ee.rotation).reshape(lead + (3, 3))
        if not jacobians:
            return rotation, None
        angular = np.where(self.chain.is_prismatic[:, None], 0.0, frames.axes)    # (B, n, 3)
        angular[:, self._ee.joint:] = 0.0                                         # downstream joints
        return rotation, angular.transpose(0, 2, 1).reshape(lead + (3, self.n))

    def ee_position_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """End-effector position (3,) [m] and d position / d q (3, n) of ONE validated
        configuration q (n,), from Pinocchio's C++ kinematics (equal to :meth:`ee_kinematics`
        to round-off; for the many small single-configuration calls of inverse kinematics,
        where the vectorized chain's per-call overhead dominates)."""
        model = self.model
        if self._pin_data is None:
            self._pin_data = model.createData()
            self._ee_frame = frame_index(model, self.end_effector)
            self._base_frame_index = (None if self.base_frame is None
                                      else frame_index(model, self.base_frame))
        data = self._pin_data
        q_pin = self.chain.to_pinocchio(np.asarray(q, dtype=float))   # validated: no checks
        pin.computeJointJacobians(model, data, q_pin)
        pin.updateFramePlacements(model, data)
        position = data.oMf[self._ee_frame].translation
        jac = pin.getFrameJacobian(model, data, self._ee_frame,
                                   pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[:3]
        if self._base_frame_index is not None:
            base = data.oMf[self._base_frame_index]
            position = base.rotation.T @ (position - base.translation)
            jac = base.rotation.T @ jac
        return np.array(position), np.array(jac[:, :self.n])   # reduced model: v = the chain's joints

    def ee_pose_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """End-effector position (3,) [m], rotation (3, 3) and the stacked Jacobian (6, n)
        (d position / d q over the base-frame angular velocity's d omega / d qdot) of ONE
        validated configuration q (n,), from Pinocchio's C++ kinematics (for the many small
        calls of pose inverse kinematics)."""
        position, linear = self.ee_position_jacobian(q)           # fills self._pin_data
        data = self._pin_data
        rotation = data.oMf[self._ee_frame].rotation
        angular = pin.getFrameJacobian(self.model, data, self._ee_frame,
                                       pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[3:, :self.n]
        if self._base_frame_index is not None:
            base = data.oMf[self._base_frame_index].rotation
            rotation, angular = base.T @ rotation, base.T @ angular
        return position, np.array(rotation), np.vstack([linear, angular])

    def sphere_attachments(self) -> tuple[np.ndarray, np.ndarray]:
        """Chain joint (S,) and centre in that joint's frame (S, 3) of every collision sphere."""
        spheres = self.spheres
        if self._sphere_cache is None or self._sphere_cache[0] is not spheres:
            joints = np.zeros(spheres.count, dtype=int)
            local = np.zeros((spheres.count, 3))
            for s, (link, centre) in enumerate(zip(spheres.link_names, spheres.centres)):
                att = self.attachment(link, "spheres.link_names")
                joints[s] = att.joint
                local[s] = att.rotation @ centre + att.translation
            self._sphere_cache = (spheres, joints, local)
        return self._sphere_cache[1], self._sphere_cache[2]

    def sphere_centres(self, q, jacobians: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
        """Collision sphere centres (..., S, 3) [m] in the base frame and, if asked,
        their Jacobians (..., S, 3, n) with respect to q (..., n)."""
        flat, lead = self._batch(q, "q")
        joints, local = self.sphere_attachments()
        frames = self.chain.joint_frames(flat)
        pos, jac = self.chain.points(frames, joints, local, jacobians)
        S = len(joints)
        centres = pos.reshape(lead + (S, 3))
        if not jacobians:
            return centres, None
        return centres, jac.reshape(lead + (S, 3, self.n))

    def frame_positions(self, q) -> np.ndarray:
        """Points to draw the arm, (..., L, 3) [m]: base origin, each joint origin, end effector (L = n + 2)."""
        flat, lead = self._batch(q, "q")
        frames = self.chain.joint_frames(flat)
        ee, _, _ = self.chain.point(frames, self._ee.joint, self._ee.translation, False)
        points = np.concatenate((frames.origins, ee[:, None]), axis=1)
        return points.reshape(lead + (self.n + 2, 3))

    def frame_position(self, q, frame: str) -> np.ndarray:
        """Origin (..., 3) [m] of any model frame for q (..., n)."""
        att = self.attachment(frame)
        flat, lead = self._batch(q, "q")
        frames = self.chain.joint_frames(flat)
        pos, _, _ = self.chain.point(frames, att.joint, att.translation, False)
        return pos.reshape(lead + (3,))

    # ------------------------------------------------------ inverse kinematics
    def ik(self, target, seed=None, tol: float = 1e-4, max_iter: int = 200, restarts: int = 8,
           rng: np.random.Generator | int | None = 0):
        """End-effector position IK; see robots.ik.solve_ik. Returns IKResult(q (n,), error [m], success)."""
        return solve_ik(self, target, seed=seed, tol=tol, max_iter=max_iter, restarts=restarts, rng=rng)

    def ik_trajectory(self, targets, seed=None, tol: float = 1e-4, max_iter: int = 100,
                      rng: np.random.Generator | int | None = 0):
        """IK along a path (T, 3) with continuity; see robots.ik.solve_ik_trajectory.
        Returns IKTrajectoryResult(q (T, n), errors (T,) [m], success)."""
        return solve_ik_trajectory(self, targets, seed=seed, tol=tol, max_iter=max_iter, rng=rng)

    def __repr__(self) -> str:
        return (f"Robot(name={self.name!r}, n={self.n}, end_effector={self.end_effector!r}, "
                f"base_frame={self.base_frame!r})")
