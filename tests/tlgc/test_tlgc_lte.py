"""Laplacian trajectory editing that converges and stays bounded (issue 11).

Synthetic, seeded planar letter-like shapes and loops whose ends almost meet: the chord between
the constraints says little about the path's scale and turn there, which sent the old
fixed-point iteration to scales of 5 and metre-sized moves.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from bad_input import raises_naming
from tlgc import GeneralizationError, TLGCArgumentError, fit_cylinder
from tlgc.generalization import (DEFAULT_MAX_AMPLIFICATION, LTE_MODES, constraint_similarity,
                                 lte_deform, lte_generalize, lte_solve)

LETTERS = {
    "S": [[0.3, 0.3], [0.1, 0.35], [0.0, 0.25], [0.15, 0.15], [0.3, 0.08], [0.25, -0.02], [0.0, 0.0]],
    "W": [[0, 0.3], [0.07, 0], [0.15, 0.2], [0.23, 0], [0.3, 0.3]],
    "M": [[0, 0], [0.02, 0.3], [0.15, 0.1], [0.28, 0.3], [0.3, 0]],
    "e": [[0, 0.1], [0.2, 0.1], [0.18, 0.2], [0.1, 0.24], [0.0, 0.15], [0.03, 0.03], [0.15, 0.0],
          [0.22, 0.04]],
    "G": [[0.25, 0.25], [0.12, 0.3], [0.0, 0.15], [0.1, 0.0], [0.25, 0.05], [0.25, 0.12], [0.15, 0.12]],
}


def letter(name: str, num: int = 400) -> np.ndarray:
    """A planar letter-like path (num, 3) [m]: cubic spline through control points."""
    ctrl = np.asarray(LETTERS[name], dtype=float)
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(ctrl, axis=0), axis=1))]
    xy = CubicSpline(s, ctrl, axis=0)(np.linspace(0.0, s[-1], num))
    return np.c_[xy, np.zeros(num)]


def loop(gap: float = 0.04, radius: float = 0.15, num: int = 400) -> np.ndarray:
    """A planar circular loop (num, 3) [m] whose ends are ``gap`` apart."""
    half = np.arcsin(gap / (2 * radius))
    a = np.linspace(-np.pi / 2 + half, 1.5 * np.pi - half, num)
    return np.stack([radius * np.cos(a), radius * np.sin(a) + radius, np.zeros(num)], axis=1)


SHAPES = {**{f"letter {k}": letter(k) for k in LETTERS}, "loop 4 cm": loop(0.04),
          "loop 1 cm": loop(0.01)}


def end_moves(rng: np.random.Generator, count: int) -> np.ndarray:
    """Seeded end displacements (count, 3) of 5-20 cm, mostly in the shape's plane."""
    d = rng.normal(size=(count, 3)) * [1.0, 1.0, 0.3]
    return d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(0.05, 0.20, (count, 1))


def check_bounded(path: np.ndarray, constraints: dict, mode: str, bound: float) -> float:
    """lte_solve either refuses with GeneralizationError or meets the constraints exactly and
    moves no point more than ``bound`` x the largest constraint move; lte_deform gives the same
    path. Returns the amplification, NaN when refused."""
    try:
        result = lte_solve(path, constraints, mode, bound)
    except GeneralizationError as exc:
        assert "max_amplification" in str(exc)
        return float("nan")
    move = max(np.linalg.norm(v - path[k]) for k, v in constraints.items())
    largest = np.linalg.norm(result.path - path, axis=1).max()
    assert largest <= bound * move * (1 + 1e-9), (mode, largest, move)
    assert result.amplification == pytest.approx(largest / move)
    for k, v in constraints.items():
        np.testing.assert_allclose(result.path[k], v, atol=1e-12)
    a = lte_deform(path, constraints, mode=mode, max_amplification=bound)[0]
    np.testing.assert_allclose(a, result.path, atol=1e-12)
    return result.amplification


@pytest.mark.parametrize("name", sorted(SHAPES))
@pytest.mark.parametrize("mode", LTE_MODES)
def test_letters_and_loops_converge_and_stay_bounded(name, mode):
    path = SHAPES[name]
    rng = np.random.default_rng(sorted(SHAPES).index(name))
    figures = [check_bounded(path, {0: path[0], len(path) - 1: path[-1] + d}, mode,
                             DEFAULT_MAX_AMPLIFICATION) for d in end_moves(rng, 12)]
    # also with a third constraint in the middle and a tighter bound
    mid = len(path) // 2
    figures += [check_bounded(path, {0: path[0], mid: path[mid] + 0.3 * d,
                                     len(path) - 1: path[-1] + d}, mode, 1.5)
                for d in end_moves(rng, 4)]
    figures = np.array(figures)
    print(f"{name} {mode}: 16 moves, largest displacement / largest constraint move "
          f"{np.nanmax(figures):.3f}, refused {int(np.isnan(figures).sum())}")


def test_issue_examples_no_runaway_scale_and_no_collapse():
    path = loop(0.04)
    n = len(path) - 1
    # End moved 20 cm: the chord grows five-fold; the old iteration scaled the loop by 5.1.
    for d in ([0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, -0.2, 0.0]):
        result = lte_solve(path, {0: path[0], n: path[-1] + d})
        assert result.estimated.scale > 3.9                        # what the chord alone says
        assert result.strength < 1.0                               # ... tempered to the bound
        assert np.linalg.norm(result.path - path, axis=1).max() <= 2.0 * 0.2 + 1e-9
    # End moved 5 cm sideways: the chord shrinks; the loop must not shrink to a quarter.
    result = lte_solve(path, {0: path[0], n: path[-1] + [0.05, 0, 0]})
    assert result.transform.scale > 0.75
    assert np.linalg.norm(result.path - path, axis=1).max() <= 2.0 * 0.05 + 1e-9
    # The local edit never scales or turns.
    local = lte_solve(path, {0: path[0], n: path[-1] + [0.05, 0, 0]}, mode="laplacian")
    assert local.transform.scale == 1.0 and local.amplification <= 1.0 + 1e-9


def test_similarity_from_constraints_is_closed_form():
    rng = np.random.default_rng(3)
    src = rng.normal(size=(5, 3))
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    rot = q * np.sign(np.diag(r))
    rot = rot if np.linalg.det(rot) > 0 else -rot
    fit = constraint_similarity(src, 0.7 * src @ rot.T + 1.0)
    assert fit.scale == pytest.approx(0.7) and np.allclose(fit.rotation, rot)
    # Two points: chord ratio and the minimal rotation (no turn about the chord).
    two = constraint_similarity(np.array([[0, 0, 0], [1.0, 0, 0]]), np.array([[0, 0, 0], [0, 2.0, 0]]))
    assert two.scale == pytest.approx(2.0)
    np.testing.assert_allclose(two.rotation @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(two.rotation @ [0, 0, 1], [0, 0, 1], atol=1e-12)
    assert constraint_similarity(src[:2], src[:2] * 3, mode="rigid").scale == 1.0
    lap = constraint_similarity(src, src @ rot.T, mode="laplacian")
    np.testing.assert_array_equal(lap.rotation, np.eye(3))
    with raises_naming(TLGCArgumentError, "mode"):
        constraint_similarity(src, src, mode="affine")
    with raises_naming(GeneralizationError, "constraints"):
        constraint_similarity(src[:2], np.zeros((2, 3)))


def test_bound_is_enforced_or_refused_with_a_reason():
    path = letter("W")
    n = len(path) - 1
    cons = {0: path[0], n // 3: path[n // 3] + [0, 0.15, 0], 2 * n // 3: path[2 * n // 3] - [0, 0.15, 0],
            n: path[-1]}
    local = lte_solve(path, cons, mode="laplacian", max_amplification=10.0)
    assert local.amplification > 1.0
    with raises_naming(GeneralizationError, "constraints", "max_amplification=1"):
        lte_solve(path, cons, mode="laplacian", max_amplification=1.0)
    with raises_naming(TLGCArgumentError, "max_amplification"):
        lte_solve(path, cons, max_amplification=0.5)


@pytest.mark.parametrize("mode", [None, *LTE_MODES])
def test_cylinders_on_letters_and_loops_generalize_bounded(mode):
    rng = np.random.default_rng(9)
    for name in ("letter S", "letter G", "loop 4 cm"):
        path = SHAPES[name]
        offsets = 0.01 * rng.normal(size=(4, 1, 3))
        cyl = fit_cylinder(path[None] + offsets - offsets.mean(axis=0), "circle")
        for d in end_moves(rng, 4):
            target = cyl.directrix[-1] + d
            try:
                new = lte_generalize(cyl, {len(path) - 1: target}, mode=mode)
            except GeneralizationError:
                continue
            moved = np.linalg.norm(new.directrix - cyl.directrix, axis=1).max()
            assert moved <= DEFAULT_MAX_AMPLIFICATION * np.linalg.norm(d) * (1 + 1e-9)
            np.testing.assert_allclose(new.directrix[-1], target, atol=1e-9)
            np.testing.assert_array_equal(new.directrix[:3], cyl.directrix[:3])
