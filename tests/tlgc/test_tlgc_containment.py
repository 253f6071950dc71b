"""Containment of arbitrary points (issue 11): exact for the cylinder's own points, inclusive,
end caps closed, and the same inside/outside answer as an independent brute-force check."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from scenes import load_demonstrations, make_demonstrations
from tlgc import CROSS_SECTION_TYPES, INSIDE_TOLERANCE, fit_cylinder, random_starts, reproduce

KINDS = sorted(CROSS_SECTION_TYPES)
DATASETS = ["needle_threading", "pick_place", "box_closing", "synthetic0"]


def brute_force_inside(cyl, points: np.ndarray) -> np.ndarray:
    """Inside (P,) by the definition, one point and one frame interval at a time.

    Between frames k and k+1 the section s = k + lam has the plane with normal
    (1 - lam) t_k + lam t_{k+1} through which the plane function
    g(lam) = (1 - lam) t_k . (p - c_k) + lam t_{k+1} . (p - c_{k+1}) vanishes; its in-plane
    coordinates and boundary radius are blended with the same weights. Every interval whose
    g changes sign (or is 0 at an end) is solved numerically (Brent's method, not the closed
    form), the blended coordinates are formed in world terms and the point is inside iff some
    such section holds it within the boundary (ratio <= 1 + 1e-9); a point within 1e-12 m of
    a frame's plane is on it (the end caps are closed). No nearest-point window,
    no preference order: every interval of every frame is tried. A point no section plane
    passes through (beyond an end cap) is outside.
    """
    c, t, nrm, bin_ = cyl.directrix, cyl.tangents, cyl.normals, cyl.binormals
    result = np.zeros(len(points), dtype=bool)
    for i, p in enumerate(points):
        f = np.sum((p - c) * t, axis=1)                          # plane offsets of every frame
        f[np.abs(f) <= 1e-12] = 0.0                              # on a frame's plane (round-off)
        for k in np.flatnonzero(f[:-1] * f[1:] <= 0.0):
            def g(lam, k=k):
                return (1.0 - lam) * f[k] + lam * f[k + 1]
            lam = 0.0 if f[k] == 0.0 else 1.0 if f[k + 1] == 0.0 else brentq(
                g, 0.0, 1.0, xtol=1e-15, rtol=4 * np.finfo(float).eps)
            a = (1.0 - lam) * (p - c[k]) @ nrm[k] + lam * (p - c[k + 1]) @ nrm[k + 1]
            b = (1.0 - lam) * (p - c[k]) @ bin_[k] + lam * (p - c[k + 1]) @ bin_[k + 1]
            angle = np.arctan2(b, a) % (2.0 * np.pi)
            radius = (1.0 - lam) * cyl.radius(k, angle) + lam * cyl.radius(k + 1, angle)
            if np.hypot(a, b) <= (1.0 + 1e-9) * radius:
                result[i] = True
                break
    return result


def sample_points(cyl, count: int, rng: np.random.Generator) -> np.ndarray:
    """Seeded points (count, 3) around the cylinder: most near its surface (ratio 0-1.6, a few
    sections off their plane), some beyond the end caps and some anywhere in its bounding box."""
    near = count * 7 // 10
    k = rng.integers(0, cyl.num_sections, near)
    angle = rng.uniform(0.0, 2.0 * np.pi, near)
    radius = rng.uniform(0.0, 1.6, near) * cyl.radius(k, angle)
    pts = cyl.to_world(np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=-1), k)
    step = float(np.linalg.norm(np.diff(cyl.directrix, axis=0), axis=1).mean())
    pts += rng.normal(scale=3.0 * step, size=(near, 1)) * cyl.tangents[k]
    caps = count * 15 // 100
    end = rng.integers(0, 2, caps) * (cyl.num_sections - 1)
    sign = np.where(end == 0, -1.0, 1.0)
    ring = cyl.to_world(rng.uniform(-1.0, 1.0, (caps, 2)) * cyl.radius(end, 0.0)[:, None], end)
    pts_caps = ring + (sign * rng.uniform(0.0, 0.2, caps))[:, None] * cyl.tangents[end]
    box = rng.uniform(cyl.directrix.min(axis=0) - 0.1, cyl.directrix.max(axis=0) + 0.1,
                      (count - near - caps, 3))
    return np.concatenate([pts, pts_caps, box])


def _demonstrations(name, shared_dataset):
    return load_demonstrations(shared_dataset(name)).positions


@pytest.mark.parametrize("dataset", DATASETS)
@pytest.mark.parametrize("kind", KINDS)
def test_every_effective_point_is_inside_its_cylinder(shared_dataset, dataset, kind):
    cyl = fit_cylinder(_demonstrations(dataset, shared_dataset), kind)
    points = cyl.to_world(cyl.effective_points, np.arange(cyl.num_sections)[None, :])
    c = cyl.containment(points.reshape(-1, 3))
    print(f"{dataset} {kind}: {c.inside.size} effective points, largest ratio "
          f"{c.ratio.max():.15f}")
    assert c.inside.all()
    assert c.ratio.max() <= 1.0 + INSIDE_TOLERANCE
    np.testing.assert_array_equal(c.offset, 0.0)
    # independently: each effective point against its own section's boundary radius ...
    e = cyl.effective_points
    own = np.hypot(e[..., 0], e[..., 1]) / cyl.radius(
        np.arange(cyl.num_sections)[None, :], np.arctan2(e[..., 1], e[..., 0]) % (2 * np.pi))
    assert own.max() <= 1.0 + 1e-9
    # ... and every 7th of them through the brute-force containment
    assert brute_force_inside(cyl, points.reshape(-1, 3)[::7]).all()


@pytest.mark.parametrize("dataset", DATASETS)
def test_random_points_agree_with_brute_force(shared_dataset, dataset):
    demos = _demonstrations(dataset, shared_dataset)
    for kind in KINDS:
        cyl = fit_cylinder(demos, kind)
        points = sample_points(cyl, 1000, np.random.default_rng(11))
        fast = cyl.containment(points)
        slow = brute_force_inside(cyl, points)
        print(f"{dataset} {kind}: 1000 points, {slow.sum()} inside, "
              f"{np.sum(fast.inside != slow)} disagreements")
        np.testing.assert_array_equal(fast.inside, slow)
        assert 0.2 < slow.mean() < 0.9                    # both answers well represented
        np.testing.assert_array_equal(cyl.contains(points), slow)


@pytest.mark.parametrize("kind", KINDS)
def test_synthetic_points_agree_with_brute_force(kind):
    demos = make_demonstrations("curved_reach", num_demos=5, num_points=300, seed=0).positions
    cyl = fit_cylinder(demos, kind)
    points = sample_points(cyl, 1000, np.random.default_rng(5))
    np.testing.assert_array_equal(cyl.containment(points).inside, brute_force_inside(cyl, points))


def test_boundary_test_is_inclusive_and_tolerance_is_stated():
    demos = make_demonstrations("curved_reach", num_demos=5, num_points=200, seed=0).positions
    cyl = fit_cylinder(demos, "spline")
    k = np.arange(5, 195, 10)
    angle = np.linspace(0.0, 2 * np.pi, len(k), endpoint=False)
    for ratio, inside in ((1.0, True), (1.0 + 0.5 * INSIDE_TOLERANCE, True),
                          (1.0 + 100 * INSIDE_TOLERANCE, False)):
        r = ratio * cyl.radius(k, angle)
        pts = cyl.to_world(np.stack([r * np.cos(angle), r * np.sin(angle)], axis=-1), k)
        assert np.all(cyl.containment(pts).inside == inside), ratio


def test_points_between_frames_use_the_interpolated_section():
    # Straight cylinder whose radius grows linearly: between frames the boundary is the
    # interpolated one, so a point at the interpolated radius is on the boundary (inside).
    x = np.linspace(0.0, 1.0, 11)
    radius = 0.05 + 0.05 * x
    demos = np.stack([np.stack([x, s * radius, t * radius], axis=1)
                      for s, t in ((1, 0), (-1, 0), (0, 1), (0, -1))])
    cyl = fit_cylinder(demos, "circle")
    xq = np.array([0.05, 0.333, 0.75])
    rq = 0.05 + 0.05 * xq
    on = np.stack([xq, rq, 0 * xq], axis=1)
    c = cyl.containment(on)
    np.testing.assert_allclose(c.section, xq * 10, atol=1e-12)
    np.testing.assert_allclose(c.ratio, 1.0, atol=1e-12)
    assert c.inside.all()
    assert not cyl.containment(on * [1, 1.001, 1]).inside.any()


def test_points_beyond_the_end_caps_are_outside_with_their_distance(shared_dataset):
    for demos in (make_demonstrations("curved_reach", num_demos=5, num_points=300, seed=0).positions,
                  _demonstrations("needle_threading", shared_dataset)):
        cyl = fit_cylinder(demos, "circle")
        before = cyl.directrix[0] - 0.2 * cyl.tangents[0]
        after = cyl.directrix[-1] + 0.2 * cyl.tangents[-1]
        c = cyl.containment(np.stack([before, after]))
        assert not c.inside.any()
        np.testing.assert_array_equal(c.index, [0, cyl.num_sections - 1])
        np.testing.assert_allclose(c.offset, [-0.2, 0.2], atol=1e-12)
        np.testing.assert_allclose(c.beyond, [0.2, 0.2], atol=1e-12)
        # On the cap plane itself, within the boundary: inside (caps are closed, inclusive).
        ends = np.stack([cyl.directrix[0], cyl.directrix[-1]])
        assert cyl.containment(ends).inside.all()


def test_reproductions_and_random_starts_are_inside():
    demos = make_demonstrations("needle_threading", num_demos=4, num_points=400, seed=2).positions
    for kind in KINDS:
        cyl = fit_cylinder(demos, kind)
        starts = random_starts(cyl, 50, rng=3)
        assert cyl.contains(starts).all()
        for eta_final in (None, 0.0, 1.0):
            reps = reproduce(cyl, starts, eta_final=eta_final)
            assert cyl.contains(reps.reshape(-1, 3)).all(), (kind, eta_final)


def test_empty_and_single_point_queries():
    demos = make_demonstrations("curved_reach", num_demos=3, num_points=50, seed=0).positions
    cyl = fit_cylinder(demos, "ellipse")
    c = cyl.containment(np.zeros((0, 3)))
    assert c.inside.shape == (0,) and c.index.shape == (0,)
    assert cyl.containment(cyl.directrix[25:26]).inside.all()
