"""Depth images into point clouds (scenes.depth, PointCloud.from_depth): images rendered here by
ray casting (ray-box slabs, ray-sphere) from a pinhole camera, recovered as clouds in the
robot frame."""
from __future__ import annotations

import json

import numpy as np
from scipy.spatial import cKDTree

from bad_input import raises_naming
from scenes import Box, InvalidArgumentError, PointCloud, Scene, SceneFileError

W, H = 320, 240
INTRINSICS = (300.0, 300.0, (W - 1) / 2, (H - 1) / 2)       # fx, fy, cx, cy [px]
BOX = Box([0.5, 0.0, 0.1], [0.2, 0.3, 0.2])
VOXEL = 0.01


# ------------------------------------------------------------------------------ rendering
def look_at(eye, target) -> np.ndarray:
    """Camera pose (4, 4), optical frame (z forward, x right, y down) -> robot frame."""
    z = np.asarray(target, float) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    pose[:3, 3] = eye
    return pose


def rays(pose, intrinsics=INTRINSICS, shape=(H, W)):
    """Origin (3,) and per pixel the direction (H, W, 3) whose optical z component is 1, so
    the ray parameter at a hit is the pixel's depth."""
    fx, fy, cx, cy = intrinsics
    v, u = np.mgrid[0:shape[0], 0:shape[1]].astype(float)
    camera = np.stack([(u - cx) / fx, (v - cy) / fy, np.ones_like(u)], axis=-1)
    return pose[:3, 3], camera @ pose[:3, :3].T


def hit_box(origin, direction, low, high) -> np.ndarray:
    """Ray parameter (H, W) of the first hit of an axis-aligned box (slabs), inf for a miss."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (np.asarray(low) - origin) / direction
        t2 = (np.asarray(high) - origin) / direction
    near = np.nanmax(np.minimum(t1, t2), axis=-1)
    far = np.nanmin(np.maximum(t1, t2), axis=-1)
    return np.where((far >= near) & (near > 0.0), near, np.inf)


def hit_sphere(origin, direction, centre, radius) -> np.ndarray:
    """Ray parameter (H, W) of the first hit of a sphere, inf for a miss."""
    oc = origin - np.asarray(centre)
    a = np.sum(direction ** 2, axis=-1)
    b = 2.0 * direction @ oc
    c = oc @ oc - radius ** 2
    disc = b * b - 4 * a * c
    root = (-b - np.sqrt(np.maximum(disc, 0.0))) / (2 * a)
    return np.where((disc >= 0.0) & (root > 0.0), root, np.inf)


def render(pose, boxes=(BOX,), spheres=()) -> np.ndarray:
    """Depth image (H, W) [m] of the boxes and spheres (centre, radius); 0 where nothing is hit."""
    origin, direction = rays(pose)
    depth = np.full((H, W), np.inf)
    for box in boxes:
        lo, hi = box.aabb()
        depth = np.minimum(depth, hit_box(origin, direction, lo, hi))
    for centre, radius in spheres:
        depth = np.minimum(depth, hit_sphere(origin, direction, centre, radius))
    return np.where(np.isfinite(depth), depth, 0.0)


def face_samples(box: Box, eye, spacing=0.005) -> np.ndarray:
    """Points on the faces of an axis-aligned box that face the camera at eye."""
    lo, hi = box.aabb()
    out = []
    for axis in range(3):
        for side, value in ((-1, lo[axis]), (1, hi[axis])):
            if side * (eye[axis] - value) <= 0:
                continue                         # the face looks away from the camera
            others = [a for a in range(3) if a != axis]
            grids = np.meshgrid(*[np.arange(lo[a], hi[a] + 1e-9, spacing) for a in others], indexing="ij")
            points = np.empty((grids[0].size, 3))
            points[:, axis] = value
            for a, grid in zip(others, grids):
                points[:, a] = grid.ravel()
            out.append(points)
    return np.concatenate(out)


EYE = np.array([1.3, 0.6, 0.9])
POSE = look_at(EYE, BOX.center)


# ------------------------------------------------------------------------------ recovery
def test_the_visible_surface_of_a_box_is_recovered_within_one_voxel():
    depth = render(POSE)
    exact = PointCloud.from_depth(depth, INTRINSICS, POSE)
    assert np.abs(BOX.distance(exact.points)).max() < 1e-9         # back-projection is exact
    cloud = PointCloud.from_depth(depth, INTRINSICS, POSE, voxel=VOXEL, radius=0.006)
    assert len(cloud.points) < len(exact.points) / 2
    assert np.abs(BOX.distance(cloud.points)).max() <= VOXEL           # every point near the box
    visible = face_samples(BOX, EYE)
    gap, _ = cKDTree(cloud.points).query(visible)
    assert gap.max() <= VOXEL * np.sqrt(3), gap.max()                 # the visible faces covered
    # one point per occupied voxel
    keys = np.floor(exact.points / VOXEL).astype(int)
    assert len(cloud.points) == len(np.unique(keys, axis=0))
    assert cloud.radius == 0.006


def test_pixels_without_measurement_are_dropped():
    depth = render(POSE)
    valid = int((depth > 0).sum())
    rows, cols = np.nonzero(depth > 0)
    depth[rows[::7], cols[::7]] = np.nan
    depth[rows[1::7], cols[1::7]] = np.inf
    depth[rows[2::7], cols[2::7]] = 0.0
    cloud = PointCloud.from_depth(depth, INTRINSICS, POSE)
    assert np.all(np.isfinite(cloud.points))
    assert len(cloud.points) == valid - len(rows[::7]) - len(rows[1::7]) - len(rows[2::7])


def test_millimetres_with_a_scale():
    depth = render(POSE)
    millimetres = np.round(depth * 1000.0).astype(np.uint16)
    cloud = PointCloud.from_depth(millimetres, INTRINSICS, POSE, depth_scale=0.001)
    assert np.abs(BOX.distance(cloud.points)).max() < 1e-3            # 0.5 mm rounding x slant
    assert len(cloud.points) == int((depth > 0).sum())
    with raises_naming(InvalidArgumentError, "depth_scale"):
        PointCloud.from_depth(millimetres, INTRINSICS, POSE)


def test_region_of_interest():
    depth = render(POSE)
    roi = [[0.0, -1.0, 0.15], [1.0, 1.0, 1.0]]                       # the top 5 cm of the box
    whole = PointCloud.from_depth(depth, INTRINSICS, POSE)
    cloud = PointCloud.from_depth(depth, INTRINSICS, POSE, roi=roi)
    assert np.all(cloud.points[:, 2] >= 0.15)
    assert len(cloud.points) == int((whole.points[:, 2] >= 0.15).sum()) < len(whole.points)


def test_intrinsics_forms_agree_and_bad_arguments_are_named():
    depth = render(POSE)
    fx, fy, cx, cy = INTRINSICS
    K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]
    reference = PointCloud.from_depth(depth, INTRINSICS, POSE).points
    for form in (K, {"fx": fx, "fy": fy, "cx": cx, "cy": cy}, list(INTRINSICS)):
        np.testing.assert_array_equal(PointCloud.from_depth(depth, form, POSE).points, reference)
    cases = [((depth, (0.0, fy, cx, cy), POSE), "intrinsics"),
             ((depth, {"fx": fx}, POSE), "intrinsics"),
             ((depth, INTRINSICS, np.eye(3)), "camera_pose"),
             ((depth, INTRINSICS, 2 * np.eye(4)), "camera_pose"),
             ((depth[0], INTRINSICS, POSE), "depth"),
             ((depth, INTRINSICS, POSE, {"voxel": -1.0}), "voxel"),
             ((depth, INTRINSICS, POSE, {"roi": [[1, 1, 1], [0, 0, 0]]}), "roi"),
             ((np.zeros((H, W)), INTRINSICS, POSE), "PointCloud.from_depth")]
    for args, word in cases:
        kwargs = args[3] if len(args) == 4 else {}
        with raises_naming(InvalidArgumentError, word):
            PointCloud.from_depth(*args[:3], **kwargs)


# ------------------------------------------------------------------------------ the arm's pixels
def arm_view(jaco):
    """A camera that sees the Jaco (its collision spheres rendered) and the box; q, pose, depth."""
    q = jaco.neutral_configuration()
    centres, _ = jaco.sphere_centres(q)
    spheres = list(zip(centres, jaco.spheres.radii))
    eye = np.array([1.2, -1.0, 0.9])
    pose = look_at(eye, [0.25, -0.15, 0.3])
    return q, pose, render(pose, boxes=(BOX,), spheres=spheres)


def test_the_arms_own_pixels_are_removed(jaco):
    from robots.collision_check import CollisionChecker
    from scenes.coal_shapes import coal_obstacles
    from scenes import Sphere
    q, pose, depth = arm_view(jaco)
    margin = 0.03
    seen = PointCloud.from_depth(depth, INTRINSICS, pose, voxel=VOXEL)
    on_box = np.abs(BOX.distance(seen.points)) <= VOXEL
    assert (~on_box).sum() > 200                                     # the camera sees the arm
    cloud = PointCloud.from_depth(depth, INTRINSICS, pose, voxel=VOXEL, robot=jaco, q=q,
                                  robot_margin=margin)
    # independent check (robots.collision_check, coal on the URDF meshes): a ball of the margin
    # about every point left touches no link, the base included
    balls = [Sphere(p, margin) for p in cloud.points]
    checker = CollisionChecker(jaco, coal_obstacles(Scene(balls, bounds=[[-2] * 3, [2] * 3])),
                               include_fixed=True)
    report = checker.check(q[None], margin=0.0)
    assert not report.collision and not report.fixed_overlaps, report.min_distance
    # the box is kept whole, and at most a few of the arm's points stay (where the rendered
    # spheres bulge out beyond the meshes by more than the margin)
    kept_box = np.abs(BOX.distance(cloud.points)) <= VOXEL
    assert kept_box.sum() == on_box.sum()
    assert (~kept_box).sum() <= 0.1 * (~on_box).sum()


# ------------------------------------------------------------------------------ planning
def test_a_plan_around_the_cloud_clears_the_true_box(jaco, prior):
    """The box under the free plan's path, seen by a camera above: planned around the cloud,
    the arm keeps clear of the true box (coal on the URDF meshes)."""
    from clamp import plan
    from robots.collision_check import CollisionChecker
    from scenes.coal_shapes import coal_obstacles
    start = np.array([0.2054, -0.4722, 0.2625])
    free = plan(prior, jaco, None, start)
    middle = free.ee_path[len(free.ee_path) // 2]
    box = Box(middle - [0.0, 0.0, 0.04 - 0.02], [0.08, 0.08, 0.08])    # 2 cm into the path
    free_check = CollisionChecker(jaco, coal_obstacles(Scene([box]))).check(free.q)
    assert free_check.collision                                         # the box is in the way
    eye = middle + [0.5, -0.4, 0.6]
    pose = look_at(eye, box.center)
    cloud = PointCloud.from_depth(render(pose, boxes=(box,)), INTRINSICS, pose, voxel=VOXEL,
                                  radius=VOXEL)
    result = plan(prior, jaco, Scene([cloud]), start)
    assert result.success, result.reasons if hasattr(result, "reasons") else result
    report = CollisionChecker(jaco, coal_obstacles(Scene([box]))).check(result.q, margin=0.0)
    assert not report.collision and report.min_distance > 0.0, report.min_distance


# ------------------------------------------------------------------------------ scene files
def test_a_depth_image_in_a_scene_file(tmp_path):
    from PIL import Image
    depth = render(POSE)
    Image.fromarray(np.round(depth * 1000).astype(np.uint16)).save(tmp_path / "camera.png")
    np.save(tmp_path / "camera.npy", depth)
    fx, fy, cx, cy = INTRINSICS
    entry = {"type": "depth_image", "intrinsics": {"fx": fx, "fy": fy, "cx": cx, "cy": cy},
             "camera_pose": POSE.tolist(), "voxel": VOXEL}
    scene_file = tmp_path / "scenes" / "scene.json"
    scene_file.parent.mkdir()
    scene_file.write_text(json.dumps({"obstacles": [
        {**entry, "file": "../camera.png", "depth_scale": 0.001, "radius": 0.02},
        {**entry, "file": "../camera.npy"}]}))
    png, npy = Scene.load(scene_file).obstacles                         # relative to the scene file
    assert isinstance(png, PointCloud) and png.radius == 0.02 and npy.radius == 0.01
    assert np.abs(BOX.distance(png.points)).max() <= VOXEL
    for cloud in (png, npy):
        gap, _ = cKDTree(cloud.points).query(face_samples(BOX, EYE))
        assert gap.max() <= VOXEL * np.sqrt(3)
    for bad, word in [({**entry, "file": "../missing.npy"}, "missing.npy"),
                      ({**entry, "file": "../camera.npy", "colour": 1}, "colour"),
                      ({k: v for k, v in entry.items() if k != "camera_pose"} | {"file": "../camera.npy"},
                       "camera_pose"),
                      ({**entry, "file": "../camera.png"}, "depth_scale")]:
        scene_file.write_text(json.dumps({"obstacles": [bad]}))
        with raises_naming(SceneFileError, scene_file.name, "obstacles[0]", word):
            Scene.load(scene_file)
