"""TLGC: trajectory learning with generalized cylinders (fit, reproduce, generalize)."""
from .cross_sections import (CROSS_SECTION_TYPES, CircleSections, CrossSections, EllipseSections,
                             SplineSections, fit_cross_sections)
from .cylinder import Containment, GeneralizedCylinder, fit_cylinder, resample_demonstrations
from .errors import (CylinderFileError, InvalidArgumentError, InvalidDemonstrationsError,
                     StartOutsideError, TLGCError, TooFewDemonstrationsError,
                     UnknownCrossSectionError)
from .frames import bishop_frames
from .reproduction import random_starts, ratio_schedule, reproduce, start_coordinates

__all__ = [
    "CROSS_SECTION_TYPES", "CircleSections", "Containment", "CrossSections", "CylinderFileError",
    "EllipseSections", "GeneralizedCylinder", "InvalidArgumentError", "InvalidDemonstrationsError",
    "SplineSections", "StartOutsideError", "TLGCError", "TooFewDemonstrationsError",
    "UnknownCrossSectionError", "bishop_frames", "fit_cross_sections", "fit_cylinder",
    "random_starts", "ratio_schedule", "reproduce", "resample_demonstrations",
    "start_coordinates",
]
