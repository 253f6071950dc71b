"""The world and what was shown in it: obstacles, scenes, signed distance fields,
demonstration sets (import/export, resampling, time alignment) and synthetic skills."""
from .errors import (DemonstrationFileError, InvalidArgumentError, InvalidDemonstrationsError,
                     InvalidObstacleError, SceneFileError, ScenesError, UnknownSkillError)
from .obstacles import Box, Cylinder, Obstacle, Sphere
from .scene import DEFAULT_WORKSPACE, Scene, available_scenes, builtin_scene
from .sdf import SignedDistanceField

__all__ = [
    "Box", "Cylinder", "Obstacle", "Sphere", "Scene", "SignedDistanceField", "DEFAULT_WORKSPACE",
    "available_scenes", "builtin_scene",
    "ScenesError", "InvalidArgumentError", "InvalidObstacleError", "SceneFileError",
    "InvalidDemonstrationsError", "DemonstrationFileError", "UnknownSkillError",
]
