"""The learned skill: a linear Gaussian chain over workspace states learned from demonstrations
(:mod:`.learning`, incrementally :mod:`.conjugate`, obstacle-aware weighting
:mod:`.obstacle_weighting`), conditioned on what a plan is asked (:mod:`.conditioning`), the
skill's region and checks (:mod:`.skill`) and the calibrated plausibility of a path
(:mod:`.plausibility`); the chain's Gaussian algebra (compositions, marginals, filter and
smoother, backward messages) is :mod:`.chain`. Knows nothing of robots' planning problems or
solvers."""
from clamp.prior.linear_gaussian import LinearGaussianPrior, WorkspacePrior
from clamp.prior.orientation_prior import OrientationPrior

__all__ = ["LinearGaussianPrior", "WorkspacePrior", "OrientationPrior"]
