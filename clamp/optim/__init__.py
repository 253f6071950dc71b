"""Solving a planning problem: the banded Levenberg-Marquardt on the state array
(:mod:`.solver`, :mod:`.banded`), GTSAM's optimizers on the graph (:mod:`.optimizers`), the
constrained (augmented-Lagrangian) solve (:mod:`.constrained`) and the Laplace covariance of an
optimum (:mod:`.uncertainty`)."""
