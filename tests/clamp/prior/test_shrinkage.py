"""Start shrinkage (clamp.prior.shrinkage): the weight is chosen by leave-one-out prediction of the
demonstrations from their starts, the recorded errors are those predictions' errors (normal to
the mean path: the mean positions' gradient, an orientation chain's mean angular velocity), the
mean stays the demonstrations' mean and a given weight makes a moved start fade as the target
says."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from clamp import InvalidParameterError, condition_prior, learn_prior
from clamp.prior.learning import learn_joint_prior, learn_orientation
from clamp.prior.orientation_prior import orientation_states
from clamp.prior.shrinkage import fading_responses, shrink_start_offsets
from scenes import Demonstrations, make_demonstrations


def converging(num_demos=6, T=120, seed=4):
    """Demonstrations from scattered starts that all converge to one end at rest (as LASA's):
    each start offset fades as (1 - tau)^2 along a common curve, plus each demonstration's own
    smooth variation (three sine modes, 1 cm), which the per-step regression must see through."""
    rng = np.random.default_rng(seed)
    tau = np.linspace(0.0, 1.0, T)
    base = np.stack([0.30 + 0.15 * np.sin(2.5 * tau), -0.35 + 0.1 * tau ** 2,
                     0.12 + 0.0 * tau], axis=1)
    positions = np.empty((num_demos, T, 3))
    for m in range(num_demos):
        offset = np.array([*rng.normal(scale=0.03, size=2), 0.0])
        wiggle = sum(np.outer(np.sin(np.pi * k * tau) * np.sin(np.pi * tau),
                              [*rng.normal(scale=0.01, size=2), 0.0]) for k in (1, 2, 3))
        positions[m] = base + (1.0 - tau)[:, None] ** 2 * offset + wiggle
    time = tau * 3.0
    return Demonstrations(positions, np.gradient(positions, time, axis=1), time)


def subset(demos, keep):
    return Demonstrations(demos.positions[keep], demos.velocities[keep], demos.time)


def loo_rms(demos, normal=False, **options):
    """RMS [m] over demonstrations and steps of each one's start-conditioned prior mean when
    learned from the others (computed through the public API, independently of the learner);
    ``normal``: of the part of each error normal to the prior's mean path at that step."""
    squares = []
    for k in range(demos.M):
        prior = learn_prior(subset(demos, np.arange(demos.M) != k), **options)
        mean = condition_prior(prior, [(0, demos.positions[k, 0])]).mean[:, :3]
        error = mean - demos.positions[k]
        if normal:
            direction = np.gradient(prior.mean[:, :3], axis=0)
            unit = direction / np.linalg.norm(direction, axis=1, keepdims=True)
            error = error - np.sum(error * unit, axis=1, keepdims=True) * unit
        squares.append(np.sum(error ** 2, axis=1))
    return float(np.sqrt(np.mean(squares)))


def test_auto_weight_is_chosen_by_leave_one_out_and_its_errors_are_true():
    demos = converging()
    prior = learn_prior(demos)
    record = prior.info["start_shrinkage"]
    assert record["setting"] == "auto" and 0.0 < record["weight"] <= 1.0
    # the recorded error of the plain chain is what predicting each demonstration gives,
    # normal to the mean path (along it, the error is a difference in speed)
    assert record["loo_rms_plain"] == pytest.approx(
        loo_rms(demos, normal=True, start_shrinkage=0.0), rel=1e-3)
    assert record["loo_rms"] < record["loo_rms_plain"]
    # and the prior learned with the chosen weight predicts held-out demonstrations better
    assert loo_rms(demos) < loo_rms(demos, start_shrinkage=0.0)
    assert "weight" in prior.summary() and "leave-one-out" in prior.summary()


def test_mean_stays_the_demonstrations_mean():
    demos = converging()
    for weight in ("auto", 0.5, 1.0):
        prior = learn_prior(demos, start_shrinkage=weight)
        np.testing.assert_allclose(prior.mean[:, :3], demos.positions.mean(axis=0), atol=1e-6)
        np.testing.assert_allclose(prior.mean[:, 3:], demos.velocities.mean(axis=0), atol=1e-6)


def test_full_weight_carries_a_moved_start_as_the_fading_target():
    demos = converging()
    prior = learn_prior(demos, start_shrinkage=1.0)
    offset = np.array([0.02, -0.01, 0.0])
    moved = condition_prior(prior, [(0, prior.mean[0, :3] + offset)]).mean[:, :3]
    start = np.zeros((6, 3))
    start[:3] = np.eye(3)
    gain = fading_responses(demos.time, start, demos.positions)[:, :3, :3]   # (T, 3, 3)
    expected = prior.mean[:, :3] + gain @ offset
    middle = slice(0, prior.T // 2)       # where the response is large: the damping is small
    np.testing.assert_allclose(moved[middle], expected[middle], atol=0.05 * 0.02)
    # the offset has faded by the end, which all demonstrations share
    assert np.linalg.norm(moved[-1] - demos.positions[:, -1].mean(axis=0)) < 1e-3


def test_the_initial_velocity_moves_with_the_start_as_the_fading_target():
    """The velocity a moved start implies is the target's (none: the demonstrations' mean
    initial velocity), not the per-step regression of the first velocities on the first
    positions (from 3-10 samples); with a weight w, (1 - w) of that regression; the initial
    covariance stays positive definite."""
    demos = converging(num_demos=4)
    plain = learn_prior(demos, start_shrinkage=0.0)
    prior = learn_prior(demos, start_shrinkage=1.0)
    offset = np.array([0.02, -0.01, 0.0])
    conditioned = condition_prior(prior, [(0, prior.mean[0, :3] + offset)]).mean[0]
    regressed = condition_prior(plain, [(0, plain.mean[0, :3] + offset)]).mean[0, 3:] \
        - plain.mean[0, 3:]
    assert np.linalg.norm(regressed) > 1e-3                                       # [m/s]
    np.testing.assert_allclose(conditioned[3:], prior.mean[0, 3:], atol=1e-3 * np.linalg.norm(regressed))
    half = learn_prior(demos, start_shrinkage=0.5)
    moved = condition_prior(half, [(0, half.mean[0, :3] + offset)]).mean[0, 3:] - half.mean[0, 3:]
    np.testing.assert_allclose(moved, 0.5 * regressed, atol=1e-2 * np.linalg.norm(regressed))
    # the positions' covariance kept (up to the lift back to the learner's jitter floor)
    np.testing.assert_allclose(prior.cov0[:3, :3], plain.cov0[:3, :3], rtol=1e-2, atol=1e-7)
    assert np.linalg.eigvalsh(prior.cov0).min() > 0.0


def test_two_demonstrations_take_the_fading_response():
    """With two demonstrations (nothing to leave out) a moved start fades as (1 - tau) times
    the norm of their spread relative to the start's, on every axis, followed closely over the
    whole motion (computed here from the demonstrations themselves)."""
    demos = make_demonstrations("box_closing", num_demos=2, num_points=40, seed=1)
    with pytest.warns(Warning):
        prior = learn_prior(demos)
    assert prior.info["start_shrinkage"]["weight"] == 1.0
    assert "at least 3" in prior.info["start_shrinkage"]["reason"]
    tau = (demos.time - demos.time[0]) / (demos.time[-1] - demos.time[0])
    spread = np.linalg.norm(demos.positions.std(axis=0), axis=1)
    gain = (1.0 - tau) * np.minimum(1.0, spread / spread[0])
    for offset in (np.array([0.02, -0.01, 0.0]), np.array([0.0, 0.01, 0.015])):
        moved = condition_prior(prior, [(0, prior.mean[0, :3] + offset)]).mean[:, :3]
        expected = prior.mean[:, :3] + gain[:, None] * offset
        np.testing.assert_allclose(moved, expected, atol=0.02 * np.linalg.norm(offset))


@pytest.mark.parametrize("bad", [-0.1, 1.5, "yes", True, None])
def test_bad_weight_names_the_argument(bad):
    with pytest.raises(InvalidParameterError, match="start_shrinkage"):
        learn_prior(converging(num_demos=3, T=20), start_shrinkage=bad)


def test_an_axis_two_demonstrations_share_still_moves_with_the_start():
    """Two demonstrations equal in z (as synthetic0's): a start off that axis is met (the
    agreeing coordinate's variance is raised relative to the others', AXIS_FLOOR_RATIO; before,
    the start was missed by its whole 2 cm) and its offset fades by the common end."""
    demos = converging(num_demos=2, T=60)
    with pytest.warns(Warning):
        prior = learn_prior(demos)
    start = prior.mean[0, :3] + np.array([0.0, 0.0, 0.02])
    moved = condition_prior(prior, [(0, start)]).mean[:, :3]
    assert np.linalg.norm(moved[0] - start) < 1e-4
    assert abs(moved[prior.T // 2, 2] - prior.mean[prior.T // 2, 2]) < 0.02
    assert np.linalg.norm(moved[-1] - prior.mean[-1, :3]) < 1e-3


def early_fading(num_demos=6, T=120, seed=5):
    """As :func:`converging`, but every start offset is gone within the first 30 % of the
    motion (as the synthetic skills' are) while the demonstrations still spread later."""
    demos = converging(num_demos, T, seed)
    tau = np.linspace(0.0, 1.0, T)
    mean = demos.positions.mean(axis=0)
    offsets = demos.positions[:, :1] - mean[:1]
    keep = (1.0 - tau) ** 2                        # converging()'s own fade of the offset
    drop = np.clip(1.0 - tau / 0.3, 0.0, None) ** 2
    positions = demos.positions + offsets * (drop - keep)[None, :, None]
    return Demonstrations(positions, np.gradient(positions, demos.time, axis=1), demos.time)


def test_weights_per_shape_are_recorded_and_summed():
    prior = learn_prior(converging())
    record = prior.info["start_shrinkage"]
    assert set(record["weights"]) == {"spread", "regressed"}
    assert all(w >= 0.0 for w in record["weights"].values())
    assert record["weight"] == pytest.approx(sum(record["weights"].values()))
    assert record["weight"] <= 1.0 + 1e-9
    assert "spread" in prior.summary() or "regressed" in prior.summary()


def test_an_offset_the_demonstrations_drop_early_is_dropped_early():
    """The regressed shape follows the demonstrations' own start gain: where they lose their
    start offset within a third of the motion it takes the larger weight, and the chosen
    blend predicts held-out demonstrations better than the spread shape whole."""
    demos = early_fading()
    record = learn_prior(demos).info["start_shrinkage"]
    assert record["weights"]["regressed"] > record["weights"]["spread"]
    assert loo_rms(demos) < loo_rms(demos, start_shrinkage=1.0)
    assert loo_rms(demos) < loo_rms(demos, start_shrinkage=0.0)


def turning(num_demos=6, T=90, seed=5):
    """Quaternions (M, T, 4) and time (T,) [s]: hands turning 120 deg about z from scattered
    starting rotations (offsets about z and x that fade), each at its own pace."""
    rng = np.random.default_rng(seed)
    tau = np.linspace(0.0, 1.0, T)
    angles = []
    for _ in range(num_demos):
        pace = tau ** rng.uniform(0.8, 1.25)
        offset = rng.normal(scale=np.radians(8.0), size=2)
        angles.append(np.stack([np.radians(120.0) * pace + offset[0] * (1 - tau) ** 2,
                                offset[1] * (1 - tau), 0.1 * np.sin(np.pi * tau)], axis=1))
    R = Rotation.from_euler("zxy", np.reshape(angles, (-1, 3)))
    return R.as_quat().reshape(num_demos, T, 4), 3.0 * tau


def test_an_orientation_chain_judges_its_leave_one_out_errors_normal_to_the_mean_turn():
    """The orientation chain's coordinates are centred on the mean rotation at every step, so
    the mean path's direction in the leave-one-out error is the mean angular velocity (the
    chain's velocity part), not the gradient of the coordinates' mean (near 0). The recorded
    error of the plain chain is that of predicting each demonstration from its start, learned
    from the others (computed here with the public learner of a chain over given states),
    normal to the others' mean angular velocity."""
    q, time = turning()
    prior = learn_orientation(q, time)
    record = prior.info["start_shrinkage"]
    states = orientation_states(Rotation.from_quat(q.reshape(-1, 4)).as_matrix().reshape(
        q.shape[:2] + (3, 3)), prior.rotations, time)
    squares, along_mean = [], []
    for k in range(len(q)):
        others = np.arange(len(q)) != k
        chain = learn_joint_prior(states[others, :, :3], states[others, :, 3:], time)
        error = condition_prior(chain, [(0, states[k, 0, :3])], sigma=1e-9).mean[:, :3] \
            - states[k, :, :3]
        for direction, out in ((chain.mean[:, 3:], squares),
                               (np.gradient(chain.mean[:, :3], axis=0), along_mean)):
            unit = direction / np.linalg.norm(direction, axis=1, keepdims=True)
            out.append(np.sum((error - np.sum(error * unit, axis=1, keepdims=True) * unit) ** 2,
                              axis=1))
    assert record["loo_rms_plain"] == pytest.approx(np.sqrt(np.mean(squares)), rel=1e-3)
    assert record["loo_rms_plain"] != pytest.approx(np.sqrt(np.mean(along_mean)), rel=1e-2)


def test_an_unknown_path_direction_is_refused():
    demos = converging(num_demos=4)
    with pytest.raises(InvalidParameterError, match="along"):
        shrink_start_offsets(np.concatenate([demos.positions, demos.velocities], axis=2),
                             demos.time, None, None, None, None, "auto", None, along="speed")
