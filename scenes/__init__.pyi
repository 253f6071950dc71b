# The public names of scenes, read by static type checkers and, at run time, by
# lazy_loader.attach_stub in __init__.py (each submodule is imported on first use).
from .bags import BagSplit, load_bag_demonstrations
from .datasets import shared_dataset
from .demonstrations import NOMINAL_DURATION, Demonstrations
from .errors import (DemonstrationFileError, InvalidArgumentError, InvalidDemonstrationsError,
                     InvalidObstacleError, SceneFileError, ScenesError, UnknownSkillError)
from .io import load_demonstrations, save_csv
from .mesh import TriangleMesh
from .obstacles import Box, Capsule, Cylinder, Obstacle, Sphere
from .point_cloud import PointCloud
from .scene import DEFAULT_WORKSPACE, Scene, available_scenes, builtin_scene
from .sdf import SignedDistanceField
from .synthetic import SKILLS, make_cluttered_demonstrations, make_demonstrations

__all__ = [
    "Box", "Capsule", "Cylinder", "Obstacle", "Sphere", "TriangleMesh", "PointCloud", "Scene", "SignedDistanceField", "DEFAULT_WORKSPACE",
    "available_scenes", "builtin_scene",
    "Demonstrations", "NOMINAL_DURATION", "load_demonstrations", "save_csv",
    "load_bag_demonstrations", "BagSplit", "shared_dataset",
    "make_demonstrations", "make_cluttered_demonstrations", "SKILLS",
    "ScenesError", "InvalidArgumentError", "InvalidObstacleError", "SceneFileError",
    "InvalidDemonstrationsError", "DemonstrationFileError", "UnknownSkillError",
]
