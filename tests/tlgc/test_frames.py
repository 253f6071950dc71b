"""Bishop frames: orthonormal, tangent along the curve, no twist (vs the analytic helix RMF)."""
from __future__ import annotations

import numpy as np

from bad_input import raises_naming
from tlgc.errors import TLGCArgumentError
from tlgc.frames import bishop_frames, unit_tangents


def helix(num: int = 2000, radius: float = 1.0, pitch: float = 0.3, turns: float = 2.0):
    """Helix points (num, 3), parameter t (num,) and arc length per unit t."""
    t = np.linspace(0.0, 2.0 * np.pi * turns, num)
    points = np.stack([radius * np.cos(t), radius * np.sin(t), pitch * t], axis=1)
    return points, t, np.hypot(radius, pitch)


def test_frames_are_right_handed_orthonormal_with_tangent_along_the_curve():
    points, _, _ = helix()
    frames = bishop_frames(points)
    gram = np.einsum("nij,nkj->nik", frames, frames)
    np.testing.assert_allclose(gram, np.broadcast_to(np.eye(3), gram.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(frames), 1.0, atol=1e-12)
    chord = np.gradient(points, axis=0, edge_order=2)
    chord /= np.linalg.norm(chord, axis=1)[:, None]
    np.testing.assert_allclose(frames[:, 0], chord, atol=1e-12)


def test_helix_normal_turns_against_the_frenet_frame_by_minus_torsion_times_arc_length():
    # A rotation-minimising normal n = cos(phi) N + sin(phi) B obeys phi' = -torsion.
    radius, pitch = 1.0, 0.3
    points, t, speed = helix(4000, radius, pitch)
    frames = bishop_frames(points)
    frenet_n = np.stack([-np.cos(t), -np.sin(t), np.zeros_like(t)], axis=1)
    frenet_t = np.stack([-radius * np.sin(t), radius * np.cos(t), pitch * np.ones_like(t)], axis=1) / speed
    frenet_b = np.cross(frenet_t, frenet_n)
    phi = np.unwrap(np.arctan2(np.einsum("ij,ij->i", frames[:, 1], frenet_b),
                               np.einsum("ij,ij->i", frames[:, 1], frenet_n)))
    torsion = pitch / (radius**2 + pitch**2)
    arc = speed * t
    np.testing.assert_allclose(phi - phi[0], -torsion * arc, atol=1e-9)
    assert abs(torsion * arc[-1]) > 1.0          # the Frenet frame twists a lot; ours does not


def test_consecutive_frames_differ_by_the_minimal_rotation():
    # The discrete twist b_i . (n_{i+1} - n_{i-1}) vanishes to second order in the step.
    points, _, _ = helix(1000)
    frames = bishop_frames(points)
    twist = np.einsum("ij,ij->i", frames[1:-1, 2], frames[2:, 1] - frames[:-2, 1])
    bend = np.linalg.norm(frames[2:, 0] - frames[:-2, 0], axis=1)
    assert np.abs(twist).max() < 1e-4 * bend.max()


def test_straight_line_with_stalls_gives_constant_frames():
    x = np.r_[np.zeros(5), np.linspace(0.0, 1.0, 50), np.ones(5)]
    points = np.stack([x, 2 * x, -x], axis=1) + np.array([0.1, 0.2, 0.3])
    frames = bishop_frames(points)
    direction = np.array([1.0, 2.0, -1.0]) / np.sqrt(6.0)
    np.testing.assert_allclose(frames[:, 0], np.broadcast_to(direction, (60, 3)), atol=1e-12)
    np.testing.assert_allclose(frames, np.broadcast_to(frames[0], frames.shape), atol=1e-12)


def test_initial_normal_is_respected_and_projected():
    points, _, _ = helix(200)
    hint = np.array([0.3, -0.2, 1.0]) + unit_tangents(points)[0]        # not normal to t0
    frames = bishop_frames(points, initial_normal=hint)
    t0 = frames[0, 0]
    expected = hint - t0 * (hint @ t0)
    np.testing.assert_allclose(frames[0, 1], expected / np.linalg.norm(expected), atol=1e-12)


def test_bad_input_raises_clear_errors():
    with raises_naming(TLGCArgumentError, "points"):
        bishop_frames(np.zeros((10, 2)))
    with raises_naming(TLGCArgumentError, "points"):
        bishop_frames(np.array([[0.0, 0, 0], [np.nan, 0, 0]]))
    with raises_naming(TLGCArgumentError, "points"):
        bishop_frames(np.ones((5, 3)))
    with raises_naming(TLGCArgumentError, "initial_normal"):
        bishop_frames(np.c_[np.linspace(0, 1, 5), np.zeros(5), np.zeros(5)], initial_normal=[2.0, 0, 0])


def test_stall_between_turning_tangents_keeps_a_continuous_normal():
    # A corner visited twice: zero chord while the tangent turns; the frame must rotate, not flip.
    a = np.stack([np.linspace(-1, 0, 20), np.zeros(20), np.zeros(20)], axis=1)
    b = np.stack([np.zeros(20), np.linspace(0, 1, 20), np.zeros(20)], axis=1)
    points = np.concatenate([a, a[-1:], b])
    frames = bishop_frames(points, initial_normal=[0.0, 0.0, 1.0])
    np.testing.assert_allclose(np.linalg.det(frames), 1.0, atol=1e-12)
    np.testing.assert_allclose(frames[:, 1], np.broadcast_to([0.0, 0.0, 1.0], (41, 3)), atol=1e-12)
