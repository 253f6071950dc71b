"""Bad-input catalogue of ``clamp``: every public function of docs/interfaces.md fed bad
input answers with the project's error naming the argument (see tests/bad_input.py), and a
plan that misses what it was asked for says so with the numbers."""
from __future__ import annotations

import re

from types import SimpleNamespace

import numpy as np
import pytest

from bad_input import Case, cases, check
from clamp import PlannerConfig, build, learn_prior, plan
from clamp.animation import write_animation
from clamp.errors import (ArgumentTypeError, ClampError, DegenerateDemonstrationsError,
                          InsufficientDemonstrationsError, InvalidParameterError, NonFiniteError,
                          PriorFileError, ShapeError)
from clamp.factors import (EEPositionFamily, JointGPFamily, JointLimitFamily, JointTargetFamily,
                           ObstacleFamily, WorkspaceGPFamily, WorkspaceStartFamily)
from clamp.initialisation import prior_mean_initialisation, straight_line_initialisation
from clamp.learning import learn_joint_prior
from clamp.optimizers import optimize
from clamp.plan_plots import plot_plan_3d, plot_plan_uncertainty
from clamp.plausibility import plausibility
from clamp.prior import LinearGaussianPrior, WorkspacePrior
from clamp.prior_plots import plot_prior_3d, plot_prior_time
from clamp.uncertainty import block_tridiagonal_inverse
from clamp.validation import as_array, as_count, as_scalar, as_time
from clamp.verdict import sphere_clearance
from robots.errors import RobotError
from scenes import Box, Demonstrations, Scene, make_demonstrations
from scenes.errors import InvalidArgumentError, SceneFileError

START = [0.2054, -0.4722, 0.2625]


def _demos():
    return make_demonstrations("box_closing", num_demos=4, num_points=30, seed=1)


def _plan(fx, **kwargs):
    kwargs.setdefault("start", START)
    kwargs.setdefault("covariance", False)
    return plan(fx.prior, fx.robot, **kwargs)


def _identical():
    d = _demos()
    return Demonstrations(np.repeat(d.positions[:1], 4, 0), np.repeat(d.velocities[:1], 4, 0), d.time)


def _save(fx, name: str, **arrays):
    path = fx.tmp / name
    np.savez(path, **arrays)
    return path


def _prior_arrays(fx, **changes):
    p = fx.prior
    arrays = dict(format=np.array("clamp-linear-gaussian-prior/1"), kind=np.array("workspace"),
                  state_names=np.array(p.state_names), info=np.array("{}"), time=p.time, Phi=p.Phi,
                  u=p.u, Q=p.Q, mean0=p.mean0, cov0=p.cov0)
    arrays.update(changes)
    return arrays


S, NF, P, T, I = ShapeError, NonFiniteError, InvalidParameterError, ArgumentTypeError, \
    InsufficientDemonstrationsError

CATALOGUE: list[Case] = [
    # --- learning
    Case("learn-identical-demos", lambda fx: learn_prior(_identical()), DegenerateDemonstrationsError,
         "demonstrations"),
    Case("learn-not-demos", lambda fx: learn_prior("demos.mat"), S, "demos"),
    Case("learn-both", lambda fx: learn_prior(_demos(), positions=np.zeros((2, 3, 3))), P, "demos"),
    Case("learn-missing-arrays", lambda fx: learn_prior(positions=np.zeros((2, 3, 3))), P, "demos"),
    Case("learn-one-demo", lambda fx: learn_prior(positions=np.zeros((1, 5, 3)), velocities=np.zeros(
        (1, 5, 3)), time=np.arange(5.0)), I, "demonstrations"),
    Case("learn-one-sample", lambda fx: learn_prior(positions=np.zeros((3, 1, 3)), velocities=np.zeros(
        (3, 1, 3)), time=np.arange(1.0)), S, "time"),
    Case("learn-time-order", lambda fx: learn_prior(positions=_demos().positions,
                                                    velocities=_demos().velocities,
                                                    time=_demos().time[::-1]), P, "time"),
    Case("learn-1e200", lambda fx: learn_prior(positions=_demos().positions * 1e200,
                                               velocities=_demos().velocities, time=_demos().time),
         P, "positions"),
    Case("learn-nan", lambda fx: learn_prior(positions=np.where(np.arange(3) == 1, np.nan,
                                                                _demos().positions),
                                             velocities=_demos().velocities, time=_demos().time),
         NF, "positions"),
    Case("learn-velocity-shape", lambda fx: learn_prior(positions=_demos().positions,
                                                        velocities=_demos().velocities[:, :5],
                                                        time=_demos().time), S, "velocities"),
    Case("learn-axes", lambda fx: learn_prior(positions=np.zeros((3, 5, 2)), velocities=np.zeros(
        (3, 5, 2)), time=np.arange(5.0)), S, "positions"),
    Case("learn-ridge-negative", lambda fx: learn_prior(_demos(), ridge=-1.0), P, "ridge"),
    Case("learn-ridge-bool", lambda fx: learn_prior(_demos(), ridge=True), P, "ridge"),
    Case("learn-jitter-nan", lambda fx: learn_prior(_demos(), jitter=np.nan), P, "jitter"),
    Case("learn-coupled-text", lambda fx: learn_prior(_demos(), coupled="yes"), P, "coupled"),
    Case("learn-joint-q-shape", lambda fx: learn_joint_prior(np.zeros((3, 5)), np.zeros((3, 5)),
                                                             np.arange(5.0)), S, "q"),
    Case("learn-joint-qdot-shape", lambda fx: learn_joint_prior(np.zeros((3, 5, 2)), np.zeros((3, 5, 1)),
                                                                np.arange(5.0)), S, "qdot"),
    Case("learn-joint-identical", lambda fx: learn_joint_prior(np.ones((3, 5, 2)), np.ones((3, 5, 2)),
                                                               np.arange(5.0)),
         DegenerateDemonstrationsError, "demonstrations"),
    # --- priors
    Case("prior-phi-shape", lambda fx: WorkspacePrior(np.arange(3.0), np.zeros((2, 4, 4)), np.zeros((2, 4)),
                                                      np.tile(np.eye(4), (2, 1, 1)), np.zeros(4), np.eye(4)),
         S, "Phi"),
    Case("prior-q-not-pd", lambda fx: WorkspacePrior(fx.prior.time, fx.prior.Phi, fx.prior.u,
                                                     -np.asarray(fx.prior.Q), fx.prior.mean0, fx.prior.cov0),
         P, "Q"),
    Case("prior-q-asymmetric", lambda fx: WorkspacePrior(
        fx.prior.time, fx.prior.Phi, fx.prior.u, np.asarray(fx.prior.Q) + np.triu(np.ones((6, 6)), 1),
        fx.prior.mean0, fx.prior.cov0), P, "Q"),
    Case("prior-time-length", lambda fx: WorkspacePrior(fx.prior.time[:-1], fx.prior.Phi, fx.prior.u,
                                                        fx.prior.Q, fx.prior.mean0, fx.prior.cov0), S, "time"),
    Case("sample-count", lambda fx: fx.prior.sample(0, 1), P, "count"),
    Case("sample-count-bool", lambda fx: fx.prior.sample(True, 1), P, "count"),
    Case("sample-rng", lambda fx: fx.prior.sample(2, "seed"), P, "rng"),
    Case("log-likelihood-shape", lambda fx: fx.prior.log_likelihood(np.zeros((3, 6))), S, "x"),
    Case("log-likelihood-nan", lambda fx: fx.prior.log_likelihood(np.full((fx.prior.T, 6), np.nan)), NF, "x"),
    Case("mahalanobis-shape", lambda fx: fx.prior.mahalanobis(np.zeros((fx.prior.T, 3))), S, "x"),
    Case("success-probability-text", lambda fx: fx.prior.success_probability("plan"), S, "x"),
    Case("step-probabilities-ragged", lambda fx: fx.prior.step_success_probabilities([[1, 2], [3]]), S, "x"),
    Case("transition-residuals-shape", lambda fx: fx.prior.transition_residuals(np.zeros((2, 2))), S, "x"),
    Case("envelope-level", lambda fx: fx.prior.envelope(1.5), P, "level"),
    Case("envelope-level-zero", lambda fx: fx.prior.envelope(0.0), P, "level"),
    Case("prior-load-missing", lambda fx: WorkspacePrior.load(fx.tmp / "none.npz"), PriorFileError, "path"),
    Case("prior-load-directory", lambda fx: WorkspacePrior.load(fx.tmp), PriorFileError, "directory"),
    Case("prior-load-garbage", lambda fx: WorkspacePrior.load(_write(fx, "g.npz", b"PK\x03\x04junk")),
         PriorFileError, "path"),
    Case("prior-load-format", lambda fx: WorkspacePrior.load(_save(fx, "f.npz", **_prior_arrays(
        fx, format=np.array("other/1")))), PriorFileError, "format"),
    Case("prior-load-kind", lambda fx: WorkspacePrior.load(_save(fx, "k.npz", **_prior_arrays(
        fx, kind=np.array("joint")))), PriorFileError, "joint"),
    Case("prior-load-nan", lambda fx: WorkspacePrior.load(_save(fx, "n.npz", **_prior_arrays(
        fx, u=np.full_like(fx.prior.u, np.nan)))), PriorFileError, "u"),
    Case("prior-load-info", lambda fx: WorkspacePrior.load(_save(fx, "i.npz", **_prior_arrays(
        fx, info=np.array("{")))), PriorFileError, "info"),
    Case("prior-load-info-list", lambda fx: WorkspacePrior.load(_save(fx, "il.npz", **_prior_arrays(
        fx, info=np.array("[1, 2]")))), PriorFileError, "info"),
    Case("prior-load-object", lambda fx: WorkspacePrior.load(_save(fx, "o.npz", **_prior_arrays(
        fx, Phi=np.array([None, 1], dtype=object)))), PriorFileError, "path"),
    Case("prior-load-names", lambda fx: WorkspacePrior.load(_save(fx, "sn.npz", **_prior_arrays(
        fx, state_names=np.array(["a", "b"])))), PriorFileError, "state_names"),
    Case("prior-load-path-type", lambda fx: WorkspacePrior.load(42), T, "path"),
    Case("prior-save-path-type", lambda fx: fx.prior.save(42), T, "path"),
    Case("plot-prior-3d-type", lambda fx: plot_prior_3d("prior"), T, "prior"),
    Case("plot-prior-time-demos", lambda fx: plot_prior_time(fx.prior, demos="demos"), S, "demos"),
    # --- configuration
    Case("config-joint-limits-text", lambda fx: PlannerConfig(joint_limits="no"), P, "joint_limits"),
    Case("config-unknown-field", lambda fx: PlannerConfig(sigma_obstacle=0.1), P, "sigma_obstacle"),
    Case("config-group-type", lambda fx: PlannerConfig(model={"epsilon": 0.1}), P, "config.model"),
    Case("config-sigma-negative", lambda fx: PlannerConfig().with_(sigma_obs=-1.0), P, "sigma_obs"),
    Case("config-epsilon-bool", lambda fx: PlannerConfig().with_(epsilon=True), P, "epsilon"),
    Case("config-cell-tiny", lambda fx: PlannerConfig().with_(sdf_cell_size=0.0), P, "sdf_cell_size"),
    Case("config-cell-large", lambda fx: PlannerConfig().with_(sdf_cell_size=0.5), P, "sdf_cell_size"),
    Case("config-max-iterations", lambda fx: PlannerConfig().with_(max_iterations=2.5), P, "max_iterations"),
    Case("config-optimizer", lambda fx: PlannerConfig(optimizer="lu"), P, "optimizer"),
    Case("config-initialisation", lambda fx: PlannerConfig().with_(initialisation="magic"), P,
         "initialisation"),
    Case("config-blend-text", lambda fx: PlannerConfig().with_(blend_start_offset="no"), P,
         "blend_start_offset"),
    Case("config-straight-line", lambda fx: PlannerConfig().with_(straight_line_configurations=[1]), P,
         "straight_line_configurations"),
    Case("config-tolerance-nan", lambda fx: PlannerConfig().with_(goal_tolerance=np.nan), P, "goal_tolerance"),
    Case("config-reference-unknown", lambda fx: PlannerConfig.reference(lambda0=1.0), P, "lambda0"),
    # --- planning
    Case("plan-config-dict", lambda fx: _plan(fx, config={"sigma_obs": 0.01}), T, "config"),
    Case("plan-prior-type", lambda fx: plan("prior.npz", fx.robot, start=START), T, "prior"),
    Case("plan-prior-joint", lambda fx: plan(learn_joint_prior(np.random.default_rng(0).normal(
        size=(4, 5, 2)), np.random.default_rng(1).normal(size=(4, 5, 2)), np.arange(5.0)), fx.robot,
        start=START), S, "prior"),
    Case("plan-robot-type", lambda fx: plan(fx.prior, "jaco", start=START), T, "robot"),
    Case("plan-scene-number", lambda fx: _plan(fx, scene=42), T, "scene"),
    Case("plan-scene-list-mixed", lambda fx: _plan(fx, scene=[Box([0.3, 0, 0.2], [0.1] * 3), "wall"]),
         T, "scene[1]"),
    Case("plan-scene-missing-file", lambda fx: _plan(fx, scene=str(fx.tmp / "none.json")), SceneFileError,
         "none.json"),
    Case("plan-sdf-text", lambda fx: _plan(fx, scene=Box([0.3, 0, 0.2], [0.1] * 3), sdf="abc"), T, "sdf"),
    Case("plan-sdf-without-scene", lambda fx: _plan(fx, sdf=Scene([Box([0.3, 0, 0.2], [0.1] * 3)]).sdf()),
         P, "sdf"),
    Case("plan-start-none", lambda fx: plan(fx.prior, fx.robot), P, "start"),
    Case("plan-start-shape", lambda fx: _plan(fx, start=[0.1, 0.2]), S, "start"),
    Case("plan-start-nan", lambda fx: _plan(fx, start=[np.nan, 0.2, 0.3]), NF, "start"),
    Case("plan-start-text", lambda fx: _plan(fx, start="home"), S, "start"),
    Case("plan-start-bools", lambda fx: _plan(fx, start=[True, False, True]), S, "start"),
    Case("plan-goal-shape", lambda fx: _plan(fx, goal=np.zeros(5)), S, "goal"),
    Case("plan-goal-inf", lambda fx: _plan(fx, goal=[np.inf, 0, 0]), NF, "goal"),
    Case("plan-via-index", lambda fx: _plan(fx, via_points=[(10_000, [0.3, 0.2, 0.1])]), P, "via_points[0]"),
    Case("plan-via-index-bool", lambda fx: _plan(fx, via_points=[(True, [0.3, 0.2, 0.1])]), P,
         "via_points[0]"),
    Case("plan-via-not-pair", lambda fx: _plan(fx, via_points=[[0.3, 0.2, 0.1]]), S, "via_points[0]"),
    Case("plan-via-none", lambda fx: _plan(fx, via_points=None), T, "via_points"),
    Case("plan-via-target", lambda fx: _plan(fx, via_points=[(5, [0.3, 0.2])]), S, "via_points[0]"),
    Case("plan-extra-number", lambda fx: _plan(fx, extra_factors=[42]), P, "extra_factors[0]"),
    Case("plan-extra-none", lambda fx: _plan(fx, extra_factors=None), T, "extra_factors"),
    Case("plan-initial-shape", lambda fx: _plan(fx, initial=np.zeros((3, 3))), S, "initial"),
    Case("plan-covariance-text", lambda fx: _plan(fx, covariance="no"), P, "covariance"),
    Case("build-start-shape", lambda fx: build(fx.prior, fx.robot, None, [1, 2]), S, "start"),
    Case("build-config-type", lambda fx: build(fx.prior, fx.robot, None, START, config="fast"), T, "config"),
    Case("optimize-problem-type", lambda fx: optimize("problem"), T, "problem"),
    Case("plausibility-shape", lambda fx: plausibility(fx.prior, np.zeros((3, 6))), S, "x"),
    Case("plausibility-start", lambda fx: plausibility(fx.prior, np.asarray(fx.prior.mean), start=[1, 2]),
         S, "start"),
    Case("block-inverse-shape", lambda fx: block_tridiagonal_inverse(np.zeros((3, 2, 2)), np.zeros((3, 2, 2))),
         S, "E"),
    Case("block-inverse-not-pd", lambda fx: block_tridiagonal_inverse(-np.tile(np.eye(2), (3, 1, 1)),
                                                                      np.zeros((2, 2, 2))), P, "state 0"),
    Case("sphere-clearance-q", lambda fx: sphere_clearance(fx.robot, None, np.zeros((3, 2))), RobotError, "q"),
    Case("plot-plan-3d-result", lambda fx: plot_plan_3d("result", fx.robot), T, "result"),
    Case("plot-plan-uncertainty-result", lambda fx: plot_plan_uncertainty(None), T, "result"),
    Case("animation-time", lambda fx: write_animation(fx.tmp / "a.html", fx.robot, [0, 1, 1],
                                                      np.zeros((3, fx.robot.n))), ClampError, "time"),
    Case("animation-q", lambda fx: write_animation(fx.tmp / "b.html", fx.robot, [0, 1, 2], np.zeros((3, 2))),
         ClampError, "q"),
    Case("to-joint-trajectory-robot", lambda fx: fx.result.to_joint_trajectory("jaco"), RobotError, "robot"),
    # --- initialisations
    Case("init-prior-mean-path", lambda fx: prior_mean_initialisation(fx.robot, np.zeros((5, 2)), 0.1,
                                                                       np.zeros(fx.robot.n)), S, "mean_path"),
    Case("init-prior-mean-dt", lambda fx: prior_mean_initialisation(fx.robot, np.zeros((5, 3)), 0.0,
                                                                    np.zeros(fx.robot.n)), P, "dt"),
    Case("init-prior-mean-goal", lambda fx: prior_mean_initialisation(fx.robot, np.zeros((5, 3)), 0.1,
                                                                      np.zeros(fx.robot.n), goal=[1, 2]), S, "goal"),
    Case("init-straight-q-last", lambda fx: straight_line_initialisation(fx.robot, np.zeros(fx.robot.n),
                                                                         np.zeros(2), 10, 0.1), S, "q_last"),
    Case("init-straight-T", lambda fx: straight_line_initialisation(fx.robot, np.zeros(fx.robot.n),
                                                                    np.zeros(fx.robot.n), 1, 0.1), P, "T"),
    # --- factor families (constructors)
    Case("family-joint-target-sigma", lambda fx: JointTargetFamily([0], np.zeros((1, 6)), [-1.0]), P, "sigma"),
    Case("family-workspace-gp-q", lambda fx: WorkspaceGPFamily(np.zeros((3, 6, 6)), np.zeros((3, 6)),
                                                               -np.ones((3, 6, 6))), P, "Q"),
    Case("family-workspace-start-mean", lambda fx: WorkspaceStartFamily(np.zeros(5), np.eye(6)), S, "mean"),
    Case("family-joint-gp-dt", lambda fx: JointGPFamily(10, 6, -0.1), P, "dt"),
    Case("family-joint-target-count", lambda fx: JointTargetFamily([0, 1], np.zeros((3, 6)), [1e-3] * 2), S,
         "targets"),
    Case("family-ee-position-shape", lambda fx: EEPositionFamily([0], np.zeros((1, 2)), [1e-3]), S, "targets"),
    Case("family-obstacle-epsilon", lambda fx: ObstacleFamily(np.arange(3), np.ones(4), Scene().query, -1.0,
                                                              0.01), P, "epsilon"),
    Case("family-joint-limits-order", lambda fx: JointLimitFamily(np.arange(3), np.ones(6), np.zeros(6),
                                                                  np.ones(6), 1e-3), P, "lower"),
    # --- clamp.validation helpers
    Case("validation-array-shape", lambda fx: as_array(np.zeros(4), "x", (3,)), S, "x"),
    Case("validation-scalar-bool", lambda fx: as_scalar(False, "sigma"), P, "sigma"),
    Case("validation-count", lambda fx: as_count(-2, "count"), P, "count"),
    Case("validation-time", lambda fx: as_time([0.0, 0.0], "time"), P, "time"),
]


def _write(fx, name: str, data: bytes):
    path = fx.tmp / name
    path.write_bytes(data)
    return path


@pytest.fixture(scope="module")
def fx(jaco, tmp_path_factory):
    prior = learn_prior(_demos())
    result = plan(prior, jaco, start=START, covariance=False)
    return SimpleNamespace(robot=jaco, prior=prior, result=result,
                           tmp=tmp_path_factory.mktemp("bad_clamp"))


@pytest.mark.parametrize("case", cases(CATALOGUE))
def test_bad_input(case: Case, fx) -> None:
    check(case, fx)


# ---------------------------------------------------------------- what a plan must report
def test_via_point_out_of_reach_fails_with_its_error(fx) -> None:
    """A via point 2 m away from the arm: success False before planning, the reason names the
    state and how far the target lies beyond the arm's reach (at least 1 m here)."""
    target = np.array([2.2, -0.4, 0.3])
    result = _plan(fx, via_points=[(15, target)])
    assert not result.success
    reason = next(r for r in result.reasons if "via point at state 15" in r)
    found = re.search(r"closest reach ([0-9.]+) mm away", reason)
    assert "out of reach" in reason and found and float(found.group(1)) > 1000.0


def test_joint_start_outside_limits_names_joint_and_excess(fx) -> None:
    robot = fx.robot
    q = robot.neutral_configuration()
    joint = int(np.flatnonzero(np.isfinite(robot.upper_limits))[0])
    q[joint] = robot.upper_limits[joint] + 0.3
    result = _plan(fx, start=q)
    assert not result.success
    text = " ".join(result.reasons)
    assert robot.joint_names[joint] in text and "0.3 rad above its upper limit" in text


def test_plan_limit_reason_names_the_worst_joint(fx) -> None:
    from clamp.limit_report import limit_violations
    robot = fx.robot
    q = np.tile(robot.neutral_configuration(), (5, 1))
    qdot = np.zeros_like(q)
    qdot[3, 2] = robot.velocity_limits[2] + 0.25
    reasons = limit_violations(robot, q, qdot, 0.0, 1e-3)
    assert len(reasons) == 1
    assert robot.joint_names[2] in reasons[0] and "0.25 rad/s" in reasons[0] and "state 3" in reasons[0]


@pytest.mark.parametrize("form", ["obstacle", "list", "path", "scene"])
def test_scene_forms_all_avoid_the_obstacle(fx, form, tmp_path) -> None:
    """A Box, [Box], a scene file path and a Scene give the same plan, which keeps clear of the
    box (the obstacle is never ignored: clearance is finite and measured on the box)."""
    mid = np.asarray(fx.prior.mean)[fx.prior.T // 2, :3]
    box = Box(mid, [0.06, 0.06, 0.06])
    path = tmp_path / "scene.json"
    Scene([box]).save(path)
    scene = {"obstacle": box, "list": [box], "path": str(path), "scene": Scene([box])}[form]
    result = _plan(fx, scene=scene)
    reference = _plan(fx, scene=Scene([box]))
    assert np.isfinite(result.min_clearance)
    assert result.min_clearance == pytest.approx(reference.min_clearance)
    centres, _ = fx.robot.sphere_centres(result.q)
    clearance = box.distance(centres) - fx.robot.spheres.radii
    assert result.min_clearance == pytest.approx(clearance.min())


def test_config_fields_by_name_are_kept() -> None:
    config = PlannerConfig(joint_limits=False, sigma_obs=0.01)
    assert config.model.joint_limits is False and config.model.sigma_obs == 0.01
    assert PlannerConfig(optimizer="gtsam").optimizer.optimizer == "gtsam"


def test_tiny_grid_cell_is_not_allocated_for_primitives(fx) -> None:
    """sdf_cell_size=1e-4 m (a 13 TiB grid over the default workspace) is a valid setting: a
    scene of primitives is queried exactly and never builds that grid; a grid asked for
    explicitly is refused before allocating, with its size."""
    box = Box(np.asarray(fx.prior.mean)[fx.prior.T // 2, :3], [0.06, 0.06, 0.06])
    fine = _plan(fx, scene=box, config=PlannerConfig(sdf_cell_size=1e-4))
    assert fine.min_clearance == pytest.approx(_plan(fx, scene=box).min_clearance)
    with pytest.raises(InvalidArgumentError, match="TiB|GiB"):
        Scene([box]).sdf(1e-4)
