"""Bad-input catalogue of ``clamp``: every public function of docs/interfaces.md fed bad
input answers with the project's error naming the argument (see tests/bad_input.py), and a
plan that misses what it was asked for says so with the numbers."""
from __future__ import annotations

import re

from types import SimpleNamespace

import numpy as np
import pytest

from bad_input import Case, cases, check, raises_naming
from clamp import PlannerConfig, build, learn_prior, plan, replan
from clamp.optim.stopping import StoppingRule
from clamp.viz.animation import write_animation
from clamp.batch.runner import LocalPool, plan_many, read_results
from clamp.batch.report import reason_key, summarize, summary_table
from clamp.prior.conditioning import condition_prior
from clamp.errors import (ClampTypeError, ClampError, DegenerateDemonstrationsError,
                          InsufficientDemonstrationsError, InvalidParameterError, NonFiniteError,
                          PriorFileError, ShapeError)
from clamp.factors import (EEPositionFamily, JointGPFamily, JointLimitFamily, JointTargetFamily,
                           ObstacleFamily, OrientationFamily, WorkspaceGPFamily,
                           WorkspaceStartFamily)
from clamp.planning.initialisation import prior_mean_initialisation, straight_line_initialisation
from clamp.prior.learning import check_spread, learn_joint_prior
from clamp.prior.obstacle_weighting import ObstacleWeighting, demonstration_weights
from clamp.optim.optimizers import optimize
from clamp.viz.plan_plots import (plot_clearance, plot_joint_angles, plot_orientation, plot_plan_3d,
                              plot_plan_uncertainty, plot_top_view)
from clamp.prior.plausibility import plausibility
from clamp.prior.linear_gaussian import WorkspacePrior
from clamp.viz.prior_plots import plot_prior_3d, plot_prior_time, plot_weighted_priors
from clamp.batch.problem_sets import across_robots, scene_benchmark, start_problems, start_region
from clamp.batch.problems import (Problem, ProblemFormatError, make_problem, read_problems,
                            write_problems)
from clamp.planning.request import make_request
from clamp.optim.uncertainty import block_tridiagonal_inverse
from clamp.validation import as_array, as_count, as_scalar, as_time
from clamp.planning.verdict import sphere_clearance
from robots.errors import RobotTypeError
from robots.errors import RobotError, UnknownRobotError
from scenes import Box, Demonstrations, Scene, make_demonstrations
from scenes.errors import InvalidArgumentError, InvalidObstacleError, SceneFileError

START = [0.2054, -0.4722, 0.2625]
SKILL = {"skill": "box_closing", "num_points": 30}
BOX = Box([0.3, -0.3, 0.2], [0.1, 0.1, 0.1])


def _demos():
    return make_demonstrations("box_closing", num_demos=4, num_points=30, seed=1)


def _plan(fx, **kwargs):
    kwargs.setdefault("start", START)
    kwargs.setdefault("covariance", False)
    return plan(fx.prior, fx.robot, **kwargs)


def _identical():
    d = _demos()
    return Demonstrations(np.repeat(d.positions[:1], 4, 0), np.repeat(d.velocities[:1], 4, 0), d.time)


def _incremental(fx):
    """A prior learned with method="incremental" (made once per module)."""
    if not hasattr(fx, "incremental"):
        fx.incremental = learn_prior(_demos(), method="incremental")
    return fx.incremental


def _request(fx):
    return make_request(fx.prior, fx.robot, START, None, (), PlannerConfig(),
                        np.asarray(fx.result.q[0]))


def _orientation():
    return OrientationFamily([1], tolerance=0.1, rotation=np.eye(3))


def _problem():
    return make_problem("p", SKILL, "jaco", START)


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


PF = ProblemFormatError
S, NF, P, T, I = ShapeError, NonFiniteError, InvalidParameterError, ClampTypeError, \
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
    Case("config-targets-text", lambda fx: PlannerConfig(condition_on_targets="no"), P,
         "condition_on_targets"),
    Case("config-removed-field", lambda fx: PlannerConfig(relative_error_tol=0.05), P,
         "relative_error_tol"),
    Case("config-removed-toggle", lambda fx: PlannerConfig().with_(obstacle_factors=False), P,
         "obstacle_factors"),
    Case("config-stopping-name", lambda fx: PlannerConfig(stopping="quick"), P, "stopping"),
    Case("config-stopping-rule", lambda fx: StoppingRule(relative_tol=-1.0), P,
         "stopping.relative_tol"),
    Case("config-unknown-field", lambda fx: PlannerConfig(sigma_obstacle=0.1), P, "sigma_obstacle"),
    Case("config-group-type", lambda fx: PlannerConfig(model={"epsilon": 0.1}), P, "config.model"),
    Case("config-sigma-negative", lambda fx: PlannerConfig().with_(sigma_obs=-1.0), P, "sigma_obs"),
    Case("config-epsilon-bool", lambda fx: PlannerConfig().with_(epsilon=True), P, "epsilon"),
    Case("config-max-iterations", lambda fx: PlannerConfig().with_(max_iterations=2.5), P, "max_iterations"),
    Case("config-optimizer", lambda fx: PlannerConfig(optimizer="lu"), P, "optimizer"),
    Case("config-initialisation", lambda fx: PlannerConfig().with_(initialisation="magic"), P,
         "initialisation"),
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
    # --- replanning (clamp.replan)
    Case("replan-previous-type", lambda fx: replan("plan.json", goal=START), T, "previous"),
    Case("replan-goal-shape", lambda fx: replan(fx.result, goal=[1, 2]), S, "goal"),
    Case("replan-goal-nan", lambda fx: replan(fx.result, goal=[np.nan, 0, 0]), NF, "goal"),
    Case("replan-scene-number", lambda fx: replan(fx.result, scene=42), T, "scene"),
    Case("replan-via-none", lambda fx: replan(fx.result, via_points=None), T, "via_points"),
    Case("replan-via-number", lambda fx: replan(fx.result, via_points=5), T, "via_points"),
    Case("replan-via-index", lambda fx: replan(fx.result, via_points=[(999, START)]), P, "via_points[0]"),
    Case("replan-config-dict", lambda fx: replan(fx.result, config={"sigma_obs": 0.01}), T, "config"),
    Case("replan-covariance-text", lambda fx: replan(fx.result, goal=[0.3, -0.3, 0.2], covariance="no"),
         P, "covariance"),
    # --- conditioning (clamp.prior.conditioning)
    Case("condition-prior-type", lambda fx: condition_prior("prior.npz", [(0, START)]), T, "prior"),
    Case("condition-index-range", lambda fx: condition_prior(fx.prior, [(99, START)]), P, "observations[0]"),
    Case("condition-index-float", lambda fx: condition_prior(fx.prior, [(1.5, START)]), P, "observations[0]"),
    Case("condition-index-bool", lambda fx: condition_prior(fx.prior, [(True, START)]), P, "observations[0]"),
    Case("condition-index-text", lambda fx: condition_prior(fx.prior, [("a", START)]), P, "observations[0]"),
    Case("condition-not-pair", lambda fx: condition_prior(fx.prior, [START]), S, "observations[0]"),
    Case("condition-none", lambda fx: condition_prior(fx.prior, None), T, "observations"),
    Case("condition-position-shape", lambda fx: condition_prior(fx.prior, [(0, [1, 2])]), S,
         "observations[0] position"),
    Case("condition-position-nan", lambda fx: condition_prior(fx.prior, [(0, [np.nan, 2, 3])]), NF,
         "observations[0] position"),
    Case("condition-position-1e200", lambda fx: condition_prior(fx.prior, [(0, [1e200, 0, 0])]), P,
         "observations[0] position"),
    Case("condition-sigma", lambda fx: condition_prior(fx.prior, [(0, START)], sigma=0), P, "sigma"),
    # --- obstacle weighting and learning modes
    Case("weighting-eps-negative", lambda fx: ObstacleWeighting(eps=-1), P, "eps"),
    Case("weighting-sigma-zero", lambda fx: ObstacleWeighting(sigma=0), P, "sigma"),
    Case("weighting-eps-text", lambda fx: ObstacleWeighting(eps="a"), P, "eps"),
    Case("weighting-distance-text", lambda fx: ObstacleWeighting().weight("abc"), S, "distance"),
    Case("weighting-distance-nan", lambda fx: ObstacleWeighting().weight([np.nan]), NF, "distance"),
    Case("demo-weights-positions", lambda fx: demonstration_weights(np.zeros((2, 3)), [[BOX]] * 2,
                                                                    ObstacleWeighting()), S, "positions"),
    Case("demo-weights-count", lambda fx: demonstration_weights(np.zeros((2, 3, 3)), [[BOX]] * 3,
                                                                ObstacleWeighting()), S, "obstacles"),
    Case("demo-weights-obstacle", lambda fx: demonstration_weights(np.zeros((2, 3, 3)), [["box"], []],
                                                                   ObstacleWeighting()),
         InvalidObstacleError, "obstacles[0]"),
    Case("demo-weights-weighting", lambda fx: demonstration_weights(np.zeros((2, 3, 3)), [[BOX]] * 2,
                                                                    {"eps": 0.1}), T, "weighting"),
    Case("learn-method", lambda fx: learn_prior(_demos(), method="online"), P, "method"),
    Case("learn-method-none", lambda fx: learn_prior(_demos(), method=None), P, "method"),
    Case("learn-weighting-text", lambda fx: learn_prior(_demos(), obstacle_weighting="yes"), P,
         "obstacle_weighting"),
    Case("learn-weighting-extra", lambda fx: learn_prior(_demos(), obstacle_weighting={"eps": 0.1, "x": 1}),
         P, "obstacle_weighting"),
    Case("learn-weighting-negative", lambda fx: learn_prior(_demos(), obstacle_weighting={"eps": -0.1}),
         P, "eps"),
    Case("update-batch-prior", lambda fx: fx.prior.update(_demos()), P, "prior"),
    Case("update-type", lambda fx: _incremental(fx).update("demos.mat"), S, "demos"),
    Case("update-none", lambda fx: _incremental(fx).update(None), P, "demos"),
    Case("update-steps", lambda fx: _incremental(fx).update(make_demonstrations(
        "box_closing", num_demos=4, num_points=20, seed=2)), S, "demos.positions"),
    Case("update-time", lambda fx: _incremental(fx).update(make_demonstrations(
        "box_closing", num_demos=4, num_points=30, dt=0.3, seed=2)), S, "demos.time"),
    Case("plot-weighted-prior", lambda fx: plot_weighted_priors("prior", fx.prior, _demos()), T,
         "unweighted"),
    Case("plot-weighted-demos", lambda fx: plot_weighted_priors(fx.prior, fx.prior, "demos"), S, "demos"),
    Case("plot-weighted-weights", lambda fx: plot_weighted_priors(fx.prior, fx.prior, _demos(),
                                                                  weights=np.zeros((2, 2))), S, "weights"),
    Case("plot-weighted-reference", lambda fx: plot_weighted_priors(fx.prior, fx.prior, _demos(),
                                                                    reference=np.zeros((2, 2))), S,
         "reference"),
    Case("plot-weighted-level", lambda fx: plot_weighted_priors(fx.prior, fx.prior, _demos(), level=2), P,
         "level"),
    Case("step-mahalanobis-shape", lambda fx: fx.prior.step_mahalanobis_squared(np.zeros((3, 6))), S, "x"),
    # --- orientation family
    Case("orientation-tolerance", lambda fx: OrientationFamily([1], tolerance=-1, rotation=np.eye(3)), P,
         "tolerance"),
    Case("orientation-both-targets", lambda fx: OrientationFamily([1], tolerance=0.1, axis=[0, 0, 1],
                                                                  direction=[0, 0, 1], rotation=np.eye(3)),
         P, "rotation"),
    Case("orientation-axis-zero", lambda fx: OrientationFamily([1], tolerance=0.1, axis=[0, 0, 0],
                                                               direction=[0, 0, 1]), P, "axis"),
    Case("orientation-direction-shape", lambda fx: OrientationFamily([1], tolerance=0.1, axis=[0, 0, 1],
                                                                     direction=[0, 1]), S, "direction"),
    Case("orientation-rotation", lambda fx: OrientationFamily([1], tolerance=0.1, rotation=2 * np.eye(3)),
         P, "rotation"),
    Case("orientation-indices-negative", lambda fx: OrientationFamily([-1], tolerance=0.1,
                                                                      rotation=np.eye(3)), P, "indices"),
    Case("orientation-indices-text", lambda fx: OrientationFamily("ab", tolerance=0.1, rotation=np.eye(3)),
         S, "indices"),
    Case("orientation-indices-float", lambda fx: OrientationFamily([1.5], tolerance=0.1,
                                                                   rotation=np.eye(3)), P, "indices"),
    Case("orientation-indices-empty", lambda fx: OrientationFamily([], tolerance=0.1, rotation=np.eye(3)),
         P, "indices"),
    Case("orientation-margin", lambda fx: OrientationFamily([1], tolerance=0.1, margin=0.2,
                                                            rotation=np.eye(3)), P, "margin"),
    Case("orientation-sigma", lambda fx: OrientationFamily([1], tolerance=0.1, sigma=0, rotation=np.eye(3)),
         P, "sigma"),
    Case("orientation-window-fraction", lambda fx: OrientationFamily.window(30, 1.5, tolerance=0.1,
                                                                            rotation=np.eye(3)), P, "fraction"),
    Case("orientation-window-fraction-zero", lambda fx: OrientationFamily.window(
        30, 0, tolerance=0.1, rotation=np.eye(3)), P, "fraction"),
    Case("orientation-window-states", lambda fx: OrientationFamily.window(-3, 0.5, tolerance=0.1,
                                                                          rotation=np.eye(3)), P, "num_states"),
    Case("orientation-window-states-text", lambda fx: OrientationFamily.window(
        "30", 0.5, tolerance=0.1, rotation=np.eye(3)), P, "num_states"),
    Case("orientation-window-states-float", lambda fx: OrientationFamily.window(
        30.5, 0.5, tolerance=0.1, rotation=np.eye(3)), P, "num_states"),
    Case("orientation-angles-robot", lambda fx: _orientation().angles("jaco", np.zeros((30, 6))), T, "robot"),
    Case("orientation-angles-q", lambda fx: _orientation().angles(fx.robot, np.zeros((30, 2))), S, "q"),
    Case("orientation-angles-short", lambda fx: OrientationFamily([10], tolerance=0.1, rotation=np.eye(
        3)).angles(fx.robot, np.zeros((3, fx.robot.n))), S, "q"),
    Case("orientation-violation-q", lambda fx: _orientation().violation(fx.robot, "q"), S, "q"),
    Case("orientation-plan-states", lambda fx: _plan(fx, extra_factors=[OrientationFamily(
        [99], tolerance=0.1, rotation=np.eye(3))]), P, "extra_factors[0]"),
    Case("plot-orientation-result", lambda fx: plot_orientation("plan", fx.robot, _orientation()), T,
         "result"),
    Case("plot-orientation-robot", lambda fx: plot_orientation(fx.result, "jaco", _orientation()), T,
         "robot"),
    Case("plot-orientation-family", lambda fx: plot_orientation(fx.result, fx.robot, "family"), T,
         "family"),
    # --- other plan figures
    Case("plot-plan-3d-robot", lambda fx: plot_plan_3d(fx.result, "jaco"), T, "robot"),
    Case("plot-plan-3d-scene", lambda fx: plot_plan_3d(fx.result, fx.robot, scene=42), T, "scene"),
    Case("plot-plan-3d-arm-states", lambda fx: plot_plan_3d(fx.result, fx.robot, arm_states=-1), P,
         "arm_states"),
    Case("plot-top-view-result", lambda fx: plot_top_view("plan", fx.robot), T, "result"),
    Case("plot-top-view-robot", lambda fx: plot_top_view(fx.result, "jaco"), T, "robot"),
    Case("plot-top-view-scene", lambda fx: plot_top_view(fx.result, fx.robot, scene=42), T, "scene"),
    Case("plot-top-view-arm-states", lambda fx: plot_top_view(fx.result, fx.robot, arm_states=2.5), P,
         "arm_states"),
    Case("plot-joint-angles-result", lambda fx: plot_joint_angles("plan", fx.robot), T, "result"),
    Case("plot-joint-angles-robot", lambda fx: plot_joint_angles(fx.result, "jaco"), T, "robot"),
    Case("plot-clearance-result", lambda fx: plot_clearance("plan", fx.robot, Scene([BOX]), 0.05), T,
         "result"),
    Case("plot-clearance-scene", lambda fx: plot_clearance(fx.result, fx.robot, 42, 0.05), T, "scene"),
    Case("plot-clearance-epsilon", lambda fx: plot_clearance(fx.result, fx.robot, Scene([BOX]), "a"), P,
         "epsilon"),
    Case("plot-clearance-epsilon-negative", lambda fx: plot_clearance(fx.result, fx.robot, Scene([BOX]),
                                                                      -1.0), P, "epsilon"),
    Case("sphere-clearance-scene", lambda fx: sphere_clearance(fx.robot, 42, np.zeros((3, fx.robot.n))), T,
         "scene"),
    # --- problem and configuration (clamp.graph.problem, clamp.config)
    Case("problem-values-shape", lambda fx: build(fx.prior, fx.robot, None, START).values(np.zeros((3, 3))),
         S, "theta"),
    Case("config-fast-unknown", lambda fx: PlannerConfig.fast(bogus=1), P, "bogus"),
    Case("config-fast-iterations", lambda fx: PlannerConfig.fast(max_iterations=-1), P, "max_iterations"),
    Case("check-spread-shape", lambda fx: check_spread(np.zeros((3, 2))), S, "states"),
    # --- problems as data (clamp.batch.problems)
    Case("problem-id-number", lambda fx: make_problem(5, SKILL, "jaco", START), PF, "id"),
    Case("problem-id-empty", lambda fx: make_problem("", SKILL, "jaco", START), PF, "id"),
    Case("problem-start-text", lambda fx: make_problem("a", SKILL, "jaco", "abc"), PF, "start"),
    Case("problem-start-none", lambda fx: make_problem("a", SKILL, "jaco", None), PF, "start"),
    Case("problem-start-number", lambda fx: make_problem("a", SKILL, "jaco", 5), PF, "start"),
    Case("problem-start-bools", lambda fx: make_problem("a", SKILL, "jaco", [True, False, True]), PF,
         "start"),
    Case("problem-goal-text", lambda fx: make_problem("a", SKILL, "jaco", START, goal="x"), PF, "goal"),
    Case("problem-via-number", lambda fx: make_problem("a", SKILL, "jaco", START, via_points=[5]), PF,
         "via_points[0]"),
    Case("problem-via-none", lambda fx: make_problem("a", SKILL, "jaco", START, via_points=None), T,
         "via_points"),
    Case("problem-via-index-text", lambda fx: make_problem("a", SKILL, "jaco", START,
                                                           via_points=[("a", START)]), PF, "via_points[0]"),
    Case("problem-config-text", lambda fx: make_problem("a", SKILL, "jaco", START, config="fast"), PF,
         "config"),
    Case("problem-meta-list", lambda fx: make_problem("a", SKILL, "jaco", START, meta=[1]), PF, "meta"),
    Case("problem-meta-object", lambda fx: make_problem("a", SKILL, "jaco", START, meta={"a": object()}),
         PF, "meta"),
    Case("problem-prior-text", lambda fx: make_problem("a", "prior.npz", "jaco", START), PF, "prior"),
    Case("problem-prior-two", lambda fx: make_problem("a", {"skill": "x", "path": "p"}, "jaco", START), PF,
         "prior"),
    Case("problem-prior-seed-text", lambda fx: make_problem("a", {"skill": "box_closing", "seed": "0"},
                                                            "jaco", START), PF, "seed"),
    Case("problem-robot-number", lambda fx: make_problem("a", SKILL, 5, START), PF, "robot"),
    Case("problem-robot-urdf-only", lambda fx: make_problem("a", SKILL, {"urdf": "a.urdf"}, START), PF,
         "robot"),
    Case("problem-scene-number", lambda fx: make_problem("a", SKILL, "jaco", START, scene=5), PF, "scene"),
    Case("problem-expected", lambda fx: make_problem("a", SKILL, "jaco", START, expected="yes"), PF,
         "expected"),
    Case("problem-expected-list", lambda fx: make_problem("a", SKILL, "jaco", START, expected=["feasible"]),
         PF, "expected"),
    Case("problem-dict-type", lambda fx: Problem.from_dict([1]), PF, "expected a JSON object"),
    Case("problem-dict-unknown", lambda fx: Problem.from_dict({**_problem().to_dict(), "colour": 1}), PF,
         "colour"),
    Case("problem-dict-missing", lambda fx: Problem.from_dict({"id": "a", "prior": SKILL}), PF, "robot"),
    Case("problem-dict-format", lambda fx: Problem.from_dict({**_problem().to_dict(), "format": ["x"]}), PF,
         "format"),
    Case("problem-dict-via-number", lambda fx: Problem.from_dict({**_problem().to_dict(), "via_points": 5}),
         PF, "via_points"),
    Case("problem-dict-config-list", lambda fx: Problem.from_dict({**_problem().to_dict(), "config": [1]}),
         PF, "config"),
    Case("problem-json-type", lambda fx: Problem.from_json(42), T, "problem"),
    Case("problem-json-invalid", lambda fx: Problem.from_json("{not json"), PF, "not valid JSON"),
    Case("problem-json-deep", lambda fx: Problem.from_json("[" * 100_000), PF, "not valid JSON"),
    Case("problem-json-bytes", lambda fx: Problem.from_json(b"\xff\xfe\x00"), PF, "not valid JSON"),
    Case("problem-replace-start", lambda fx: _problem().replace(start="x"), PF, "start"),
    Case("read-problems-type", lambda fx: read_problems(42), T, "path"),
    Case("read-problems-missing", lambda fx: read_problems(fx.tmp / "none.jsonl"), PF, "path"),
    Case("read-problems-directory", lambda fx: read_problems(fx.tmp), PF, "directory"),
    Case("read-problems-invalid", lambda fx: read_problems(_write(fx, "bad.jsonl", b"{not json\n")), PF,
         "bad.jsonl:1"),
    Case("read-problems-latin1", lambda fx: read_problems(_write(fx, "latin.jsonl", b"\xff\xfe{}\n")), PF,
         "latin.jsonl"),
    Case("read-problems-duplicate", lambda fx: read_problems(_write(
        fx, "dup.jsonl", 2 * (_problem().to_json() + "\n").encode())), PF, "problems[1]"),
    Case("write-problems-items", lambda fx: write_problems([1, 2], fx.tmp / "w.jsonl"), T, "problems[0]"),
    Case("write-problems-none", lambda fx: write_problems(None, fx.tmp / "w.jsonl"), T, "problems"),
    Case("write-problems-duplicate", lambda fx: write_problems([_problem()] * 2, fx.tmp / "w.jsonl"), PF,
         "problems[1]"),
    Case("write-problems-path", lambda fx: write_problems([_problem()], 42), T, "path"),
    Case("write-problems-exists", lambda fx: write_problems([_problem()], _write(fx, "old.jsonl", b"x\n")),
         PF, "already exists"),
    Case("write-problems-overwrite", lambda fx: write_problems([_problem()], fx.tmp / "w.jsonl",
                                                               overwrite="yes"), P, "overwrite"),
    # --- many plans (clamp.batch.runner, clamp.batch.problem_sets, clamp.batch.report)
    Case("plan-many-items", lambda fx: list(plan_many([1])), P, "problems[0]"),
    Case("plan-many-none", lambda fx: list(plan_many(None)), T, "problems"),
    Case("plan-many-duplicate", lambda fx: list(plan_many([_problem()] * 2)), PF, "problems[1]"),
    Case("plan-many-executor", lambda fx: list(plan_many([_problem()], executor="dask")), P, "executor"),
    Case("plan-many-workers", lambda fx: list(plan_many([_problem()], executor=0)), P, "workers"),
    Case("plan-many-retries", lambda fx: list(plan_many([_problem()], retries=-1)), P, "retries"),
    Case("plan-many-out-type", lambda fx: list(plan_many([_problem()], out=42)), T, "out"),
    Case("plan-many-out-folder", lambda fx: list(plan_many([_problem()], out=fx.tmp)), P, "out"),
    Case("plan-many-out-foreign", lambda fx: list(plan_many([_problem()], out=_write(
        fx, "foreign.jsonl", b"[1, 2]\n"))), PF, "foreign.jsonl:1"),
    Case("plan-many-out-not-results", lambda fx: list(plan_many([_problem()], out=_write(
        fx, "other.jsonl", b'{"a": 1}\n'))), P, "out"),
    Case("plan-many-base-dir", lambda fx: list(plan_many([_problem()], base_dir=42)), T, "base_dir"),
    Case("plan-many-trajectories-type", lambda fx: list(plan_many([_problem()], trajectories=42)), T,
         "trajectories"),
    Case("plan-many-trajectories-file", lambda fx: list(plan_many([_problem()], trajectories=_write(
        fx, "traj.json", b"{}"))), P, "trajectories"),
    Case("local-pool-workers", lambda fx: LocalPool(0), P, "workers"),
    Case("local-pool-workers-text", lambda fx: LocalPool("2"), P, "workers"),
    Case("read-results-type", lambda fx: read_results(42), T, "path"),
    Case("read-results-missing", lambda fx: read_results(fx.tmp / "none.jsonl"), PF, "path"),
    Case("read-results-directory", lambda fx: read_results(fx.tmp), PF, "directory"),
    Case("read-results-invalid", lambda fx: read_results(_write(fx, "rbad.jsonl", b"{not json\n")), PF,
         "rbad.jsonl:1"),
    Case("read-results-list", lambda fx: read_results(_write(fx, "rlist.jsonl", b"[1, 2]\n")), PF,
         "rlist.jsonl:1"),
    Case("read-results-latin1", lambda fx: read_results(_write(fx, "rlatin.jsonl", b"\xff\xfe{}\n")), PF,
         "rlatin.jsonl:1"),
    Case("start-region-prior", lambda fx: start_region("prior"), T, "prior"),
    Case("start-region-scale", lambda fx: start_region(fx.prior, scale=0), P, "scale"),
    Case("start-region-width", lambda fx: start_region(fx.prior, min_half_width=-1), P, "min_half_width"),
    Case("start-problems-base", lambda fx: start_problems("base", 3), T, "base"),
    Case("start-problems-both", lambda fx: start_problems(_problem(), 3, grid=2), P, "count"),
    Case("start-problems-count", lambda fx: start_problems(_problem(), 0), P, "count"),
    Case("start-problems-grid", lambda fx: start_problems(_problem(), grid=0), P, "grid"),
    Case("start-problems-seed", lambda fx: start_problems(_problem(), 3, seed=-1), P, "seed"),
    Case("start-problems-seed-text", lambda fx: start_problems(_problem(), 3, seed="a"), P, "seed"),
    Case("start-problems-base-dir", lambda fx: start_problems(_problem(), 3, base_dir=42), T, "base_dir"),
    Case("across-robots-problem", lambda fx: across_robots("p", ["jaco"]), T, "problem"),
    Case("across-robots-text", lambda fx: across_robots(_problem(), "jaco"), T, "robots"),
    Case("across-robots-item", lambda fx: across_robots(_problem(), [5]), T, "robots[0]"),
    Case("across-robots-joint-start", lambda fx: across_robots(_problem().replace(start=[0.0] * 6),
                                                               ["jaco"]), P, "start"),
    Case("scene-benchmark-count", lambda fx: scene_benchmark(0), P, "count"),
    Case("scene-benchmark-robot", lambda fx: scene_benchmark(1, robot="ur5"), UnknownRobotError, "ur5"),
    Case("scene-benchmark-robot-list", lambda fx: scene_benchmark(1, robot=["jaco"]), RobotTypeError, "name"),
    Case("scene-benchmark-seed", lambda fx: scene_benchmark(1, seed=-1), P, "seed"),
    Case("scene-benchmark-skills-text", lambda fx: scene_benchmark(1, skills="box_closing"), T, "skills"),
    Case("scene-benchmark-skills-empty", lambda fx: scene_benchmark(1, skills=[]), P, "skills"),
    Case("scene-benchmark-skills-unknown", lambda fx: scene_benchmark(1, skills=["nope"]), P, "skills"),
    Case("scene-benchmark-share", lambda fx: scene_benchmark(1, impossible_share=2), P, "impossible_share"),
    Case("scene-benchmark-points", lambda fx: scene_benchmark(1, num_points=1), P, "num_points"),
    Case("scene-benchmark-obstacles-order", lambda fx: scene_benchmark(1, obstacles=(3, 1)), P,
         "obstacles[1]"),
    Case("scene-benchmark-obstacles-negative", lambda fx: scene_benchmark(1, obstacles=(-1, 1)), P,
         "obstacles[0]"),
    Case("scene-benchmark-obstacles-text", lambda fx: scene_benchmark(1, obstacles="ab"), T, "obstacles"),
    Case("scene-benchmark-obstacles-triple", lambda fx: scene_benchmark(1, obstacles=(1, 2, 3)), P,
         "obstacles"),
    Case("scene-benchmark-offset", lambda fx: scene_benchmark(1, start_offset=-1), P, "start_offset"),
    Case("scene-benchmark-near", lambda fx: scene_benchmark(1, near=0), P, "near"),
    Case("scene-benchmark-config", lambda fx: scene_benchmark(1, config="fast"), T, "config"),
    Case("summarize-records", lambda fx: summarize(5), T, "records"),
    Case("summarize-record-type", lambda fx: summarize([1, 2]), T, "records[0]"),
    Case("summarize-status", lambda fx: summarize([{"status": "maybe"}]), P, "records[0].status"),
    Case("summarize-missing-timings", lambda fx: summarize([{"status": "done", "success": True,
                                                             "reasons": []}]), P, "records[0]"),
    Case("summary-table-type", lambda fx: summary_table("summary"), T, "summary"),
    Case("summary-table-missing", lambda fx: summary_table({"problems": 1}), P, "summary"),
    Case("reason-key-type", lambda fx: reason_key(5), T, "reason"),
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
    from clamp.planning.limit_report import limit_violations
    robot = fx.robot
    q = np.tile(robot.neutral_configuration(), (5, 1))
    qdot = np.zeros_like(q)
    qdot[3, 2] = robot.velocity_limits[2] + 0.25
    reasons = limit_violations(robot, q, qdot, 0.0, 1e-3)
    assert len(reasons) == 1
    assert robot.joint_names[2] in reasons[0] and "0.25 rad/s" in reasons[0] and "state 3" in reasons[0]


def test_plan_limit_reason_sees_velocities_between_states(fx) -> None:
    """Velocities within the limit at every state, but a joint that moves 0.5 rad in 0.1 s
    between two of them: beyond its limit there (the verdict's check, with the time)."""
    from clamp.planning.limit_report import limit_violations
    robot = fx.robot
    q = np.tile(robot.neutral_configuration(), (5, 1))
    q[3:, 1] += 0.5
    qdot = np.zeros_like(q)
    time = 0.1 * np.arange(5)
    assert limit_violations(robot, q, qdot, 0.0, 1e-3) == []            # the states alone
    reasons = limit_violations(robot, q, qdot, 0.0, 1e-3, time=time)
    assert len(reasons) == 1 and robot.joint_names[1] in reasons[0]
    assert "between states 2 and 3" in reasons[0]
    peak = 1.5 * 0.5 / 0.1                        # a cubic from rest to rest: 1.5 x the mean
    assert f"{peak - robot.velocity_limits[1]:.4g} rad/s" in reasons[0]


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
    np.testing.assert_allclose(result.q, reference.q)
    centres, _ = fx.robot.sphere_centres(result.q)       # the box shaped the plan: without it
    clearance = box.distance(centres) - fx.robot.spheres.radii      # no obstacle hinge acts
    assert result.family_errors.get("obstacle") is not None and np.isfinite(clearance.min())


def test_config_fields_by_name_are_kept() -> None:
    config = PlannerConfig(condition_on_targets=False, sigma_obs=0.01, stopping="fast")
    assert config.model.condition_on_targets is False and config.model.sigma_obs == 0.01
    assert config.optimizer.stopping_rule() == PlannerConfig.fast().optimizer.stopping_rule()
    assert PlannerConfig(optimizer="gtsam").optimizer.optimizer == "gtsam"


def test_a_removed_setting_is_refused_with_where_it_went() -> None:
    """A config (e.g. an older saved problem file) naming a setting issue 36 removed is refused,
    never silently planned differently; the message says what replaces it."""
    for name, value, replacement in (("relative_error_tol", 0.05, "stopping"),
                                     ("obstacle_factors", False, "scene=None"),
                                     ("velocity_margin", 0.0, "VELOCITY_MARGIN"),
                                     ("sdf_cell_size", 0.005, "scene.sdf(cell_size)")):
        with raises_naming(InvalidParameterError, name, replacement):
            PlannerConfig(**{name: value})
        with raises_naming(InvalidParameterError, name, replacement):
            PlannerConfig().with_(**{name: value})


def test_tiny_grid_cell_is_not_allocated_for_primitives(fx) -> None:
    """A scene of primitives is queried exactly: planning in it builds no grid; a grid of 1e-4 m
    cells (13 TiB over the default workspace, what a caller passes as ``sdf``) is refused before
    allocating, with its size."""
    box = Box(np.asarray(fx.prior.mean)[fx.prior.T // 2, :3], [0.06, 0.06, 0.06])
    scene = Scene([box])
    assert np.isfinite(_plan(fx, scene=scene).min_clearance)
    assert not scene._grids
    with raises_naming(InvalidArgumentError, "cell_size", "(15001, 15001, 8001)"):
        Scene([box]).sdf(1e-4)
