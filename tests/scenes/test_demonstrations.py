"""Demonstrations: validation, construction from unequal trajectories, resampling, DTW."""
import numpy as np
import pytest

from bad_input import raises_naming
from scenes import Box, Demonstrations, InvalidDemonstrationsError, NOMINAL_DURATION, make_demonstrations
from scenes.alignment import dtw_cost, dtw_path


def smooth_path(s):
    """A smooth 3-D curve (…,3) of the phase s in [0, 1] (metres)."""
    return np.stack([0.2 + 0.25 * s, -0.45 + 0.2 * np.sin(2.5 * s), 0.25 + 0.1 * np.sin(6 * s) * s], axis=-1)


def valid(M=3, T=20):
    rng = np.random.default_rng(0)
    return rng.normal(size=(M, T, 3)), rng.normal(size=(M, T, 3)), np.linspace(0, 1, T)


def with_value(array, value):
    out = np.array(array)
    out[1, 2, 0] = value
    return out


@pytest.mark.parametrize("change, name", [
    (lambda p, v, t: (with_value(p, np.nan), v, t), "positions"),
    (lambda p, v, t: (p, with_value(v, np.inf), t), "velocities"),
    (lambda p, v, t: (p[:1], v[:1], t), "positions"),
    (lambda p, v, t: (p[0], v[0], t), "positions"),
    (lambda p, v, t: (p[..., :2], v[..., :2], t), "positions"),
    (lambda p, v, t: (p, v, t[::-1]), "time"),
    (lambda p, v, t: (p, v, np.r_[t[:5], t[4], t[6:]]), "time[5]"),
    (lambda p, v, t: (p, v[:, :10], t), "velocities"),
    (lambda p, v, t: (p, v, t[:10]), "time"),
    (lambda p, v, t: (p[:, :1], v[:, :1], t[:1]), "positions"),
    (lambda p, v, t: ([["a"]], v, t), "positions"),
])
def test_invalid_arrays_raise_naming_the_problem(change, name):
    with raises_naming(InvalidDemonstrationsError, name):
        Demonstrations(*change(*valid()))


def test_obstacles_must_match_demonstration_count():
    p, v, t = valid()
    with raises_naming(InvalidDemonstrationsError, "obstacles"):
        Demonstrations(p, v, t, obstacles=[[Box([0, 0, 0], [1, 1, 1])]])
    with raises_naming(InvalidDemonstrationsError, "obstacles[1][0]"):
        Demonstrations(p, v, t, obstacles=[[], ["box"], []])


def test_properties_and_mean_and_translation():
    demos = make_demonstrations("curved_reach", num_demos=4, num_points=50, dt=0.1)
    assert (demos.M, demos.T) == (4, 50) and np.isclose(demos.dt, 0.1)
    assert np.isclose(demos.duration, 4.9)
    assert np.allclose(demos.mean_position(), demos.positions.mean(axis=0))
    assert demos.states.shape == (4, 50, 6)
    moved = demos.translated([0.1, -0.2, 0.05])
    assert np.allclose(moved.positions - demos.positions, [0.1, -0.2, 0.05])
    assert np.allclose(moved.velocities, demos.velocities)
    assert np.allclose(moved.obstacles[2][0].center, demos.obstacles[2][0].center + [0.1, -0.2, 0.05])
    with raises_naming(InvalidDemonstrationsError, "offset"):
        demos.translated([1, 2])


def test_dt_is_the_median_step_for_irregular_stamps():
    p, v, _ = valid(T=6)
    t = np.array([0.0, 0.16, 0.24, 0.40, 0.56, 0.72])
    assert np.isclose(Demonstrations(p, v, t).dt, 0.16)


def test_from_trajectories_resamples_unequal_lengths_by_phase():
    lengths, durations = [40, 55, 70], [3.0, 4.0, 5.0]
    trajectories = [smooth_path(np.linspace(0, 1, n)) for n in lengths]
    times = [np.linspace(1.0, 1.0 + d, n) for n, d in zip(lengths, durations)]
    demos = Demonstrations.from_trajectories(trajectories, times, num_points=101)
    assert demos.positions.shape == (3, 101, 3)
    assert np.allclose(demos.time, np.linspace(0, 4.0, 101))
    # same curve at the same phase: all three agree with the analytic curve
    assert np.abs(demos.positions - smooth_path(np.linspace(0, 1, 101))).max() < 1e-5
    # velocities are the time derivative on the common (mean-duration) axis
    s = np.linspace(0, 1, 101)
    eps = 1e-6
    analytic = (smooth_path(s + eps) - smooth_path(s - eps)) / (2 * eps) / 4.0
    assert np.abs(demos.velocities - analytic).max() < 1e-3
    assert demos.T == 101
    default = Demonstrations.from_trajectories(trajectories)
    assert default.T == 70 and np.isclose(default.duration, NOMINAL_DURATION)


def test_from_trajectories_rescales_given_velocities():
    s40, s80 = np.linspace(0, 1, 40), np.linspace(0, 1, 80)
    eps = 1e-6
    vel = [(smooth_path(s + eps) - smooth_path(s - eps)) / (2 * eps) / d for s, d in ((s40, 2.0), (s80, 6.0))]
    demos = Demonstrations.from_trajectories([smooth_path(s40), smooth_path(s80)],
                                             [np.linspace(0, 2, 40), np.linspace(0, 6, 80)],
                                             num_points=60, velocities=vel)
    derivative = np.gradient(demos.positions, demos.time, axis=1)
    assert np.abs(demos.velocities - derivative)[:, 2:-2].max() < 1e-3


@pytest.mark.parametrize("kwargs, name", [
    (dict(trajectories=[np.zeros((5, 3))]), "trajectories"),
    (dict(trajectories=[np.zeros((5, 3)), np.zeros((5, 2))]), "trajectories[1]"),
    (dict(trajectories=[np.zeros((5, 3)), np.full((5, 3), np.nan)]), "trajectories[1]"),
    (dict(trajectories=[np.zeros((5, 3))] * 2, times=[np.arange(5.0)]), "times"),
    (dict(trajectories=[np.zeros((5, 3))] * 2, times=[np.arange(5.0), np.ones(5)]), "times[1]"),
    (dict(trajectories=[np.zeros((5, 3))] * 2, num_points=1), "num_points"),
    (dict(trajectories=[np.zeros((5, 3))] * 2, velocities=[np.zeros((5, 3)), np.zeros((4, 3))]), "velocities[1]"),
])
def test_from_trajectories_errors(kwargs, name):
    with raises_naming(InvalidDemonstrationsError, name):
        Demonstrations.from_trajectories(**kwargs)


def test_resample_round_trip_on_smooth_data():
    demos = make_demonstrations("box_closing", num_demos=4, num_points=250)
    back = demos.resample(500).resample(250)
    assert np.allclose(back.time, demos.time)
    assert np.abs(back.positions - demos.positions).max() < 1e-6
    assert np.abs(back.velocities - demos.velocities).max() < 1e-6
    assert demos.resample(500).T == 500
    with raises_naming(InvalidDemonstrationsError, "T"):
        demos.resample(1)


def test_dtw_realigns_a_time_warped_copy_within_a_millimetre():
    T = 250
    tau = np.linspace(0, 1, T)
    reference = smooth_path(tau)
    warp = tau + 0.3 * np.sin(np.pi * tau) * tau          # monotone, w(0)=0, w(1)=1
    assert np.all(np.diff(warp) > 0)
    warped = smooth_path(warp)
    assert np.abs(warped - reference).max() > 0.05       # clearly out of step before alignment
    time = np.linspace(0, 10, T)
    demos = Demonstrations(np.stack([reference, warped]), np.zeros((2, T, 3)), time)
    aligned = demos.align_dtw(reference=0)
    assert np.linalg.norm(aligned.positions[1] - reference, axis=-1).max() < 1e-3
    assert np.array_equal(aligned.positions[0], reference)
    # velocities follow the aligned positions
    assert np.abs(aligned.velocities[1] - np.gradient(aligned.positions[1], time, axis=0))[2:-2].max() < 1e-3


def test_dtw_cost_matches_brute_force_recursion():
    rng = np.random.default_rng(5)
    a, b = rng.normal(size=(7, 3)), rng.normal(size=(9, 3))
    local = np.linalg.norm(a[:, None] - b[None], axis=-1)
    acc = np.full((8, 10), np.inf)
    acc[0, 0] = 0
    for i in range(1, 8):
        for j in range(1, 10):
            acc[i, j] = local[i - 1, j - 1] + min(acc[i - 1, j - 1], acc[i - 1, j], acc[i, j - 1])
    assert np.allclose(dtw_cost(a, b), acc[1:, 1:])
    ia, ib = dtw_path(a, b)
    assert (ia[0], ib[0], ia[-1], ib[-1]) == (0, 0, 6, 8)
    assert np.all(np.diff(ia) >= 0) and np.all(np.diff(ib) >= 0)
    assert np.isclose(local[ia, ib].sum(), acc[-1, -1])


def test_align_dtw_rejects_bad_reference():
    demos = make_demonstrations("pick_place", num_demos=3, num_points=30)
    with raises_naming(InvalidDemonstrationsError, "reference"):
        demos.align_dtw(reference=3)


def test_dtw_reduces_timing_spread_of_warped_demonstrations():
    demos = make_demonstrations("box_closing", num_demos=5, num_points=150)
    aligned = demos.align_dtw(reference=2)

    def mismatch(d):
        return np.linalg.norm(d.positions - d.positions[2], axis=-1).mean()

    assert mismatch(aligned) < 0.9 * mismatch(demos)
    assert np.array_equal(aligned.positions[2], demos.positions[2])
    # start and end stay where they were (the warp is monotone and covers the whole demo)
    assert np.allclose(aligned.positions[:, [0, -1]], demos.positions[:, [0, -1]], atol=1e-3)


# ------------------------------------------------------------- recorded joint trajectories
def joint_demos(M=3, T=40):
    """Demonstrations carrying joint trajectories q (M, T, 2) of a planar 2-link arm (links 0.3 m),
    positions its forward kinematics (z = 0)."""
    s = np.linspace(0.0, 1.0, T)
    q = np.stack([np.stack([0.3 + 0.5 * s + 0.05 * m, 0.8 - 0.4 * s ** 2], axis=1) for m in range(M)])
    elbow = 0.3 * np.stack([np.cos(q[..., 0]), np.sin(q[..., 0])], axis=-1)
    tip = elbow + 0.3 * np.stack([np.cos(q.sum(-1)), np.sin(q.sum(-1))], axis=-1)
    p = np.concatenate([tip, np.zeros(q.shape[:2] + (1,))], axis=-1)
    time = np.linspace(0.0, 4.0, T)
    v = np.gradient(p, time, axis=1)
    return Demonstrations(p, v, time, joint_positions=q, joint_names=["shoulder", "elbow"]), q


def test_joint_trajectories_follow_resampling_and_alignment():
    demos, q = joint_demos()
    fine = demos.resample(79)                              # every other sample is an old one
    np.testing.assert_allclose(fine.joint_positions[:, ::2], q, atol=1e-12)
    assert fine.joint_names == ("shoulder", "elbow")
    aligned = demos.align_dtw()
    assert aligned.joint_positions.shape == q.shape
    np.testing.assert_array_equal(aligned.joint_positions[0], q[0])   # the reference is kept
    assert demos.translated([0.1, 0.0, 0.0]).joint_positions is None
    paths = [demos.positions[m, : 30 + 5 * m] for m in range(3)]
    joints = [q[m, : 30 + 5 * m] for m in range(3)]
    resampled = Demonstrations.from_trajectories(paths, num_points=30, joint_positions=joints,
                                                 joint_names=demos.joint_names)
    np.testing.assert_allclose(resampled.joint_positions[:, [0, -1]],
                               np.stack([[j[0], j[-1]] for j in joints]), atol=1e-12)


@pytest.mark.parametrize("kwargs, name", [
    (dict(joint_positions=np.zeros((3, 20, 2))), "joint_names"),
    (dict(joint_positions=np.zeros((3, 19, 2)), joint_names=["a", "b"]),
     "joint_positions"),
    (dict(joint_names=["a", "b"]), "joint_names"),
    (dict(joint_positions=np.zeros((3, 20, 2)), joint_names=["a", 2]), "joint_names"),
])
def test_joint_trajectories_are_checked(kwargs, name):
    with raises_naming(InvalidDemonstrationsError, name):
        Demonstrations(*valid(), **kwargs)
