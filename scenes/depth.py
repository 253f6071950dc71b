"""Depth images to points in the robot's frame: back-projection, region of interest, voxel
downsampling and removal of the robot's own links (:meth:`scenes.PointCloud.from_depth`).

Conventions:

* ``depth`` (H, W): the distance along the optical axis (z) per pixel, in metres, or in the
  camera's integer unit (a 16-bit PNG's millimetres) times ``depth_scale`` (0.001 for mm).
  Pixels of 0, NaN or inf carry no measurement and are dropped.
* pinhole ``intrinsics``: fx, fy (focal lengths) and cx, cy (principal point), in pixels, as a
  3x3 matrix K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], a dict {"fx", "fy", "cx", "cy"} or a
  sequence (fx, fy, cx, cy). Pixel (row v, column u) has its centre at (u, v) (OpenCV's and ROS
  sensor_msgs/CameraInfo's convention), so its point is
  ``z * ((u - cx) / fx, (v - cy) / fy, 1)`` in the camera's optical frame.
* the optical frame is ROS's ``*_optical_frame``: z forward along the viewing direction, x to
  the right of the image, y down. ``camera_pose`` (4, 4) maps it to the robot's base frame
  (the frame of ``robot.fk`` and of the scenes): p_base = R p_camera + t.

The robot's own links are removed with coal on the robot's URDF collision geometry
(``robot.collision_model``, Pinocchio's placements at ``q``, the base link included): a point
goes when a ball of ``robot_margin`` about it touches a link (``coal.collide``), i.e. when the
point lies within robot_margin of the link's surface. Only the points inside a link's
axis-aligned box (coal's, grown by the margin) are queried. coal measures a mesh's surface:
a point deep inside a closed link mesh, touching no triangle, would stay; a camera sees
surfaces, so its points lie on or outside the links.
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InvalidArgumentError
from skillplan.validation import MAX_COORDINATE, as_array, as_bounds, as_positive, as_scalar, as_shaped

log = logging.getLogger(__name__)

#: default ball radius [m] about the points of a depth image's cloud (PointCloud.from_depth)
DEPTH_RADIUS = 0.01
#: default distance [m] from the robot's collision geometry within which points are dropped
#: (depth noise and the calibration of the camera pose: a few centimetres at a metre)
ROBOT_MARGIN = 0.03


def as_intrinsics(intrinsics: Any) -> tuple[float, float, float, float]:
    """(fx, fy, cx, cy) [px] from a 3x3 K, a dict or a sequence of four (module docstring)."""
    expected = ("a 3x3 camera matrix K, a dict with fx, fy, cx, cy or a sequence (fx, fy, cx, cy) "
                "[pixels]")
    if isinstance(intrinsics, dict):
        keys = {"fx", "fy", "cx", "cy"}
        if set(intrinsics) != keys:
            raise InvalidArgumentError(f"intrinsics: expected the keys {sorted(keys)}, got "
                                       f"{sorted(map(str, intrinsics))}")
        values = [intrinsics[k] for k in ("fx", "fy", "cx", "cy")]
        fx, fy, cx, cy = (as_scalar(v, f"intrinsics[{k!r}]") for k, v in zip(("fx", "fy", "cx", "cy"), values))
    else:
        arr = as_array(intrinsics, "intrinsics", InvalidArgumentError)
        if arr.shape == (3, 3):
            if arr[0, 1] != 0.0 or np.any(arr[1:, 0] != 0.0) or np.any(arr[2] != [0.0, 0.0, 1.0]):
                raise InvalidArgumentError(f"intrinsics: expected K = [[fx, 0, cx], [0, fy, cy], "
                                           f"[0, 0, 1]] (no skew), got {arr.tolist()}")
            fx, fy, cx, cy = arr[0, 0], arr[1, 1], arr[0, 2], arr[1, 2]
        elif arr.shape == (4,):
            fx, fy, cx, cy = arr
        else:
            raise InvalidArgumentError(f"intrinsics: expected {expected}, got shape {arr.shape}")
    if not (fx > 0 and fy > 0):
        raise InvalidArgumentError(f"intrinsics: expected positive focal lengths fx, fy [px], got "
                                   f"fx={fx:g}, fy={fy:g}")
    return float(fx), float(fy), float(cx), float(cy)


def as_camera_pose(camera_pose: Any) -> np.ndarray:
    """A 4x4 rigid transform camera optical frame -> robot base (rotation orthonormal with
    det +1, last row [0, 0, 0, 1])."""
    pose = as_shaped(camera_pose, "camera_pose", (4, 4), InvalidArgumentError, MAX_COORDINATE)
    R = pose[:3, :3]
    if (np.abs(pose[3] - [0.0, 0.0, 0.0, 1.0]).max() > 1e-9
            or np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0):
        raise InvalidArgumentError(f"camera_pose: expected a rigid transform (4x4, rotation "
                                   f"orthonormal with det +1, last row [0, 0, 0, 1]) from the "
                                   f"camera's optical frame to the robot base, got {np.round(pose, 4).tolist()}")
    return pose


def as_depth(depth: Any, depth_scale: Any) -> np.ndarray:
    """Depth (H, W) [m] = raw * depth_scale, NaN where there is no measurement (0, NaN, inf)."""
    raw = np.asarray(depth)
    if raw.ndim != 2 or min(raw.shape, default=0) < 1:
        raise InvalidArgumentError(f"depth: expected an image of shape (H, W), got shape {raw.shape}")
    if raw.dtype.kind not in "uif" or raw.dtype == bool:
        raise InvalidArgumentError(f"depth: expected numbers (metres, or an integer unit with "
                                   f"depth_scale), got dtype {raw.dtype}")
    scale = as_positive(depth_scale, "depth_scale")
    if raw.dtype.kind in "ui" and scale == 1.0:
        raise InvalidArgumentError(f"depth_scale: an integer depth image ({raw.dtype}) is in the "
                                   "camera's unit, usually millimetres: pass depth_scale=0.001 "
                                   "(metres per unit), got 1.0")
    metres = raw.astype(float) * scale
    metres[~np.isfinite(metres) | (metres <= 0.0)] = np.nan
    return metres


def back_project(depth: np.ndarray, intrinsics: tuple[float, float, float, float],
                 camera_pose: np.ndarray) -> np.ndarray:
    """Points (N, 3) [m] in the robot frame of the valid pixels of depth (H, W) [m, NaN
    invalid], row by row."""
    fx, fy, cx, cy = intrinsics
    v, u = np.nonzero(np.isfinite(depth))
    z = depth[v, u]
    camera = np.column_stack([(u - cx) * z / fx, (v - cy) * z / fy, z])
    return camera @ camera_pose[:3, :3].T + camera_pose[:3, 3]


def in_box(points: np.ndarray, roi: Any) -> np.ndarray:
    """Mask (N,) of the points inside the axis-aligned box roi (2, 3) [m] (boundary included)."""
    box = as_bounds(roi, "roi")
    return np.all((points >= box[0]) & (points <= box[1]), axis=1)


def voxel_centroids(points: np.ndarray, voxel: Any) -> np.ndarray:
    """One point per occupied voxel of edge ``voxel`` [m] (a grid anchored at the origin): the
    centroid of the points in it; (K, 3), in order of voxel index."""
    size = as_positive(voxel, "voxel")
    if not len(points):
        return points
    keys = np.floor(points / size).astype(np.int64)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    sums = np.zeros((len(counts), 3))
    np.add.at(sums, inverse, points)
    return sums / counts[:, None]


def near_robot(points: np.ndarray, robot: Any, q: Any, margin: float) -> np.ndarray:
    """Mask (N,) of the points within ``margin`` [m] of the robot's collision geometry at q (n,)
    (module docstring: coal on ``robot.collision_model``)."""
    import coal
    import pinocchio as pin

    for attribute in ("collision_model", "model", "to_pinocchio", "joint_names", "base_frame"):
        if not hasattr(robot, attribute):
            raise InvalidArgumentError(f"robot: expected a robots.Robot loaded from a URDF (its "
                                       f"collision geometry filters the arm's own points), got "
                                       f"{type(robot).__name__}")
    n = len(robot.joint_names)
    q = as_shaped(q, "q", (n,), InvalidArgumentError, MAX_COORDINATE)
    margin = as_positive(margin, "robot_margin")
    geometry = robot.collision_model
    model = robot.model
    data = model.createData()
    geometry_data = pin.GeometryData(geometry)
    pin.updateGeometryPlacements(model, data, geometry, geometry_data, robot.to_pinocchio(q))
    if robot.base_frame is None:
        root = points
    else:                                   # the points into Pinocchio's world (the URDF root)
        pin.updateFramePlacements(model, data)
        base = data.oMf[model.getFrameId(robot.base_frame)]
        root = points @ np.asarray(base.rotation).T + np.asarray(base.translation)
    ball = coal.Sphere(margin)
    request, result = coal.CollisionRequest(), coal.CollisionResult()
    near = np.zeros(len(points), dtype=bool)
    for k, obj in enumerate(geometry.geometryObjects):
        placement = geometry_data.oMg[k]
        transform = coal.Transform3s(np.asarray(placement.rotation), np.asarray(placement.translation))
        bounded = coal.CollisionObject(obj.geometry, transform)
        bounded.computeAABB()
        box = bounded.getAABB()
        low, high = np.asarray(box.min_) - margin, np.asarray(box.max_) + margin
        candidates = np.flatnonzero(~near & np.all((root >= low) & (root <= high), axis=1))
        for i in candidates:
            result.clear()
            if coal.collide(obj.geometry, transform, ball,
                            coal.Transform3s(np.eye(3), root[i]), request, result) > 0:
                near[i] = True
    return near


def depth_points(depth: Any, intrinsics: Any, camera_pose: Any, *, depth_scale: float = 1.0,
                 roi: Any = None, voxel: float | None = None, robot: Any = None, q: Any = None,
                 robot_margin: float = ROBOT_MARGIN) -> np.ndarray:
    """Points (N, 3) [m] in the robot frame seen in a depth image (see
    :meth:`scenes.PointCloud.from_depth` for the arguments). The steps are logged (INFO)."""
    metres = as_depth(depth, depth_scale)
    pose = as_camera_pose(camera_pose)
    points = back_project(metres, as_intrinsics(intrinsics), pose)
    counts = [f"{metres.size} pixels", f"{len(points)} valid"]
    if roi is not None:
        points = points[in_box(points, roi)]
        counts.append(f"{len(points)} in the region of interest")
    if (robot is None) != (q is None):
        raise InvalidArgumentError("robot, q: expected both (the robot and its configuration q "
                                   "[rad] when the image was taken) to remove the arm's own points, "
                                   f"or neither; got robot={type(robot).__name__}, q={q!r:.40}")
    if voxel is not None:
        points = voxel_centroids(points, voxel)
        counts.append(f"{len(points)} voxels of {voxel:g} m")
    if robot is not None:
        points = points[~near_robot(points, robot, q, robot_margin)]
        counts.append(f"{len(points)} beyond {robot_margin:g} m of {getattr(robot, 'name', 'the robot')}")
    log.info("depth image: %s", ", ".join(counts))
    return points


# ------------------------------------------------------------------------------ scene files
#: the fields of a scene file's depth-image obstacle (besides "type"), required and optional
DEPTH_FIELDS = ("file", "intrinsics", "camera_pose")
DEPTH_OPTIONS = ("depth_scale", "roi", "voxel", "radius")


def read_depth_image(path: Any) -> np.ndarray:
    """The depth image (H, W) in a ``.npy`` file (any numeric dtype) or a 16-bit greyscale
    ``.png`` (uint16, the camera's unit: pass its depth_scale), read with Pillow.
    InvalidArgumentError naming the file when it cannot be read."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".npy", ".png"):
        raise InvalidArgumentError(f"{path}: expected a depth image in a .npy or 16-bit .png file")
    try:
        if suffix == ".npy":
            return np.load(path, allow_pickle=False)
        from PIL import Image      # deferred: Pillow loads only for a .png depth image
        with Image.open(path) as image:
            if image.mode not in ("I;16", "I;16B", "I;16L", "I"):
                raise InvalidArgumentError(f"{path}: expected a 16-bit greyscale PNG (a depth "
                                           f"image), got PNG mode {image.mode!r}")
            return np.array(image).astype(np.uint16)
    except InvalidArgumentError:
        raise
    except Exception as exc:  # numpy / Pillow raise several kinds for a bad file
        raise InvalidArgumentError(f"{path}: cannot read the depth image ({type(exc).__name__}: "
                                   f"{exc})") from None


def depth_entry_points(item: dict, where: str, folder: Any) -> tuple[np.ndarray, Any]:
    """Points (N, 3) and radius of a scene file's ``{"type": "depth_image", ...}`` entry: its
    ``file`` (relative to ``folder``, the scene file's), ``intrinsics``, ``camera_pose`` and
    optional ``depth_scale``, ``roi``, ``voxel``, ``radius``. InvalidArgumentError naming the
    entry and field otherwise."""
    from pathlib import Path
    fields = {k: v for k, v in item.items() if k != "type"}
    missing = [k for k in DEPTH_FIELDS if k not in fields]
    unknown = sorted(set(fields) - set(DEPTH_FIELDS) - set(DEPTH_OPTIONS))
    if missing or unknown:
        raise InvalidArgumentError(f"{where}: a depth_image takes {list(DEPTH_FIELDS)} and optionally "
                                   f"{list(DEPTH_OPTIONS)}; missing {missing}, unknown {unknown}")
    name = fields["file"]
    if not isinstance(name, str) or not name:
        raise InvalidArgumentError(f"{where}.file: expected the name of a .npy or .png depth image, "
                                   f"got {name!r:.60}")
    try:
        depth = read_depth_image(Path(folder) / name)
        options = {k: fields[k] for k in ("depth_scale", "roi", "voxel") if k in fields}
        points = depth_points(depth, fields["intrinsics"], fields["camera_pose"], **options)
    except InvalidArgumentError as exc:
        raise InvalidArgumentError(f"{where} ({name}): {exc}") from None
    if not len(points):
        raise InvalidArgumentError(f"{where} ({name}): no point left (no valid pixel, or none in roi)")
    return points, fields.get("radius")
