"""Generalization keeps the start (issue 11): moving only the end leaves the first cross-section
(centre, plane, boundary) in place, so every start inside it still reproduces inside."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from scenes import load_demonstrations, make_demonstrations
from tlgc import (CROSS_SECTION_TYPES, GeneralizationError, fit_cylinder, random_starts,
                  reproduce)
from tlgc.generalization import (fade_weights, landmark_constraints, lte_generalize,
                                 tps_generalize)

KINDS = sorted(CROSS_SECTION_TYPES)
DIRECTIONS = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
DISTANCES = (0.05, 0.20)
MAX_MOVE = 1e-3          # [m] largest allowed change of the first section
MAX_TILT = 0.1           # [deg] largest allowed turn of its plane (or of its normal)


def first_section_change(old, new) -> tuple[float, float]:
    """Largest displacement [m] of the first section's centre and boundary (64 angles) and the
    angle [deg] its tangent (plane) or normal turned."""
    ring = np.linalg.norm(new.boundary_points(64, [0]) - old.boundary_points(64, [0]), axis=-1)
    move = max(float(ring.max()), float(np.linalg.norm(new.directrix[0] - old.directrix[0])))
    tilt = max(np.degrees(np.arccos(np.clip(new.tangents[0] @ old.tangents[0], -1.0, 1.0))),
               np.degrees(np.arccos(np.clip(new.normals[0] @ old.normals[0], -1.0, 1.0))))
    return move, float(tilt)


def generalized(cyl, method: str, source: np.ndarray, target: np.ndarray):
    if method == "tps":
        return tps_generalize(cyl, source, target)
    mode = None if method == "lte" else method.split("-")[1]
    return lte_generalize(cyl, landmark_constraints(cyl, source, target), mode=mode)


def check_end_moves(cyl, methods, starts: np.ndarray) -> dict:
    """Every end move of DISTANCES x DIRECTIONS with each method: first section unchanged,
    starts reproduce inside, the end reaches its target. Returns the worst figures."""
    source = cyl.directrix[[0, -1]]
    worst = {m: [0.0, 0.0, 1.0] for m in methods}
    for distance in DISTANCES:
        for direction in DIRECTIONS:
            target = source + np.stack([np.zeros(3), distance * direction])
            for method in methods:
                new = generalized(cyl, method, source, target)
                move, tilt = first_section_change(cyl, new)
                assert move <= MAX_MOVE and tilt <= MAX_TILT, (method, distance, direction)
                assert np.linalg.norm(new.directrix[-1] - target[1]) < 1e-3
                reps = reproduce(new, starts)            # raises if a start left the section
                own = new.ratio(reps, np.arange(new.num_sections)[None, :])
                assert own.max() <= 1.0 + 1e-9
                inside = new.contains(reps[:, ::25].reshape(-1, 3))
                assert inside.all(), (method, distance, direction)
                w = worst[method]
                w[0], w[1], w[2] = max(w[0], move), max(w[1], tilt), min(w[2], inside.mean())
    return worst


@pytest.mark.parametrize("dataset", ["needle_threading", "pick_place"])
@pytest.mark.parametrize("kind", KINDS)
def test_end_moves_keep_the_first_section_on_real_data(shared_dataset, dataset, kind):
    cyl = fit_cylinder(load_demonstrations(shared_dataset(dataset)), kind)
    starts = random_starts(cyl, 200, rng=np.random.default_rng(21))
    assert cyl.contains(starts).all()
    worst = check_end_moves(cyl, ("tps", "lte", "lte-similarity", "lte-rigid"), starts)
    for method, (move, tilt, inside) in worst.items():
        print(f"{dataset} {kind} {method}: first section moved {move * 1e3:.2e} mm, "
              f"tilted {tilt:.2e} deg; 200 starts, inside {100 * inside:.1f} %")


@pytest.mark.parametrize("kind", KINDS)
def test_end_moves_keep_the_first_section_on_synthetic_data(kind):
    demos = make_demonstrations("pick_place", num_demos=5, num_points=120, seed=4)
    cyl = fit_cylinder(demos, kind)
    check_end_moves(cyl, ("tps", "lte", "lte-similarity", "lte-rigid"),
                    random_starts(cyl, 200, rng=np.random.default_rng(22)))


def test_deformation_fades_in_smoothly_from_the_start():
    demos = make_demonstrations("pick_place", num_demos=5, num_points=300, seed=3)
    cyl = fit_cylinder(demos, "spline")
    source = cyl.directrix[[0, -1]]
    target = source + [[0, 0, 0], [0.1, -0.05, 0.2]]
    for new in (tps_generalize(cyl, source, target),
                lte_generalize(cyl, landmark_constraints(cyl, source, target)),
                lte_generalize(cyl, landmark_constraints(cyl, source, target), mode="similarity")):
        shift = np.linalg.norm(new.directrix - cyl.directrix, axis=1)
        np.testing.assert_array_equal(shift[:3], 0.0)
        steps = np.diff(shift)
        # No jump: the displacement grows by at most a few times its average step.
        assert np.abs(steps).max() <= 5.0 * shift[-1] / len(shift)
        # Turning of consecutive tangents stays of the order of the original path's.
        turn = np.arccos(np.clip(np.einsum("ni,ni->n", new.tangents[1:], new.tangents[:-1]), -1, 1))
        base = np.arccos(np.clip(np.einsum("ni,ni->n", cyl.tangents[1:], cyl.tangents[:-1]), -1, 1))
        assert turn.max() <= base.max() + 0.02


def test_fade_weights_are_zero_on_the_first_sections_and_one_after_the_fade():
    u = np.linspace(0.0, 1.0, 101)
    w = fade_weights(u, 0.1)
    np.testing.assert_array_equal(w[:3], 0.0)
    np.testing.assert_array_equal(w[u >= u[2] + 0.1], 1.0)
    assert np.all(np.diff(w) >= 0.0)


def test_keep_start_refuses_a_moved_start_and_false_lets_it_move():
    demos = make_demonstrations("pick_place", num_demos=4, num_points=150, seed=1)
    cyl = fit_cylinder(demos, "circle")
    source = cyl.directrix[[0, -1]]
    target = source + 0.05
    with raises_naming(GeneralizationError, "target_landmarks[0]", "keep_start"):
        tps_generalize(cyl, source, target)
    with raises_naming(GeneralizationError, "constraints[0]", "keep_start"):
        lte_generalize(cyl, {0: target[0], -1: target[1]})
    moved = tps_generalize(cyl, source, target, keep_start=False)
    np.testing.assert_allclose(moved.directrix[0], target[0], atol=1e-9)
    moved = lte_generalize(cyl, {0: target[0], 149: target[1]}, keep_start=False)
    np.testing.assert_allclose(moved.directrix, cyl.directrix + 0.05, atol=1e-9)
