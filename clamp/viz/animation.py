"""3-D animation of a plan in the browser: one self-contained HTML file that opens offline.

The arm is drawn with its real visual geometry (the URDF's visual meshes and primitives, read
by Pinocchio into a visual ``GeometryModel``; the collision geometry, in one grey, when the URDF
has no visual elements, like the built-in Sawyer) and moved along the plan by Pinocchio's
``MeshcatVisualizer``; obstacles, demonstrations, the mean path, the plan's end-effector path
and an optional triangle surface (e.g. a TLGC cylinder) are drawn beside it, over a floor grid
at z = 0. The page is meshcat's static viewer: meshcat's own JavaScript bundle (three.js
included) followed by the recorded meshcat scene commands, as in
``meshcat.Visualizer.static_html()`` but without the ZeroMQ/websocket server that method needs
(the commands are recorded in-process); bundle and commands are gzip-compressed in the page
and unpacked by the browser (``DecompressionStream``). No network access is needed to write
or to open the file.

Meshes are embedded as triangle arrays (the triangles coal read from the mesh files). Coordinates
are the robot's planning frame (``robot.base_frame``): everything the planner sees is drawn
where it sees it. The camera looks at the centre of everything drawn from the front-right and
above, at the distance where it all fits (:func:`camera_distance`), and orbits about that centre.

Open the file in a browser; the bar at the bottom plays, pauses and scrubs the plan. Append
``#t=SECONDS`` to the URL to show the arm frozen at that time since the plan's start.
"""
from __future__ import annotations

import base64
import gzip
import html
import json
import logging
import math
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from clamp.errors import AnimationError
from robots.kinematics import frame_index
from scenes import Box, Capsule, Cylinder, Sphere, TriangleMesh
from scenes import Scene
from scenes import PointCloud
from robots.trajectory import atomic_write_text

logger = logging.getLogger(__name__)

#: Colours (0xRRGGBB) of the scene elements.
COLORS = {"obstacle": 0xD9534F, "demonstration": 0x5B8CC0, "mean_path": 0x1B7F3B, "ee_path": 0xF28C28,
          "surface": 0x8E44AD, "floor": 0xB4B9C2}
#: vertical field of view [deg] of meshcat's camera
CAMERA_FOV = 75.0
#: width / height of the browser window the camera is framed for
CAMERA_ASPECT = 4.0 / 3.0
#: fraction of the view's half-width and half-height the drawn points may reach (the rest
#: keeps them clear of the player bar at the bottom)
CAMERA_FILL = 0.85
#: floor grid cell [m]
FLOOR_CELL = 0.1
#: Background gradient (top, bottom), RGB in [0, 1].
BACKGROUND = ([1.0, 1.0, 1.0], [0.82, 0.85, 0.9])
#: RGBA of the arm when it is drawn from collision geometry (URDFs without visual elements).
COLLISION_COLOR = [0.35, 0.38, 0.42, 1.0]
_ROBOT_NODE = "robot"


# --------------------------------------------------------------------------- input checks
def _array(value: Any, name: str, shape: tuple[int | None, ...], dtype: type = float) -> np.ndarray:
    """Finite array whose shape matches `shape` (None = any size); AnimationError otherwise."""
    try:
        array = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise AnimationError(f"{name}: expected a numeric array, got {type(value).__name__}") from exc
    expected = "(" + ", ".join("*" if s is None else str(s) for s in shape) + (",)" if len(shape) == 1 else ")")
    if array.ndim != len(shape) or any(s is not None and a != s for a, s in zip(array.shape, shape)):
        raise AnimationError(f"{name}: expected shape {expected}, got {array.shape}")
    if array.dtype.kind == "f" and not np.all(np.isfinite(array)):
        raise AnimationError(f"{name}: contains NaN or inf values")
    return array


def surface_from_grid(X: Any, Y: Any, Z: Any) -> tuple[np.ndarray, np.ndarray]:
    """Triangle mesh of a grid surface: X, Y, Z (K, A) [m] (e.g. ``tlgc`` ``cyl.surface()``) ->
    vertices (K*A, 3), faces (2*(K-1)*(A-1), 3) int (two triangles per grid cell)."""
    X = _array(X, "X", (None, None))
    K, A = X.shape
    Y = _array(Y, "Y", (K, A))
    Z = _array(Z, "Z", (K, A))
    if K < 2 or A < 2:
        raise AnimationError(f"X, Y, Z: expected at least a 2 x 2 grid, got {X.shape}")
    vertices = np.stack((X, Y, Z), axis=-1).reshape(-1, 3)
    index = np.arange(K * A).reshape(K, A)
    a, b = index[:-1, :-1].ravel(), index[:-1, 1:].ravel()
    c, d = index[1:, :-1].ravel(), index[1:, 1:].ravel()
    faces = np.concatenate((np.column_stack((a, b, d)), np.column_stack((a, d, c))))
    return vertices, faces


def _check_surface(surface: Any) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(surface, (tuple, list)) or len(surface) != 2:
        raise AnimationError("extra_surface: expected (vertices (V, 3), faces (F, 3)), got "
                             f"{type(surface).__name__}")
    vertices = _array(surface[0], "extra_surface vertices", (None, 3))
    faces = np.asarray(surface[1])
    if faces.ndim != 2 or faces.shape[1] != 3 or faces.dtype.kind not in "iu":
        raise AnimationError(f"extra_surface faces: expected an integer array (F, 3), got {faces.dtype} {faces.shape}")
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise AnimationError(f"extra_surface faces: indices must lie in [0, {len(vertices) - 1}]")
    return vertices, faces.astype(np.uint32)


# --------------------------------------------------------------------------- meshcat plumbing
class _SceneRecorder:
    """A meshcat window that records commands instead of sending them to a server.

    Keeps, like meshcat's server scene tree, the last object, its properties and the last
    transform per path (in first-use order) and the last animation.
    """

    def __init__(self) -> None:
        self.nodes: dict[str, dict[str, Any]] = {}
        self.animation: bytes | None = None

    def send(self, command: Any) -> None:
        import umsgpack

        data = command.lower()
        packed = umsgpack.packb(data)
        kind = data["type"]
        if kind == "set_animation":
            self.animation = packed
            return
        node = self.nodes.setdefault(data["path"], {"object": None, "properties": [], "transform": None})
        if kind == "set_object":
            node["object"], node["properties"] = packed, []
        elif kind == "set_transform":
            node["transform"] = packed
        elif kind == "set_property":
            node["properties"].append(packed)
        elif kind == "delete":
            for path in [p for p in self.nodes if p == data["path"] or p.startswith(data["path"] + "/")]:
                del self.nodes[path]
        else:
            logger.debug("animation: ignoring meshcat command %r", kind)

    def commands(self) -> list[bytes]:
        """Recorded commands in replay order: objects, properties, transforms; animation last."""
        out: list[bytes] = []
        for node in self.nodes.values():
            if node["object"] is not None:
                out.append(node["object"])
            out.extend(node["properties"])
            if node["transform"] is not None:
                out.append(node["transform"])
        if self.animation is not None:
            out.append(self.animation)
        return out


def _imports():
    """meshcat, meshcat.geometry, meshcat.animation, pinocchio and the visualizer class."""
    try:
        import meshcat
        import meshcat.animation
        import meshcat.geometry
        import pinocchio as pin
        from pinocchio.visualize import MeshcatVisualizer
        from pinocchio.visualize.meshcat_visualizer import loadMesh
    except ImportError as exc:
        raise AnimationError(f"write_animation needs meshcat (pip install meshcat) and pinocchio: {exc}") from exc

    class TriangleMeshVisualizer(MeshcatVisualizer):
        """Pinocchio's MeshcatVisualizer, sending mesh files as triangle arrays (coal's triangles)
        instead of Collada text: same geometry, about a third of the bytes."""

        def loadMeshFromFile(self, geometry_object):  # noqa: N802 (Pinocchio's name)
            mesh = loadMesh(geometry_object.geometry)
            scale = np.asarray(geometry_object.meshScale, dtype=float)
            vertices = getattr(mesh, "vertices", None)
            if vertices is not None and np.all(scale != 0):
                # coal's vertices are already scaled; the viewer applies meshScale to the placement
                mesh.vertices = (vertices / scale).astype(np.float32)
            return mesh

    return meshcat, pin, TriangleMeshVisualizer


def robot_geometry(robot, pin) -> tuple[Any, str]:
    """The URDF's visual GeometryModel for robot.model, or its collision geometry when the URDF
    has no visual elements (the built-in Sawyer); returns (model, "visual" | "collision")."""
    urdf = getattr(robot, "urdf_path", None)
    if urdf is None:
        raise AnimationError("robot: has no urdf_path to read the visual geometry from (use robots.load_robot "
                             "or Robot.from_urdf)")
    for kind in ("visual", "collision"):
        geometry_type = pin.GeometryType.VISUAL if kind == "visual" else pin.GeometryType.COLLISION
        try:
            model = pin.buildGeomFromUrdf(robot.model, str(urdf), geometry_type,
                                          package_dirs=list(getattr(robot, "package_dirs", ())))
        except Exception as exc:  # Pinocchio raises bare RuntimeErrors (missing meshes, bad URDF)
            raise AnimationError(f"robot: cannot load the {kind} geometry of {str(urdf)!r}: {exc}") from exc
        if model.ngeoms > 0:
            if kind == "collision":
                logger.info("animation: %s has no visual geometry; drawing its collision geometry", urdf)
            return model, kind
    raise AnimationError(f"robot: the URDF {str(urdf)!r} has neither visual nor collision geometry to draw")


def planning_frame_transform(robot, pin) -> np.ndarray:
    """4x4 transform from the URDF root (Pinocchio world) to the robot's planning base frame."""
    base = getattr(robot, "base_frame", None)
    if not base:
        return np.eye(4)
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))

    return data.oMf[frame_index(model, base)].inverse().homogeneous


def _capsule_mesh(mg, radius: float, height: float, segments: int = 24):
    """A capsule along z (segment length ``height`` [m], ``radius`` [m]) as a triangle mesh:
    a sphere's latitude rings, the upper half moved up and the lower down by height / 2."""
    rings = segments // 2 + 1
    polar = np.linspace(0.0, np.pi, rings)
    azimuth = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    z = np.cos(polar)[:, None] * radius + np.where(polar < np.pi / 2, 0.5, -0.5)[:, None] * height
    ring = np.sin(polar)[:, None] * radius
    vertices = np.stack([ring * np.cos(azimuth), ring * np.sin(azimuth),
                         np.broadcast_to(z, (rings, segments))], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(rings - 1), np.arange(segments), indexing="ij")
    a, b = i * segments + j, i * segments + (j + 1) % segments
    c, d = a + segments, b + segments
    faces = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3),
                            np.stack([b, c, d], -1).reshape(-1, 3)])
    return mg.TriangularMeshGeometry(vertices, faces)


def _obstacle_geometry(obstacle: Any, index: int, mg, pin) -> tuple[Any, np.ndarray]:
    """meshcat geometry and 4x4 placement of one scenes obstacle."""

    placement = np.eye(4)
    if isinstance(obstacle, TriangleMesh):   # vertices in the scene frame
        return mg.TriangularMeshGeometry(np.asarray(obstacle.vertices, float), np.asarray(obstacle.faces)), placement
    placement[:3, 3] = obstacle.center
    if isinstance(obstacle, Box):
        if obstacle.rotation is not None:
            placement[:3, :3] = obstacle.rotation
        return mg.Box(np.asarray(obstacle.size, dtype=float).tolist()), placement
    if isinstance(obstacle, Sphere):
        return mg.Sphere(float(obstacle.radius)), placement
    if isinstance(obstacle, Cylinder):  # three.js cylinders run along y
        rotation = pin.Quaternion.FromTwoVectors(np.array([0.0, 1.0, 0.0]), np.asarray(obstacle.axis, float))
        placement[:3, :3] = rotation.toRotationMatrix()
        return mg.Cylinder(float(obstacle.height), float(obstacle.radius)), placement
    if isinstance(obstacle, Capsule):   # the mesh runs along z
        rotation = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), np.asarray(obstacle.axis, float))
        placement[:3, :3] = rotation.toRotationMatrix()
        return _capsule_mesh(mg, float(obstacle.radius), float(obstacle.height)), placement
    raise AnimationError(f"obstacles[{index}]: expected a scenes Box, Sphere, Cylinder, Capsule, "
                         f"TriangleMesh or PointCloud, got {type(obstacle).__name__}")


def _line(mg, points: np.ndarray, color: int):
    return mg.Line(mg.PointsGeometry(np.ascontiguousarray(points.T, dtype=np.float32)),
                   mg.LineBasicMaterial(color=color))


# --------------------------------------------------------------------------- the page
_PAGE = """<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
body {{ margin: 0; }}
#meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
#player {{ position: fixed; left: 8px; right: 8px; bottom: 8px; display: flex; align-items: center; gap: 8px;
          font: 13px sans-serif; color: #333; background: rgba(255, 255, 255, 0.8); padding: 4px 8px;
          border-radius: 4px; }}
#player input[type=range] {{ flex: 1; }}
#player button {{ width: 4.5em; }}
#clock {{ font-variant-numeric: tabular-nums; white-space: nowrap; }}
#caption {{ white-space: nowrap; overflow: hidden; text-overflow: ellipsis; max-width: 40%; }}
</style>
</head>
<body>
<div id="meshcat-pane"></div>
<div id="player"><button id="play" type="button">pause</button>
<input id="scrub" type="range" min="0" max="{duration}" step="any" value="0" aria-label="time [s]">
<span id="clock">0.00 / {duration:.2f} s</span><span id="caption">{caption}</span></div>
<script>
// meshcat's viewer bundle (three.js included) and the recorded meshcat scene commands (msgpack,
// each preceded by its 4-byte big-endian length), both gzip-compressed and base64-encoded.
const BUNDLE = "{bundle}";
const COMMANDS = "{commands}";
const TARGET = {target};   // the camera's orbit centre, three.js coordinates (y up)
async function gunzip(text) {{
  const raw = atob(text);
  const bytes = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; i++) bytes[i] = raw.charCodeAt(i);
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
  return new Uint8Array(await new Response(stream).arrayBuffer());
}}
var viewer;
(async () => {{
  const script = document.createElement("script");
  script.textContent = new TextDecoder().decode(await gunzip(BUNDLE));
  document.head.appendChild(script);
  viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
  const data = await gunzip(COMMANDS);
  const view = new DataView(data.buffer);
  for (let at = 0; at < data.length; ) {{
    const size = view.getUint32(at);
    viewer.handle_command_bytearray(data.subarray(at + 4, at + 4 + size));
    at += 4 + size;
  }}
  viewer.controls.target.set(TARGET[0], TARGET[1], TARGET[2]);
  viewer.controls.update();
  const animator = viewer.animator, play = document.getElementById("play");
  const scrub = document.getElementById("scrub"), clock = document.getElementById("clock");
  function show(t) {{
    animator.play();
    animator.pause();
    animator.seek(t);
    animator.display_progress(t);
    play.textContent = "play";
  }}
  play.onclick = () => {{
    if (animator.playing) {{ animator.pause(); play.textContent = "play"; }}
    else {{ animator.play(); play.textContent = "pause"; }}
  }};
  scrub.oninput = () => show(parseFloat(scrub.value));
  (function tick() {{
    const t = animator.actions.length ? animator.actions[0].time : 0;
    scrub.value = t;
    clock.textContent = t.toFixed(2) + " / {duration:.2f} s";
    requestAnimationFrame(tick);
  }})();
  // "#t=SECONDS" (or "?t=SECONDS") freezes the animation at that time.
  function seekFromUrl() {{
    const value = new URLSearchParams(location.hash.slice(1)).get("t") ?? new URLSearchParams(location.search).get("t");
    const t = parseFloat(value);
    if (value !== null && isFinite(t) && animator.actions.length > 0) show(t);
  }}
  seekFromUrl();
  window.addEventListener("hashchange", seekFromUrl);
}})();
</script>
</body>
</html>
"""


def animation_html(robot, time: Any, q: Any, obstacles: Any = None, demonstrations: Any = None,
                   mean_path: Any = None, extra_surface: Any = None, *, title: str | None = None,
                   show_ee_path: bool = True, frame_rate: float | None = None, loop: bool = True) -> str:
    """The animation page as a string; see write_animation for the arguments."""
    meshcat, pin, Visualizer = _imports()
    mg = meshcat.geometry
    n = int(robot.n)
    time = _array(time, "time", (None,))
    if time.shape[0] < 2 or np.any(np.diff(time) <= 0):
        raise AnimationError(f"time: expected (T,) strictly increasing with T >= 2, got {time.shape[0]} values")
    q = _array(q, "q", (time.shape[0], n))
    time = time - time[0]
    if frame_rate is not None:
        if not isinstance(frame_rate, (int, float)) or not math.isfinite(frame_rate) or frame_rate <= 0:
            raise AnimationError(f"frame_rate: expected a positive number of frames per second, got {frame_rate!r}")
        frames = np.append(np.arange(0.0, time[-1], 1.0 / frame_rate), time[-1])
        q = np.column_stack([np.interp(frames, time, q[:, j]) for j in range(n)])
        time = frames
    if obstacles is not None:
        if isinstance(obstacles, Scene):
            obstacles = obstacles.obstacles
        elif not isinstance(obstacles, Sequence):
            raise AnimationError(f"obstacles: expected a scenes.Scene, a list of obstacles or None, "
                                 f"got {type(obstacles).__name__}")
    if demonstrations is not None:
        demonstrations = _array(getattr(demonstrations, "positions", demonstrations), "demonstrations",
                                (None, None, 3))
    if mean_path is not None:
        mean_path = _array(mean_path, "mean_path", (None, 3))
    surface = _check_surface(extra_surface) if extra_surface is not None else None

    recorder = _SceneRecorder()
    vis = meshcat.Visualizer(window=recorder)
    visual_model, source = robot_geometry(robot, pin)
    if source == "collision":
        for geometry in visual_model.geometryObjects:
            geometry.meshColor = np.array(COLLISION_COLOR)
    viz = Visualizer(robot.model, None, visual_model)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        viz.initViewer(viewer=vis)
        viz.loadViewerModel(rootNodeName=_ROBOT_NODE)
    for warning in caught:
        logger.warning("animation: %s", warning.message)
    names = [viz.getViewerNodeName(g, pin.GeometryType.VISUAL) for g in visual_model.geometryObjects]
    drawn = [recorder.nodes.get(vis[name].path.lower(), {}).get("object") is not None for name in names]
    if not any(drawn):
        raise AnimationError(f"robot: none of the {visual_model.ngeoms} visual geometries of {robot.name!r} "
                             "could be drawn")
    vis[_ROBOT_NODE].set_transform(planning_frame_transform(robot, pin))
    q_pin = robot.to_pinocchio(q)
    viz.display(q_pin[0])

    # one keyframe per sample; frame "numbers" are seconds (fps = 1)
    animation = meshcat.animation.Animation(default_framerate=1)
    data, visual_data = viz.data, viz.visual_data
    scales = [np.diag(np.append(np.asarray(g.meshScale, float), 1.0)) for g in visual_model.geometryObjects]
    for t, config in zip(time, q_pin):
        pin.forwardKinematics(robot.model, data, config)
        pin.updateGeometryPlacements(robot.model, data, visual_model, visual_data)
        frame = animation.at_frame(vis, float(t))
        for k, name in enumerate(names):
            frame[name].set_transform(visual_data.oMg[k].homogeneous @ scales[k])

    points = [robot.frame_positions(q).reshape(-1, 3)]
    if obstacles:
        for i, obstacle in enumerate(obstacles):
            node = vis[f"scene/obstacles/{i}"]
            if isinstance(obstacle, PointCloud):   # points drawn at their diameter
                node.set_object(mg.Points(mg.PointsGeometry(np.ascontiguousarray(obstacle.points.T, dtype=np.float32)),
                                          mg.PointsMaterial(size=2.0 * float(np.max(obstacle.radius)),
                                                            color=COLORS["obstacle"])))
            else:
                geometry, placement = _obstacle_geometry(obstacle, i, mg, pin)
                node.set_object(geometry, mg.MeshLambertMaterial(color=COLORS["obstacle"], opacity=0.55))
                node.set_transform(placement)
            points.append(box_corners(np.clip(obstacle.aabb(), -2.0, 2.0)))
    if demonstrations is not None:
        for m, demo in enumerate(demonstrations):
            vis[f"scene/demonstrations/{m}"].set_object(_line(mg, demo, COLORS["demonstration"]))
        points.append(demonstrations.reshape(-1, 3))
    if mean_path is not None:
        vis["scene/mean_path"].set_object(_line(mg, mean_path, COLORS["mean_path"]))
        points.append(mean_path)
    if show_ee_path:
        vis["scene/ee_path"].set_object(_line(mg, robot.fk(q), COLORS["ee_path"]))
    if surface is not None:
        vertices, faces = surface
        if len(faces):
            vis["scene/surface"].set_object(mg.TriangularMeshGeometry(vertices, faces),
                                            mg.MeshLambertMaterial(color=COLORS["surface"], opacity=0.3))
            points.append(vertices)

    # floor: a grid at z = 0 of the planning frame under everything drawn (meshcat's own grid
    # and axes are hidden); camera: front-right and above the centre of everything drawn, at
    # the distance where their bounding box fills the view, orbiting about that centre
    cloud = np.concatenate(points)
    low, high = cloud.min(axis=0), cloud.max(axis=0)
    vis["scene/floor"].set_object(_floor(mg, low, high))
    vis["/Grid"].set_property("visible", False)
    vis["/Axes"].set_property("visible", False)
    low[2] = min(low[2], 0.0)
    centre = 0.5 * (low + high)
    direction = np.array([1.0, 0.75, 0.6]) / np.linalg.norm([1.0, 0.75, 0.6])
    offset = centre + direction * camera_distance(cloud, centre, direction)   # the floor may leave the view
    # the camera's parent node is turned by +90 degrees about x: world (x, y, z) = local (x, -z, y)
    vis["/Cameras/default/rotated/<object>"].set_property("position", [offset[0], offset[2], -offset[1]])
    target = [float(centre[0]), float(centre[2]), float(-centre[1])]
    vis["/Background"].set_property("top_color", BACKGROUND[0])
    vis["/Background"].set_property("bottom_color", BACKGROUND[1])
    vis.set_animation(animation, play=True, repetitions=math.inf if loop else 1)

    bundle_path = Path(meshcat.__file__).resolve().parent / "viewer" / "dist" / "main.min.js"
    try:
        bundle = bundle_path.read_text(encoding="utf-8")
    except OSError as exc:
        raise AnimationError(f"meshcat's viewer bundle {str(bundle_path)!r} is missing: {exc}") from exc
    title = title or f"{robot.name} plan"
    caption = f"{html.escape(title)} &mdash; {len(time)} frames; URL #t=SECONDS freezes a time"
    return _PAGE.format(title=html.escape(title), caption=caption, duration=float(time[-1]),
                        bundle=_packed(bundle.encode("utf-8")), commands=_packed(b"".join(
                            len(c).to_bytes(4, "big") + c for c in recorder.commands())),
                        target=json.dumps(target))


def box_corners(box: np.ndarray) -> np.ndarray:
    """The 8 corners (8, 3) of an axis-aligned box [[xmin, ymin, zmin], [xmax, ymax, zmax]]."""
    return np.array(np.meshgrid(*np.asarray(box, dtype=float).T)).reshape(3, -1).T


def camera_distance(points: np.ndarray, centre: np.ndarray, direction: np.ndarray, *, fov: float = CAMERA_FOV,
                    aspect: float = CAMERA_ASPECT, fill: float = CAMERA_FILL) -> float:
    """Distance [m] from ``centre`` (3,) along ``direction`` (3,) at which a camera looking at
    ``centre`` (z up; vertical field of view ``fov`` [deg], width / height ``aspect``) sees every
    point (P, 3) within ``fill`` of the half-width and half-height of its view."""
    back = direction / np.linalg.norm(direction)
    right = np.cross([0.0, 0.0, 1.0], back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    relative = points - centre
    x, y, z = relative @ right, relative @ up, relative @ back
    half_height = fill * math.tan(math.radians(0.5 * fov))
    half_width = aspect * half_height
    # a point is in view when |x| <= half_width (d - z) and |y| <= half_height (d - z)
    need = np.maximum(z + np.abs(x) / half_width, z + np.abs(y) / half_height)
    return max(float(need.max()), 0.3)


def _packed(data: bytes) -> str:
    """gzip then base64 (the page unpacks with the browser's DecompressionStream)."""
    return base64.b64encode(gzip.compress(data, compresslevel=9, mtime=0)).decode("ascii")


def _floor(mg, low: np.ndarray, high: np.ndarray, cell: float = FLOOR_CELL):
    """Grid lines at z = 0 [m] covering [low, high] in x and y plus one cell, on whole cells."""
    start = np.floor(low[:2] / cell) * cell - cell
    stop = np.ceil(high[:2] / cell) * cell + cell
    xs = np.arange(start[0], stop[0] + 0.5 * cell, cell)
    ys = np.arange(start[1], stop[1] + 0.5 * cell, cell)
    along_y = [[(x, ys[0], 0.0), (x, ys[-1], 0.0)] for x in xs]
    along_x = [[(xs[0], y, 0.0), (xs[-1], y, 0.0)] for y in ys]
    points = np.asarray(along_y + along_x, dtype=np.float32).reshape(-1, 3)
    return mg.LineSegments(mg.PointsGeometry(points.T), mg.LineBasicMaterial(color=COLORS["floor"]))


def write_animation(path: str | Path, robot, time: Any, q: Any, obstacles: Any = None,
                    demonstrations: Any = None, mean_path: Any = None, extra_surface: Any = None, *,
                    title: str | None = None, show_ee_path: bool = True, frame_rate: float | None = None,
                    loop: bool = True, overwrite: bool = True) -> Path:
    """Write a self-contained HTML animation of a plan; returns the path.

    robot: robots.Robot (its URDF's visual geometry is drawn); time (T,) s strictly increasing;
    q (T, n) rad; obstacles: scenes.Scene, list of scenes obstacles, or None;
    demonstrations: (M, T', 3) m (or a scenes.Demonstrations); mean_path: (T'', 3) m;
    extra_surface: triangle mesh (vertices (V, 3) m, faces (F, 3) int), e.g.
    surface_from_grid(*cyl.surface()); all in the robot's planning frame.
    title: page title; show_ee_path: draw the plan's end-effector path; frame_rate: resample
    the plan (linear in joint space) at this many frames per second (None: one keyframe per
    sample, in between the viewer interpolates each link's pose); loop: repeat the animation;
    overwrite: replace an existing file (written atomically either way).
    """

    if not overwrite and Path(path).exists():
        raise AnimationError(f"path: {str(path)!r} already exists; pass overwrite=True to replace it")
    text = animation_html(robot, time, q, obstacles, demonstrations, mean_path, extra_surface, title=title,
                          show_ee_path=show_ee_path, frame_rate=frame_rate, loop=loop)
    try:
        written = atomic_write_text(path, text, overwrite=overwrite,
                                    exists_error=lambda message: AnimationError(message))
    except AnimationError:
        raise
    except (OSError, ValueError) as exc:
        raise AnimationError(f"path: cannot write {str(path)!r}: {exc}") from exc
    logger.info("animation: wrote %s (%.1f MB)", written, len(text.encode("utf-8")) / 1e6)
    return written
