"""TLGC: trajectory learning with generalized cylinders.

Core (fit, cross-sections, frames, reproduction) plus generalization (TPS, Laplacian editing),
obstacle strategies, refinement and the CLAMP boundary factor. The boundary-factor names are
imported on first use so that ``import tlgc`` does not load GTSAM.
"""
from importlib import import_module
from typing import Any

from .cross_sections import (CROSS_SECTION_TYPES, CircleSections, CrossSections, EllipseSections,
                             SplineSections, fit_cross_sections)
from .cylinder import (INSIDE_TOLERANCE, Containment, GeneralizedCylinder, fit_cylinder,
                       resample_demonstrations)
from .errors import (CylinderFileError, GeneralizationError, TLGCArgumentError,
                     CylinderDemonstrationsError, ObstacleAvoidanceError, StartOffPlaneError,
                     StartOutsideError, TLGCError, TooFewDemonstrationsError,
                     UnknownCrossSectionError)
from .frames import bishop_frames
from .generalization import (LTEResult, constraint_similarity, fit_similarity, fit_tps,
                             landmark_constraints, lte_deform, lte_generalize, lte_solve,
                             shape_distortion, tps_generalize)
from .obstacles import (adaptive_ratio_parameters, avoid_with_adaptive_ratio,
                        avoid_with_deformation, cylinder_clearance, cylinder_intersects,
                        path_clearance, section_clearance)
from .refinement import RefinementConstraint, RefinementSet, refine_incrementally
from .reproduction import (check_starts, random_starts, ratio_schedule, reproduce,
                           start_coordinates)

_LAZY = {"BoundaryFamily": "boundary_factor", "boundary_distance": "boundary_factor",
         "boundary_residuals": "boundary_factor"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'tlgc' has no attribute {name!r}")


__all__ = [
    "CROSS_SECTION_TYPES", "CircleSections", "Containment", "CrossSections", "CylinderFileError",
    "EllipseSections", "GeneralizationError", "GeneralizedCylinder", "INSIDE_TOLERANCE",
    "TLGCArgumentError", "CylinderDemonstrationsError", "SplineSections",
    "StartOffPlaneError", "StartOutsideError", "TLGCError", "TooFewDemonstrationsError",
    "UnknownCrossSectionError", "bishop_frames", "check_starts", "fit_cross_sections",
    "fit_cylinder", "random_starts", "ratio_schedule", "reproduce", "resample_demonstrations",
    "start_coordinates",
    "LTEResult", "constraint_similarity", "fit_similarity", "fit_tps", "landmark_constraints",
    "lte_deform", "lte_generalize", "lte_solve", "shape_distortion", "tps_generalize",
    "ObstacleAvoidanceError", "adaptive_ratio_parameters", "avoid_with_adaptive_ratio",
    "avoid_with_deformation", "cylinder_clearance", "cylinder_intersects", "path_clearance",
    "section_clearance",
    "RefinementConstraint", "RefinementSet", "refine_incrementally",
    *_LAZY,
]
