"""Bad-input catalogue of ``tlgc``: every public function of docs/interfaces.md fed bad
input answers with the project's error naming the argument (see tests/bad_input.py)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bad_input import Case, cases, check, raises_naming
from scenes import Box, make_demonstrations
from tlgc import (GeneralizedCylinder, fit_cylinder, random_starts, ratio_schedule, reproduce,
                  start_coordinates)
from tlgc.boundary_factor import BoundaryFamily, boundary_distance, boundary_residuals, section_indices
from tlgc.bounding_sphere import bounding_sphere, minimal_bounding_sphere
from tlgc.cylinder import check_cylinder
from tlgc.errors import (CylinderFileError, TLGCArgumentError, CylinderDemonstrationsError,
                         StartOffPlaneError, StartOutsideError, TLGCError,
                         TooFewDemonstrationsError, UnknownCrossSectionError)
from tlgc.generalization import (fit_similarity, fit_tps, landmark_constraints, lte_deform,
                                 lte_generalize, shape_distortion, tps_generalize)
from tlgc.obstacles import (adaptive_ratio_parameters, avoid_with_adaptive_ratio,
                            avoid_with_deformation, cylinder_clearance, cylinder_intersects)
from tlgc.refinement import RefinementConstraint, RefinementSet, refine_incrementally


def _demos():
    return make_demonstrations("needle_threading", num_demos=4, num_points=40, seed=2)


def _start(fx, offset=0.0, outside=1.0):
    """A point in the first section's plane at ``outside`` x the boundary radius along the
    normal, moved ``offset`` m along the tangent."""
    c = fx.cyl
    r = float(c.radius(np.array([0]), np.array([0.0]))[0])
    return c.directrix[0] + outside * r * c.normals[0] + offset * c.tangents[0]


def _write(fx, name: str, data: bytes):
    path = fx.tmp / name
    path.write_bytes(data)
    return path


IA, ID = TLGCArgumentError, CylinderDemonstrationsError
PATH = np.column_stack([np.linspace(0, 1, 20), np.zeros(20), np.zeros(20)])

CATALOGUE: list[Case] = [
    # --- fitting
    Case("fit-one-demo", lambda fx: fit_cylinder(_demos().positions[:1]), TooFewDemonstrationsError, "demos"),
    Case("fit-identical", lambda fx: fit_cylinder(np.repeat(_demos().positions[:1], 3, 0)), ID, "demos"),
    Case("fit-cross-section", lambda fx: fit_cylinder(_demos(), cross_section="square"),
         UnknownCrossSectionError, "square"),
    Case("fit-cross-section-type", lambda fx: fit_cylinder(_demos(), cross_section=3),
         UnknownCrossSectionError, "cross_section"),
    Case("fit-shape", lambda fx: fit_cylinder(np.zeros((3, 10, 2))), ID, "demos"),
    Case("fit-nan", lambda fx: fit_cylinder(np.where(np.arange(3) == 2, np.nan, _demos().positions)), ID,
         "demos"),
    Case("fit-one-point", lambda fx: fit_cylinder([np.zeros((1, 3)), np.zeros((5, 3))]), ID, "demos"),
    Case("fit-num-points", lambda fx: fit_cylinder(_demos(), num_points=1), ID, "num_points"),
    Case("fit-num-points-bool", lambda fx: fit_cylinder(_demos(), num_points=True), ID, "num_points"),
    Case("fit-text", lambda fx: fit_cylinder("demos.mat"), ID, "demos"),
    Case("fit-1e200", lambda fx: fit_cylinder(_demos().positions * 1e200), ID, "demos"),
    Case("fit-degenerate-mean", lambda fx: fit_cylinder(np.stack([np.zeros((10, 3)), np.zeros((10, 3)) + 1e-3])),
         ID, "demos"),
    # --- cylinder methods
    Case("radius-index", lambda fx: fx.cyl.radius(np.array([10_000]), np.array([0.0])), TLGCError, "index"),
    Case("radius-angle-nan", lambda fx: fx.cyl.radius(np.array([0]), np.array([np.nan])), TLGCError, "angle"),
    Case("radius-derivative-index", lambda fx: fx.cyl.radius_derivative(np.array([-50]), np.array([0.0])),
         TLGCError, "index"),
    Case("containment-shape", lambda fx: fx.cyl.containment(np.zeros((4, 2))), IA, "points"),
    Case("containment-nan", lambda fx: fx.cyl.containment([[np.nan, 0, 0]]), IA, "points"),
    Case("to-local-index", lambda fx: fx.cyl.to_local(np.zeros((2, 3)), np.array([0, 999])), TLGCError, "index"),
    Case("to-world-shape", lambda fx: fx.cyl.to_world(np.zeros((2, 3)), np.array([0, 1])), TLGCError, "local"),
    Case("ratio-points", lambda fx: fx.cyl.ratio("here", np.array([0])), IA, "points"),
    Case("boundary-points-angles", lambda fx: fx.cyl.boundary_points(num_angles=2), IA, "num_angles"),
    Case("surface-step", lambda fx: fx.cyl.surface(step=0), IA, "step"),
    Case("with-directrix-shape", lambda fx: fx.cyl.with_directrix(np.zeros((3, 3))), IA, "directrix"),
    Case("with-directrix-normal", lambda fx: fx.cyl.with_directrix(fx.cyl.directrix, initial_normal=[0, 0]),
         TLGCError, "initial_normal"),
    Case("with-cross-sections-type", lambda fx: fx.cyl.with_cross_sections("circle"), TLGCError,
         "cross_sections"),
    Case("load-missing", lambda fx: GeneralizedCylinder.load(fx.tmp / "none.npz"), CylinderFileError, "path"),
    Case("load-directory", lambda fx: GeneralizedCylinder.load(fx.tmp), CylinderFileError, "directory"),
    Case("load-garbage", lambda fx: GeneralizedCylinder.load(_write(fx, "g.npz", b"PK\x03\x04junk")),
         CylinderFileError, "path"),
    Case("load-arrays", lambda fx: GeneralizedCylinder.load(_savez(fx, "a.npz", directrix=np.zeros((3, 3)))),
         CylinderFileError, "path"),
    Case("save-path-type", lambda fx: fx.cyl.save(3), TLGCError, "path"),
    # --- reproduction
    Case("reproduce-off-plane", lambda fx: reproduce(fx.cyl, _start(fx, offset=0.2, outside=0.5)),
         StartOffPlaneError, "starts"),
    Case("reproduce-outside", lambda fx: reproduce(fx.cyl, _start(fx, outside=1.5)), StartOutsideError, "starts"),
    Case("reproduce-cyl-type", lambda fx: reproduce("cylinder", [0, 0, 0]), IA, "cyl"),
    Case("reproduce-starts-shape", lambda fx: reproduce(fx.cyl, [0.1, 0.2]), IA, "starts"),
    Case("reproduce-starts-nan", lambda fx: reproduce(fx.cyl, [0.1, np.nan, 0.2]), IA, "starts"),
    Case("reproduce-starts-bools", lambda fx: reproduce(fx.cyl, [True, False, True]), IA, "starts"),
    Case("reproduce-eta-final", lambda fx: reproduce(fx.cyl, _start(fx, outside=0.5), eta_final=2.0), IA,
         "eta_final"),
    Case("reproduce-gamma", lambda fx: reproduce(fx.cyl, _start(fx, outside=0.5), gamma=-1.0), IA, "gamma"),
    Case("reproduce-gamma-bool", lambda fx: reproduce(fx.cyl, _start(fx, outside=0.5), gamma=True), IA, "gamma"),
    Case("reproduce-plane-tolerance", lambda fx: reproduce(fx.cyl, _start(fx, outside=0.5),
                                                           plane_tolerance=-1.0), IA, "plane_tolerance"),
    Case("reproduce-allow-outside-text", lambda fx: reproduce(fx.cyl, _start(fx, outside=0.5),
                                                              allow_outside="no"), IA, "allow_outside"),
    Case("random-starts-count", lambda fx: random_starts(fx.cyl, -1, 0), IA, "count"),
    Case("random-starts-count-float", lambda fx: random_starts(fx.cyl, 2.5, 0), IA, "count"),
    Case("random-starts-rng", lambda fx: random_starts(fx.cyl, 5, "seed"), IA, "rng"),
    Case("random-starts-rng-negative", lambda fx: random_starts(fx.cyl, 5, -1), IA, "rng"),
    Case("random-starts-index", lambda fx: random_starts(fx.cyl, 5, 0, index=10_000), TLGCError, "index"),
    Case("random-starts-cyl", lambda fx: random_starts(None, 5, 0), IA, "cyl"),
    Case("start-coordinates-shape", lambda fx: start_coordinates(fx.cyl, np.zeros((2, 2))), IA, "starts"),
    Case("ratio-schedule-gamma", lambda fx: ratio_schedule(np.array([0.5]), fx.cyl.arc_length, 0.0, np.nan),
         IA, "gamma"),
    Case("ratio-schedule-eta0", lambda fx: ratio_schedule("x", fx.cyl.arc_length, None, 1.0), IA, "eta0"),
    # --- generalization
    Case("tps-landmarks-shape", lambda fx: tps_generalize(fx.cyl, np.zeros((3, 3)), np.zeros((2, 3))), TLGCError,
         "source_landmarks"),
    Case("tps-landmarks-nan", lambda fx: tps_generalize(fx.cyl, np.full((4, 3), np.nan), np.zeros((4, 3))),
         TLGCError, "source_landmarks"),
    Case("tps-smoothing", lambda fx: tps_generalize(fx.cyl, fx.cyl.directrix[[0, 10, 20, 39]],
                                                    fx.cyl.directrix[[0, 10, 20, 39]], smoothing=-1.0),
         TLGCError, "smoothing"),
    Case("tps-cyl", lambda fx: tps_generalize("cyl", np.zeros((4, 3)), np.zeros((4, 3))), TLGCError, "cyl"),
    Case("fit-tps-coplanar", lambda fx: fit_tps(np.zeros((4, 3)), np.zeros((4, 3))), TLGCError, "landmarks"),
    Case("fit-similarity-shape", lambda fx: fit_similarity(np.zeros((3, 3)), np.zeros((4, 3))), TLGCError,
         "target"),
    Case("landmark-constraints-shape", lambda fx: landmark_constraints(fx.cyl, np.zeros((2, 3)), np.zeros((3, 3))),
         TLGCError, "source_landmarks"),
    Case("lte-generalize-index", lambda fx: lte_generalize(fx.cyl, {10_000: [0, 0, 0]}), TLGCError, "constraints"),
    Case("lte-generalize-type", lambda fx: lte_generalize(fx.cyl, [[0, 0, 0]]), TLGCError, "constraints"),
    Case("lte-generalize-mode", lambda fx: lte_generalize(fx.cyl, {0: fx.cyl.directrix[0]}, mode="bend"),
         TLGCError, "mode"),
    Case("lte-deform-path", lambda fx: lte_deform(np.zeros((5, 2)), {0: [0, 0, 0]}), TLGCError, "path"),
    Case("lte-deform-target", lambda fx: lte_deform(PATH, {0: [0, np.inf, 0]}), TLGCError, "constraints"),
    Case("lte-deform-mode", lambda fx: lte_deform(PATH, {0: [0, 0, 0]}, mode=3), TLGCError,
         "mode"),
    Case("shape-distortion-shapes", lambda fx: shape_distortion(PATH, PATH[:5]), TLGCError, "deformed"),
    # --- obstacles
    Case("bounding-sphere-type", lambda fx: bounding_sphere("box"), TLGCError, "obstacle"),
    Case("bounding-sphere-radius", lambda fx: bounding_sphere(([0, 0, 0], -1.0)), TLGCError, "radius"),
    Case("minimal-bounding-sphere-empty", lambda fx: minimal_bounding_sphere(np.zeros((0, 3))), TLGCError,
         "points"),
    Case("clearance-obstacle-type", lambda fx: cylinder_clearance(fx.cyl, "box"), TLGCError, "obstacle"),
    Case("intersects-angles", lambda fx: cylinder_intersects(fx.cyl, Box([0, 0, 0], [0.1] * 3), num_angles=0),
         TLGCError, "num_angles"),
    Case("adaptive-start-shape", lambda fx: adaptive_ratio_parameters(fx.cyl, [0, 0], Box([0, 0, 0], [0.1] * 3)),
         TLGCError, "start"),
    Case("adaptive-critical", lambda fx: adaptive_ratio_parameters(fx.cyl, _start(fx, outside=0.5),
                                                                   Box([0, 0, 0], [0.1] * 3),
                                                                   critical_fraction=2.0), TLGCError,
         "critical_fraction"),
    Case("avoid-adaptive-safety", lambda fx: avoid_with_adaptive_ratio(fx.cyl, _start(fx, outside=0.5),
                                                                       Box([0, 0, 0], [0.1] * 3), safety=-1.0),
         TLGCError, "safety"),
    Case("avoid-deformation-obstacle", lambda fx: avoid_with_deformation(fx.cyl, None), TLGCError, "obstacle"),
    # --- refinement
    Case("refinement-shapes", lambda fx: RefinementConstraint.from_correction(PATH, PATH[:5]), TLGCError,
         "corrected"),
    Case("refinement-mode", lambda fx: RefinementConstraint.from_correction(PATH, PATH + 0.01, mode="bend"),
         TLGCError, "mode"),
    Case("refinement-tolerance", lambda fx: RefinementConstraint.from_correction(PATH, PATH + 0.01,
                                                                                 tolerance=-1.0),
         TLGCError, "tolerance"),
    Case("refinement-set-item", lambda fx: RefinementSet(["constraint"]), TLGCError, "constraint"),
    Case("refinement-set-remove", lambda fx: RefinementSet().remove(3), TLGCError, "position"),
    Case("refine-replace", lambda fx: refine_incrementally(_demos().positions, _demos().positions[0],
                                                           replace=99), TLGCError, "replace"),
    Case("refine-corrected-shape", lambda fx: refine_incrementally(_demos().positions, np.zeros((5, 2))),
         TLGCError, "corrected"),
    # --- boundary factor
    Case("section-indices-count", lambda fx: section_indices(None, 0, 10), TLGCError, "num_states"),
    Case("boundary-distance-positions", lambda fx: boundary_distance(fx.cyl, np.array([0]), np.zeros((1, 2))),
         TLGCError, "positions"),
    Case("boundary-residuals-margin", lambda fx: boundary_residuals(fx.cyl, np.array([0]), np.zeros((1, 3)),
                                                                    margin=np.nan), TLGCError, "margin"),
    Case("boundary-family-sigma", lambda fx: BoundaryFamily(fx.cyl, 10, sigma=0.0), TLGCError, "sigma"),
    Case("boundary-family-cylinder", lambda fx: BoundaryFamily("cyl", 10), TLGCError, "cylinder"),
    Case("boundary-distance-sections-range", lambda fx: boundary_distance(fx.cyl, [0, 999], np.zeros((2, 3))),
         IA, "sections"),
    Case("boundary-distance-sections-text", lambda fx: boundary_distance(fx.cyl, "ab", np.zeros((2, 3))),
         IA, "sections"),
    Case("boundary-distance-sections-float", lambda fx: boundary_distance(fx.cyl, [0.5], np.zeros((1, 3))),
         IA, "sections"),
    Case("boundary-residuals-sections", lambda fx: boundary_residuals(fx.cyl, [-1], np.zeros((1, 3))), IA,
         "sections"),
    Case("check-cylinder-type", lambda fx: check_cylinder("cyl"), IA, "cyl"),
]


def _savez(fx, name: str, **arrays):
    path = fx.tmp / name
    np.savez(path, **arrays)
    return path


@pytest.fixture(scope="module")
def fx(tmp_path_factory):
    return SimpleNamespace(cyl=fit_cylinder(_demos(), cross_section="spline"),
                           tmp=tmp_path_factory.mktemp("bad_tlgc"))


@pytest.mark.parametrize("case", cases(CATALOGUE))
def test_bad_input(case: Case, fx) -> None:
    check(case, fx)


def test_start_on_plane_within_tolerance_is_reproduced(fx) -> None:
    """A start 0.5 mm off the plane (inside the stated 1 mm tolerance) is accepted; at 20 cm
    it is refused, with the distance in the message."""
    path = reproduce(fx.cyl, _start(fx, offset=5e-4, outside=0.5))
    assert path.shape == (fx.cyl.num_sections, 3)
    with raises_naming(StartOffPlaneError, "starts[0]", "0.2 m"):
        reproduce(fx.cyl, _start(fx, offset=0.2, outside=0.5))
