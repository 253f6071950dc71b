"""Skill refinement (paper section 6): incremental and constraint-based."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from scenes import make_demonstrations
from tlgc.cylinder import fit_cylinder
from tlgc.errors import TLGCArgumentError
from tlgc.refinement import RefinementConstraint, RefinementSet, refine_incrementally
from tlgc.reproduction import random_starts, reproduce


@pytest.fixture(scope="module")
def skill():
    demos = make_demonstrations("curved_reach", num_demos=4, num_points=200, seed=2)
    return demos.positions, fit_cylinder(demos, "spline")


def _lowered(path: np.ndarray, level: float, window: slice) -> np.ndarray:
    """The teacher pushes the end effector down to ``level`` within ``window`` (paper fig. 15)."""
    out = path.copy()
    out[window, 2] = np.minimum(out[window, 2], level)
    return out


def test_constraint_corrects_crossing_reproductions_only(skill):
    _, cyl = skill
    window = slice(60, 140)
    starts = random_starts(cyl, 40, rng=1)
    before = reproduce(cyl, starts)
    level = float(np.median(before[:, window, 2]))
    teacher = before[np.argmax(before[:, 100, 2])]               # the highest one is corrected
    constraint = RefinementConstraint.from_correction(teacher, _lowered(teacher, level, window))
    assert constraint.matrix.shape == (3, cyl.num_sections)
    np.testing.assert_allclose(constraint.matrix[:2], 0.0)        # pushed straight down
    crossing = np.any(before[:, window, 2] > level, axis=1) & np.any(
        constraint.active[window] & (before[:, window, 2] > level), axis=1)
    np.testing.assert_array_equal(constraint.crosses(before), crossing)
    assert 0 < crossing.sum() < len(before)

    after = constraint.apply(before)
    assert np.array_equal(after[~crossing], before[~crossing])                 # untouched
    active = constraint.active
    assert np.all(after[crossing][:, active, 2] <= level + 1e-12)               # corrected
    changed = np.any(after != before, axis=2)
    assert not changed[:, ~active].any()                                         # only where it acts
    np.testing.assert_allclose(after[..., :2], before[..., :2])                  # along V only
    # the corrected reproduction of the teacher's start is the teacher's correction
    np.testing.assert_allclose(constraint.apply(teacher), _lowered(teacher, level, window), atol=1e-12)


def test_translate_mode_adds_the_refinement_vectors(skill):
    _, cyl = skill
    before = reproduce(cyl, random_starts(cyl, 10, rng=2))
    teacher = before[0]
    corrected = teacher + np.r_[np.zeros(80), np.full(40, -0.02), np.zeros(80)][:, None] * [0, 0, 1]
    c = RefinementConstraint.from_correction(teacher, corrected, mode="translate")
    after = c.apply(before)
    hit = c.violation(before) > 0
    np.testing.assert_allclose((after - before)[hit], c.vectors[np.nonzero(hit)[1]])
    assert np.array_equal(after[~hit], before[~hit])


def test_constraints_combine_and_remove_without_refitting(skill):
    _, cyl = skill
    before = reproduce(cyl, random_starts(cyl, 30, rng=3))
    teacher = before[0]
    low = float(np.percentile(before[:, 50:150, 2], 60))
    down = RefinementConstraint.from_correction(teacher, _lowered(teacher, low, slice(50, 150)))
    side = teacher.copy()
    side[20:90, 1] -= 0.01
    sideways = RefinementConstraint.from_correction(teacher, side)
    refinements = RefinementSet([down])
    only_down = refinements.apply(before)
    np.testing.assert_array_equal(only_down, down.apply(before))
    position = refinements.add(sideways)
    both = refinements.apply(before)
    np.testing.assert_array_equal(both, sideways.apply(down.apply(before)))
    np.testing.assert_array_equal(refinements.crosses(before),
                                  down.crosses(before) | sideways.crosses(before))
    assert refinements.remove(position) is sideways
    np.testing.assert_array_equal(refinements.apply(before), only_down)
    refinements.remove(0)
    np.testing.assert_array_equal(refinements.apply(before), before)


def test_refinement_errors(skill):
    _, cyl = skill
    path = cyl.directrix
    with raises_naming(TLGCArgumentError, "corrected"):
        RefinementConstraint.from_correction(path, path)
    with raises_naming(TLGCArgumentError, "mode"):
        RefinementConstraint.from_correction(path, path + 0.1, mode="bend")
    c = RefinementConstraint.from_correction(path, path + [0, 0, 0.1])
    with raises_naming(TLGCArgumentError, "reproductions"):
        c.apply(np.zeros((3, 10, 3)))
    s = RefinementSet([c])
    with raises_naming(TLGCArgumentError, "constraint"):
        s.add(RefinementConstraint.from_correction(path[:50], path[:50] + 0.1))
    with raises_naming(TLGCArgumentError, "position"):
        s.remove(3)


def test_incremental_refinement_replaces_or_adds_a_demonstration(skill):
    demos, cyl = skill
    corrected = demos[0].copy()
    t = np.linspace(0, 1, len(corrected))
    corrected[:, 2] -= 0.05 * np.sin(np.pi * t) ** 2                  # dip in the middle
    corrected = corrected[::2]                                         # other length: resampled
    replaced, refit = refine_incrementally(demos, corrected, replace=0)
    assert replaced.shape == demos.shape
    np.testing.assert_allclose(replaced[1:], demos[1:])
    np.testing.assert_allclose(replaced[0, [0, -1]], demos[0, [0, -1]], atol=1e-4)
    assert refit.cross_section == cyl.cross_section
    # the directrix is the mean: it moves down by a quarter of the dip in the middle
    assert refit.directrix[100, 2] - cyl.directrix[100, 2] == pytest.approx(-0.05 / 4, rel=0.02)
    added, refit2 = refine_incrementally(demos, corrected)
    assert added.shape == (len(demos) + 1,) + demos.shape[1:]
    np.testing.assert_allclose(refit2.directrix, added.mean(axis=0))
    with raises_naming(TLGCArgumentError, "replace"):
        refine_incrementally(demos, corrected, replace=9)
