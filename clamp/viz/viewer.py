"""Live 3-D view of a plan in the browser, served by viser on this machine (127.0.0.1).

:class:`PlanViewer` (or ``clamp.show(result)``) starts a viser server and draws, in the robot's
planning frame (``robot.base_frame``): the arm from its URDF through viser's URDF support
(:class:`viser.extras.ViserUrdf` on a ``yourdfpy.URDF``, :func:`load_urdf`: the visual meshes, or the
collision geometry when the URDF has no visual elements, package:// names resolved against
``robot.package_dirs``), its joints set to the plan's at the current time, the plan's end-effector path, the learned prior's mean path, the
demonstrations, the posterior tube (``sigmas``-sigma ellipsoids of ``result.ee_covariance``
along ``result.ee_path``) and the obstacles. The page has a time slider and a play checkbox;
every obstacle and the goal carry a drag handle (viser transform controls): releasing one
replans through :func:`clamp.replan` with the moved obstacle or goal and draws the new plan.
The same is scriptable: ``viewer.set_time(t)``, ``viewer.move_obstacle(k, center)``,
``viewer.move_goal(goal)``, ``viewer.result``, ``viewer.close()``.

Only loopback addresses are served (``host`` 127.0.0.1, localhost or ::1); viser's share
tunnel is never used. The page is viser's own client (three.js); nothing is fetched from
elsewhere.
"""
from __future__ import annotations

import contextlib
import io
import logging
import math
import threading
from pathlib import Path
from typing import Any

import numpy as np

from clamp.errors import AnimationError, ClampTypeError, InvalidParameterError
from scenes import Box, Capsule, Cylinder, Sphere, TriangleMesh
from clamp.planning.result import PlanResult
from skillplan.validation import as_instance, as_shaped
from clamp.viz.animation import planning_frame_transform
from skillplan.validation import as_vector
from scenes import Scene
from scenes import PointCloud
from clamp.viz.animation import box_corners, camera_distance
from clamp.planning.replanning import replan

logger = logging.getLogger(__name__)

#: hosts the viewer may listen on
LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")
#: RGB (0-255) of the scene elements
COLORS = {"obstacle": (217, 83, 79), "demonstration": (91, 140, 192), "mean_path": (27, 127, 59),
          "ee_path": (242, 140, 40), "failed_path": (200, 30, 30), "tube": (242, 140, 40),
          "goal": (27, 127, 59), "arm": (90, 96, 107)}
#: width / height of the 3-D view the camera is framed for (a browser window less the panel)
VIEW_ASPECT = 1.0
#: fraction of the view's half extents the arm's joints and the paths may reach (room for the
#: links' thickness, which the joint positions leave out)
VIEW_FILL = 0.7
#: playback refresh rate [1/s]
PLAY_RATE = 20.0


def _quiet() -> contextlib.AbstractContextManager:
    """viser prints a banner with rich on start and stop; the library logs instead."""
    return contextlib.redirect_stdout(io.StringIO())


# --------------------------------------------------------------------------- geometry
def _unit_sphere(subdivisions: int = 1) -> tuple[np.ndarray, np.ndarray]:
    import trimesh
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    return np.asarray(sphere.vertices, dtype=float), np.asarray(sphere.faces, dtype=np.int64)


def tube_mesh(ee_path: Any, ee_covariance: Any, sigmas: float = 2.0,
              states: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """Posterior tube as one triangle mesh: the ``sigmas``-sigma ellipsoid of the end-effector
    position at ``states`` states spread evenly along the plan (first and last included).

    ee_path (T, 3) [m], ee_covariance (T, 3, 3) [m^2] -> vertices (K*V, 3) [m], faces (K*F, 3):
    a vertex v of ellipsoid i satisfies (v - p_i)^T Sigma_i^-1 (v - p_i) = sigmas^2.
    """
    path = as_shaped(ee_path, "ee_path", (None, 3), InvalidParameterError)
    cov = as_shaped(ee_covariance, "ee_covariance", (len(path), 3, 3), InvalidParameterError)
    if not (isinstance(sigmas, (int, float)) and math.isfinite(sigmas) and sigmas > 0):
        raise InvalidParameterError(f"sigmas: expected a positive number, got {sigmas!r}")
    index = np.unique(np.linspace(0, len(path) - 1, max(int(states), 2)).round().astype(int))
    values, vectors = np.linalg.eigh(0.5 * (cov[index] + np.swapaxes(cov[index], 1, 2)))
    root = vectors * np.sqrt(np.clip(values, 0.0, None))[:, None, :]        # (K, 3, 3): L L^T = Sigma
    unit, faces = _unit_sphere()
    vertices = path[index, None, :] + sigmas * np.einsum("kij,vj->kvi", root, unit)
    offsets = (np.arange(len(index)) * len(unit))[:, None, None]
    return vertices.reshape(-1, 3), (faces[None] + offsets).reshape(-1, 3)


def obstacle_anchor(obstacle: Any) -> np.ndarray:
    """The point (3,) [m] a drag handle holds an obstacle by: the middle of its bounding box
    (the centre of a box, sphere, cylinder or capsule)."""
    return np.asarray(obstacle.aabb(), dtype=float).mean(axis=0)


def _obstacle_mesh(obstacle: Any, index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangle mesh of a scenes obstacle about its anchor, in a frame rotated by (3, 3) from
    the scene's (a box's rotation, z along a cylinder's or capsule's axis)."""
    import trimesh

    rotation = np.eye(3)
    if isinstance(obstacle, TriangleMesh):
        return (np.asarray(obstacle.vertices, dtype=float) - obstacle_anchor(obstacle), np.asarray(obstacle.faces),
                rotation)
    if isinstance(obstacle, Box):
        mesh = trimesh.creation.box(extents=np.asarray(obstacle.size, dtype=float))
        if obstacle.rotation is not None:
            rotation = np.asarray(obstacle.rotation, dtype=float)
    elif isinstance(obstacle, Sphere):
        mesh = trimesh.creation.icosphere(subdivisions=3, radius=float(obstacle.radius))
    elif isinstance(obstacle, (Cylinder, Capsule)):   # along z in their frame
        if isinstance(obstacle, Cylinder):
            mesh = trimesh.creation.cylinder(radius=float(obstacle.radius), height=float(obstacle.height),
                                             sections=32)
        else:
            mesh = trimesh.creation.capsule(height=float(obstacle.height), radius=float(obstacle.radius))
        axis = np.asarray(obstacle.axis, dtype=float)
        rotation = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], axis / np.linalg.norm(axis))[:3, :3]
    else:
        raise InvalidParameterError(f"scene.obstacles[{index}]: expected a scenes Box, Sphere, Cylinder, Capsule, "
                                    f"TriangleMesh or PointCloud, got {type(obstacle).__name__}")
    return np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces), rotation


def _mesh_resolver(urdf_path: Path, package_dirs: Any) -> Any:
    """yourdfpy's filename handler for a robot's URDF: ``package://PKG/rest`` is looked up as
    ``DIR/PKG/rest`` in each of ``package_dirs`` (Pinocchio's rule, so the viewer finds the meshes
    the planner's geometry came from), or ``DIR/rest`` for a DIR that is the package itself;
    anything else as yourdfpy would (relative to the URDF's folder)."""
    import yourdfpy

    folders = [Path(d) for d in package_dirs]

    def resolve(fname: str) -> str:
        name = fname
        if name.startswith("package://"):
            rest = name[len("package://"):]
            package, _, inner = rest.partition("/")
            for folder in folders:
                for candidate in (folder / rest, folder / inner if folder.name == package else None):
                    if candidate is not None and candidate.is_file():
                        return str(candidate)
        return yourdfpy.filename_handler_magic(name, dir=str(urdf_path.parent))
    return resolve


def load_urdf(robot: Any) -> tuple[Any, str]:
    """The robot's URDF (``robot.urdf_path``) read by yourdfpy with its meshes, package://
    names resolved against ``robot.package_dirs`` (:func:`_mesh_resolver`): the visual geometry,
    or the collision geometry when the URDF has no visual elements (the built-in Sawyer), as
    :func:`clamp.viz.animation.robot_geometry` chooses. Returns (yourdfpy.URDF, "visual" |
    "collision"); AnimationError when there is no URDF, yourdfpy is missing or nothing can be
    drawn."""
    urdf_path = getattr(robot, "urdf_path", None)
    if urdf_path is None:
        raise AnimationError("robot: has no urdf_path to read the geometry from (use robots.load_robot "
                             "or Robot.from_urdf)")
    try:
        import yourdfpy
    except ImportError as exc:
        raise AnimationError(f"the live viewer needs yourdfpy (pip install 'skillplan[viewer]'): {exc}") from exc
    urdf_path = Path(urdf_path)
    handler = _mesh_resolver(urdf_path, getattr(robot, "package_dirs", ()))
    for kind in ("visual", "collision"):
        visual = kind == "visual"
        try:
            urdf = yourdfpy.URDF.load(str(urdf_path), build_scene_graph=visual, load_meshes=visual,
                                      build_collision_scene_graph=not visual, load_collision_meshes=not visual,
                                      filename_handler=handler)
        except Exception as exc:   # yourdfpy / lxml / trimesh raise many kinds for a bad file
            raise AnimationError(f"robot: cannot read the URDF {str(urdf_path)!r} with yourdfpy: {exc}") from exc
        scene = urdf.scene if visual else urdf.collision_scene
        if scene is not None and len(scene.geometry) > 0:
            if not visual:
                logger.info("viewer: %s has no visual geometry; drawing its collision geometry", urdf_path)
            return urdf, kind
    raise AnimationError(f"robot: none of the geometries of the URDF {str(urdf_path)!r} can be drawn "
                         "(no visual or collision elements, or their meshes were not found)")


def goal_position(goal: Any, end: np.ndarray) -> np.ndarray:
    """Where the goal's drag handle goes: a goal position (3,) [m], a goal pose's position (a
    pair (position, quaternion), as ``PlanResult.inputs.goal`` holds it), ``end`` (the plan's
    last end-effector position) without a goal; a joint goal as given (no handle)."""
    if goal is None:
        return np.asarray(end, dtype=float)
    if isinstance(goal, tuple) and len(goal) == 2:
        return np.asarray(goal[0], dtype=float)
    return np.asarray(goal, dtype=float)


def moved_goal(goal: Any, position: np.ndarray) -> Any:
    """The goal moved to ``position`` (3,) [m]: a goal pose keeps its rotation."""
    if isinstance(goal, tuple) and len(goal) == 2:
        return (position, goal[1])
    return position


def _segments(points: np.ndarray) -> np.ndarray:
    """(N, 3) polyline -> (N-1, 2, 3) segments for viser's line segments."""
    return np.stack([points[:-1], points[1:]], axis=1)


# --------------------------------------------------------------------------- the viewer
class PlanViewer:
    """A plan shown live in the browser (see the module docstring).

    result: a :class:`clamp.PlanResult` returned by :func:`clamp.plan` (its ``inputs`` give the
    robot, scene and prior, and make replanning possible); demonstrations: (M, T', 3) [m] or a
    scenes.Demonstrations to draw (optional); port: TCP port (0: a free one); host: a loopback
    address; sigmas: size of the tube's ellipsoids [standard deviations]; tube_states: how many
    ellipsoids along the plan.

    Attributes: ``url`` (http://host:port), ``port``, ``result`` (the plan shown: the latest
    replan), ``time`` [s] (the arm's time along the plan), ``scene`` (the scene planned
    around). Close with :meth:`close` (or use it as a context manager).
    """

    def __init__(self, result: Any, *, demonstrations: Any = None, port: int = 0,
                 host: str = "127.0.0.1", sigmas: float = 2.0, tube_states: int = 30) -> None:
        as_instance(result, "result", PlanResult, "a clamp.PlanResult returned by clamp.plan",
                    ClampTypeError)
        if result.inputs is None:
            raise InvalidParameterError("result: expected a PlanResult returned by clamp.plan (it keeps "
                                        "its robot, scene and prior in .inputs), got one without")
        if host not in LOOPBACK_HOSTS:
            raise InvalidParameterError(f"host: expected a loopback address {LOOPBACK_HOSTS}, got {host!r}")
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise InvalidParameterError(f"port: expected an integer in [0, 65535] (0: a free port), got {port!r}")
        if not (isinstance(sigmas, (int, float)) and math.isfinite(sigmas) and sigmas > 0):
            raise InvalidParameterError(f"sigmas: expected a positive number, got {sigmas!r}")
        if demonstrations is not None:
            demonstrations = as_shaped(getattr(demonstrations, "positions", demonstrations), "demonstrations",
                                       (None, None, 3), InvalidParameterError)
        try:
            import pinocchio as pin
            import viser
        except ImportError as exc:
            raise AnimationError(f"the live viewer needs viser (pip install 'skillplan[viewer]'): {exc}") from exc

        self._result = result
        self._robot = result.inputs.robot
        self._urdf_model, self._urdf_kind = load_urdf(self._robot)      # before the server starts
        self._scene = result.inputs.scene
        self._goal = result.inputs.goal
        self._sigmas, self._tube_states = float(sigmas), int(tube_states)
        self._lock = threading.RLock()
        self._closed = threading.Event()
        self._time = 0.0
        self._tube: Any = None

        with _quiet():
            self._server = viser.ViserServer(host=host, port=port, verbose=False)
        self.port: int = int(self._server.get_port())
        self.url: str = f"http://{'[::1]' if host == '::1' else host}:{self.port}"
        try:
            scene = self._server.scene
            scene.set_up_direction("+z")
            self._server.gui.configure_theme(control_width="medium", show_logo=False, show_share_button=False)
            self._server.gui.main_panel.dock_right()     # beside the 3-D view, not over it
            scene.add_grid("/floor", width=2.0, height=2.0, cell_size=0.1, section_size=0.5,
                           position=(0.0, 0.0, 0.0))
            base = planning_frame_transform(self._robot, pin)
            scene.add_frame("/robot", show_axes=False, position=base[:3, 3],
                            wxyz=viser.transforms.SO3.from_matrix(base[:3, :3]).wxyz)
            self._robot_urdf = self._draw_robot()
            if demonstrations is not None:
                segments = np.concatenate([_segments(d) for d in demonstrations])
                scene.add_line_segments("/demonstrations", segments, COLORS["demonstration"], thickness=0.002)
            mean_path = np.asarray(result.inputs.prior.mean)[:, :3]       # the learned prior's
            scene.add_line_segments("/mean_path", _segments(mean_path), COLORS["mean_path"], thickness=0.002)
            self._obstacle_controls = self._draw_obstacles()
            self._goal_control = self._draw_goal()
            self._add_gui()
            self._draw_plan()
            self._frame_camera(demonstrations)
            self.set_time(0.0)
        except BaseException:
            self.close()
            raise
        self._player = threading.Thread(target=self._play_loop, name=f"clamp-viewer-{self.port}", daemon=True)
        self._player.start()
        logger.info("viewer: serving %s", self.url)

    # ------------------------------------------------------------------ public API
    @property
    def result(self) -> Any:
        """The plan shown (a PlanResult; the latest replan after a move)."""
        return self._result

    @property
    def scene(self) -> Any:
        """The scene the shown plan was planned around (scenes.Scene or None)."""
        return self._scene

    @property
    def time(self) -> float:
        """Time [s] along the plan at which the arm is drawn."""
        return self._time

    @property
    def robot_urdf(self) -> Any:
        """The arm as drawn: a :class:`viser.extras.ViserUrdf` of the robot's URDF (its
        actuated joints in ``get_actuated_joint_names()`` order; those of the plan set by
        :meth:`set_time`, any other, e.g. a gripper's, at 0, where the planner's model holds it)."""
        return self._robot_urdf

    @property
    def duration(self) -> float:
        """Duration [s] of the shown plan."""
        return float(self._result.time[-1] - self._result.time[0])

    def set_time(self, t: float) -> None:
        """Draw the arm at time ``t`` [s] since the plan's start (clipped to the plan; joint
        positions interpolated linearly between states)."""
        if isinstance(t, bool) or not isinstance(t, (int, float, np.floating)) or not math.isfinite(t):
            raise InvalidParameterError(f"t: expected a finite time [s], got {t!r}")
        with self._lock:
            time = self._result.time - self._result.time[0]
            t = float(np.clip(t, 0.0, time[-1]))
            q = np.array([np.interp(t, time, column) for column in self._result.q.T])
            configuration = self._rest_configuration.copy()
            configuration[self._joint_index] = q      # by name: the URDF's actuated order may differ
            with self._server.atomic():
                self._robot_urdf.update_cfg(configuration)
            self._time = t
            if abs(self._slider.value - t) > 1e-9:
                self._slider.value = t

    def move_obstacle(self, index: int, center: Any) -> Any:
        """Move obstacle ``index`` of the scene so its centre (the middle of its bounding box,
        :func:`obstacle_anchor`) is ``center`` (3,) [m], replan (:func:`clamp.replan`,
        warm-started from the shown plan) and show the new plan; returns it."""
        obstacles = () if self._scene is None else self._scene.obstacles
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < len(obstacles):
            raise InvalidParameterError(f"index: expected an obstacle index in [0, {len(obstacles) - 1}] "
                                        f"(the scene has {len(obstacles)}), got {index!r}")
        center = as_vector(center, "center", 3, InvalidParameterError)
        moved = list(obstacles)
        moved[index] = moved[index].translated(center - obstacle_anchor(moved[index]))
        return self._replan(scene=Scene(moved))

    def move_goal(self, goal: Any) -> Any:
        """Replan to end-effector goal ``goal`` (3,) [m] (a goal pose keeps its rotation) and
        show the new plan; returns it."""
        return self._replan(goal=moved_goal(self._goal, as_vector(goal, "goal", 3, InvalidParameterError)))

    def close(self) -> None:
        """Stop playback and the server (its port is free afterwards); idempotent."""
        self._closed.set()
        player = getattr(self, "_player", None)
        if player is not None and player is not threading.current_thread():
            player.join()
        server = getattr(self, "_server", None)
        if server is not None:
            self._server = None
            with _quiet():
                server.stop()
            logger.info("viewer: stopped %s", self.url)

    def __enter__(self) -> "PlanViewer":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._closed.is_set() else self.url
        return f"PlanViewer({self._robot.name}, {state})"

    # ------------------------------------------------------------------ drawing
    def _draw_robot(self) -> Any:
        """The arm under ``/robot`` (the planning frame) as a ViserUrdf of :func:`load_urdf`'s
        URDF, in one grey; maps the robot's joints (``robot.joint_names``, the columns of the
        plan's q; a continuous joint's angle as is) to the URDF's actuated joints by name."""
        from viser.extras import ViserUrdf

        visual = self._urdf_kind == "visual"
        drawn = ViserUrdf(self._server, self._urdf_model, root_node_name="/robot", load_meshes=visual,
                          load_collision_meshes=not visual, mesh_color_override=COLORS["arm"],
                          collision_mesh_color_override=COLORS["arm"])
        names = list(drawn.get_actuated_joint_names())
        missing = [name for name in self._robot.joint_names if name not in names]
        if missing:
            raise AnimationError(f"robot: joints {missing} of {self._robot.name!r} are not actuated joints of "
                                 f"its URDF {str(self._robot.urdf_path)!r} as yourdfpy reads it ({names})")
        self._joint_index = np.array([names.index(name) for name in self._robot.joint_names], dtype=int)
        # joints off the planned chain (a gripper's) at 0, where robots.Robot locks them (Pinocchio's neutral)
        self._rest_configuration = np.zeros(len(names))
        return drawn

    def _draw_obstacles(self) -> list[Any]:
        """Each obstacle under a drag handle at its anchor (:func:`obstacle_anchor`)."""
        import viser

        controls = []
        obstacles = () if self._scene is None else self._scene.obstacles
        for i, obstacle in enumerate(obstacles):
            anchor = obstacle_anchor(obstacle)
            size = float(np.max(np.ptp(np.asarray(obstacle.aabb(), dtype=float), axis=0)))
            control = self._server.scene.add_transform_controls(
                f"/obstacles/{i}", scale=float(np.clip(0.8 * size, 0.15, 0.5)), disable_rotations=True,
                position=anchor)
            if isinstance(obstacle, PointCloud):
                self._server.scene.add_point_cloud(f"/obstacles/{i}/points", np.asarray(obstacle.points) - anchor,
                                                   COLORS["obstacle"], point_size=2.0 * float(np.max(obstacle.radius)),
                                                   point_shape="circle")
            else:
                vertices, faces, rotation = _obstacle_mesh(obstacle, i)
                self._server.scene.add_mesh_simple(f"/obstacles/{i}/mesh", vertices, faces, color=COLORS["obstacle"],
                                                   opacity=0.6, wxyz=viser.transforms.SO3.from_matrix(rotation).wxyz)
            control.on_update(self._released(lambda event, i=i: self.move_obstacle(i, event.target.position)))
            controls.append(control)
        return controls

    def _draw_goal(self) -> Any | None:
        """A drag handle at the goal (the plan's last end-effector position when none was given;
        none for a joint-space goal)."""
        goal = goal_position(self._goal, self._result.ee_path[-1])
        if goal.shape != (3,):
            return None
        control = self._server.scene.add_transform_controls("/goal", scale=0.1, disable_rotations=True,
                                                            position=goal)
        self._server.scene.add_icosphere("/goal/marker", radius=0.012, color=COLORS["goal"])
        control.on_update(self._released(lambda event: self.move_goal(event.target.position)))
        return control

    def _released(self, action):
        """A transform-control callback running ``action(event)`` when a drag ends."""
        def callback(event: Any) -> None:
            if event.phase != "end":
                return
            try:
                action(event)
            except Exception:   # a callback thread: report, keep serving
                logger.exception("viewer: replanning after a drag failed")
        return callback

    def _draw_plan(self) -> None:
        """Draw (or redraw) the shown plan's end-effector path and posterior tube."""
        result, scene = self._result, self._server.scene
        color = COLORS["ee_path"] if result.success else COLORS["failed_path"]
        scene.add_line_segments("/plan/ee_path", _segments(np.asarray(result.ee_path)), color, thickness=0.004)
        if self._tube is not None:
            self._tube.remove()
            self._tube = None
        if result.ee_covariance is not None:
            vertices, faces = tube_mesh(result.ee_path, result.ee_covariance, self._sigmas, self._tube_states)
            self._tube = scene.add_mesh_simple("/plan/tube", vertices, faces, color=COLORS["tube"], opacity=0.25)
        self._status.content = self._status_text()

    def _status_text(self) -> str:
        r = self._result
        verdict = "**success**" if r.success else "**failed**: " + "; ".join(r.reasons)
        clearance = "inf" if not np.isfinite(r.min_clearance) else f"{1e3 * r.min_clearance:.1f} mm"
        return (f"{verdict}  \nclearance {clearance}, {r.iterations} iterations, "
                f"{1e3 * r.timings.get('total', float('nan')):.0f} ms  \n"
                f"tube: {self._sigmas:g}-sigma ellipsoids; drag a box or the goal to replan")

    def _add_gui(self) -> None:
        gui = self._server.gui
        self._slider = gui.add_slider("time [s]", min=0.0, max=max(self.duration, 1e-3),
                                      step=max(self.duration, 1e-3) / 200, initial_value=0.0)
        self._slider.on_update(self._slider_moved)
        self._playing = gui.add_checkbox("play", initial_value=False)
        self._status = gui.add_markdown(self._status_text())

    def _slider_moved(self, _event: Any) -> None:
        if abs(self._slider.value - self._time) > 1e-9:      # not the echo of set_time
            self.set_time(self._slider.value)

    def _frame_camera(self, demonstrations: np.ndarray | None) -> None:
        """Initial camera: front-right and above the centre of the arm's motion, the paths and
        the obstacles, at the distance where they fit (:func:`clamp.viz.animation.camera_distance`)."""
        points = [self._robot.frame_positions(self._result.q).reshape(-1, 3), self._result.ee_path]
        if self._scene is not None:
            points += [box_corners(np.clip(o.aabb(), -2.0, 2.0)) for o in self._scene.obstacles]
        if demonstrations is not None:
            points.append(demonstrations.reshape(-1, 3))
        cloud = np.concatenate(points)
        centre = 0.5 * (cloud.min(axis=0) + cloud.max(axis=0))
        direction = np.array([1.0, 0.8, 0.6]) / np.linalg.norm([1.0, 0.8, 0.6])
        camera = self._server.initial_camera
        camera.look_at = centre
        camera.position = centre + direction * camera_distance(cloud, centre, direction, fov=math.degrees(camera.fov),
                                                                aspect=VIEW_ASPECT, fill=VIEW_FILL)
        camera.up = (0.0, 0.0, 1.0)

    # ------------------------------------------------------------------ replanning
    def _replan(self, **changes: Any) -> Any:
        with self._lock:
            new = replan(self._result, **changes)
            self._result = new
            self._scene = new.inputs.scene
            if "goal" in changes:
                self._goal = changes["goal"]
            if "scene" in changes:
                for control, obstacle in zip(self._obstacle_controls, self._scene.obstacles):
                    control.position = obstacle_anchor(obstacle)
            if self._goal_control is not None:
                self._goal_control.position = goal_position(self._goal, self._result.ee_path[-1])
            self._slider.max = max(self.duration, 1e-3)
            self._draw_plan()
            self.set_time(min(self._time, self.duration))
            logger.info("viewer: replanned (%s) in %.0f ms: %s", ", ".join(changes),
                        1e3 * new.timings.get("total", float("nan")), "success" if new.success else new.reasons)
            return new

    def _play_loop(self) -> None:
        """Advance the time while "play" is ticked (loops at the end)."""
        step = 1.0 / PLAY_RATE
        while not self._closed.wait(step):
            if not self._playing.value or self._server is None:
                continue
            t = self._time + step
            try:
                self.set_time(0.0 if t > self.duration + 1e-9 else t)
            except Exception:
                logger.exception("viewer: playback step failed")


def show(result: Any, demonstrations: Any = None, **options: Any) -> PlanViewer:
    """Start a :class:`PlanViewer` of ``result`` (see it for ``options``) and return it."""
    return PlanViewer(result, demonstrations=demonstrations, **options)


