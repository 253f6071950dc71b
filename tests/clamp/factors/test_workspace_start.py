"""The workspace start family moved to a new start: its minimiser is the learned prior
conditioned on that start (the velocity too, not only the position), checked against
``clamp.condition_prior`` and against a plan whose joint-space GP is weak. The priors are the
plain chain (start_shrinkage=0), whose initial velocity follows the start the most."""
from __future__ import annotations

import dataclasses

import numpy as np

import clamp
import robots
import scenes
from clamp.factors import shifted_start_mean


def fading_offsets(num_demos: int = 6, T: int = 60, duration: float = 3.0) -> scenes.Demonstrations:
    """Demonstrations of an arc in the Jaco's workspace whose start offsets fade out along the
    motion: each leaves its start already moving back towards the others (its initial velocity
    depends on its start, as a person's does when reaching from elsewhere)."""
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, duration, T)
    s = t / duration
    arc = np.stack([0.30 + 0.10 * s, -0.40 + 0.08 * np.sin(np.pi * s), 0.25 + 0.05 * s], axis=1)
    offsets = rng.normal(scale=0.02, size=(num_demos, 1, 3))
    positions = arc[None] + offsets * (1.0 - s[None, :, None]) ** 2 + rng.normal(scale=5e-4, size=(num_demos, T, 3))
    return scenes.Demonstrations(positions, np.gradient(positions, t, axis=1), t, name="fading offsets")


def test_the_moved_mean_is_the_initial_state_conditioned_on_the_start():
    prior = clamp.learn_prior(fading_offsets(), start_shrinkage=0.0)
    rng = np.random.default_rng(4)
    for _ in range(3):
        start = np.asarray(prior.mean0)[:3] + rng.normal(scale=0.03, size=3)
        expected = np.asarray(clamp.condition_prior(prior, [(0, start)]).mean)[0]
        moved = shifted_start_mean(prior.mean0, prior.cov0, start)
        np.testing.assert_allclose(moved[:3], start, atol=0)
        # the velocity the demonstrations show with such a start (~1e-5 m conditioning noise)
        np.testing.assert_allclose(moved[3:], expected[3:], atol=1e-4 * np.abs(expected[3:]).max())
        assert np.linalg.norm(moved[3:] - np.asarray(prior.mean0)[3:]) > 1e-3   # it did move


def test_a_plan_with_a_weak_joint_prior_follows_the_conditioned_prior():
    """Empty scene, start 4 cm off the demonstrations': with the joint GP 100x weaker than the
    default, the arm's hand path is the conditioned prior's mean (the graph's optimum is it)."""
    prior = clamp.learn_prior(fading_offsets(), start_shrinkage=0.0)
    start = np.asarray(prior.mean0)[:3] + np.array([0.0, 0.03, -0.02])
    config = clamp.PlannerConfig()
    config = dataclasses.replace(config, model=dataclasses.replace(config.model, Qc=100.0))
    result = clamp.plan(prior, robots.load_robot("jaco"), None, start, config=config)
    mean = np.asarray(clamp.condition_prior(prior, [(0, start)]).mean)[:, :3]
    assert result.success
    assert np.max(np.linalg.norm(np.asarray(result.ee_path) - mean, axis=1)) < 2e-4   # 1.4 mm with
    # the learned initial velocity kept (the start's pull on it lost)
