"""Learned linear-Gaussian trajectory priors (CLAMP paper, section 4, eq. 8 and 11).

A prior over T support states x_0 .. x_{T-1} (each a D-vector ``[positions, velocities]``):

    x_0     ~ N(mean0, cov0)
    x_{i+1} = Phi_i x_i + u_i + w_i,     w_i ~ N(0, Q_i),     i = 0 .. T-2

is a Gaussian process over the support states with a block-tridiagonal precision. Its
marginal means and covariances follow by the O(T) recursion

    mean_{i+1} = Phi_i mean_i + u_i,     cov_{i+1} = Phi_i cov_i Phi_i^T + Q_i,

which is eq. (8) evaluated block by block, never forming the dense (D T)^2 covariance
(:func:`clamp.prior.chain.marginals`; the chain's algebra is all in :mod:`clamp.prior.chain`).

:class:`LinearGaussianPrior` is generic in the number of axes (a joint-space prior for an
n-joint arm has D = 2n); :class:`WorkspacePrior` is the end-effector workspace prior of CLAMP
with D = 6, state ``[px, py, pz, vx, vy, vz]`` (metres, metres per second).
"""
from __future__ import annotations

import copy
import json
import os
import zipfile
from pathlib import Path
from typing import Any, ClassVar, cast

import numpy as np
from scipy import special   # chdtrc, ndtri: scipy.stats' chi2.sf and norm.ppf, without loading scipy.stats (a second)

from clamp.prior import chain
from clamp.prior.conjugate import POSTERIOR_KEYS, ConjugatePosterior
from clamp.prior.demonstration_states import (assemble_blocks, block_covariance, demo_arrays,
                                              sample_weights, stack_states)
from clamp.prior.obstacle_weighting import ObstacleWeighting
from clamp.prior.skill import SkillRegion
from clamp.errors import ClampTypeError, InvalidParameterError, PriorFileError, ShapeError
from clamp.validation import as_array, as_count, as_scalar, as_time, cholesky, is_symmetric
from skillplan.command_line import atomic_write
from skillplan.validation import as_file, as_path

#: name of the saved prior's file format (the ``format`` entry is ``NAME/VERSION``)
FILE_FORMAT_NAME = "clamp-linear-gaussian-prior"
#: the newest layout this version writes and reads: ``time, Phi, u, Q, mean0, cov0`` arrays, ``kind``,
#: ``state_names``, ``info`` (JSON) and the optional ``posterior_*`` entries. A file without a
#: ``format`` entry is read as version 1 when it holds those arrays (kind, state names and info
#: then take their defaults).
FILE_FORMAT_VERSION = 1
FILE_FORMAT = f"{FILE_FORMAT_NAME}/{FILE_FORMAT_VERSION}"
_ARRAY_KEYS = ("time", "Phi", "u", "Q", "mean0", "cov0")
_JITTER_HINT = " (learn with a larger jitter)"


def _frozen(arr: np.ndarray) -> np.ndarray:
    """Read-only copy: a prior's parameters and cached marginals must stay consistent."""
    out = np.array(arr, dtype=np.float64, copy=True)
    out.flags.writeable = False
    return out


def envelope_quantile(level: float) -> float:
    """Two-sided standard normal quantile z of a probability ``level`` in (0, 1) (1.96 for
    0.95): a Gaussian coordinate lies within mean -+ z sigma with probability ``level``."""
    level = as_scalar(level, "level", strictly_positive=True)
    if level >= 1.0:
        raise InvalidParameterError(f"level: expected a probability in (0, 1), got {level}")
    return float(special.ndtri(0.5 + 0.5 * level))



def transition_residuals(Phi: np.ndarray, u: np.ndarray, x_prev: np.ndarray,
                         x_next: np.ndarray) -> np.ndarray:
    """Transition residuals x_{i+1} - Phi_i x_i - u_i (..., K, D) of the linear Gaussian prior.

    Phi (K, D, D), u (K, D); x_prev, x_next (..., K, D) the states before and after each of the
    K transitions. The one definition used by the prior's likelihood and by the planner's
    workspace GP factors.
    """
    return x_next - np.einsum("kij,...kj->...ki", Phi, x_prev) - u

#: prefix of a workspace prior file's orientation entries (``orientation_Phi``, ...,
#: ``orientation_info``, ``orientation_posterior_*``): the orientation chain of a pose prior
#: (:mod:`clamp.prior.orientation_prior`), absent for a position-only prior. Optional entries
#: of version 1: a reader that predates them loads the position prior alone.
ORIENTATION_PREFIX = "orientation_"


def _orientation_part(path: Path, contents: dict[str, np.ndarray]) -> LinearGaussianPrior:
    """The orientation chain stored in a prior file's ``orientation_*`` entries."""
    OrientationPrior = LinearGaussianPrior.of_kind("orientation")
    part = {k[len(ORIENTATION_PREFIX):]: v for k, v in contents.items()
            if k.startswith(ORIENTATION_PREFIX)}
    missing = [ORIENTATION_PREFIX + k for k in (*_ARRAY_KEYS[1:], "info") if k not in part]
    if missing:
        raise PriorFileError(f"path: '{path}' has an incomplete orientation prior (lacks "
                             f"{missing})")
    try:
        info = json.loads(str(part["info"]))
        posterior = None
        if "posterior_factor" in part:
            posterior = ConjugatePosterior.from_arrays(
                {k: part[f"posterior_{k}"] for k in POSTERIOR_KEYS})
        return OrientationPrior(contents["time"], *(part[k] for k in _ARRAY_KEYS[1:]),
                                info=info, posterior=posterior)
    except (KeyError, json.JSONDecodeError, ShapeError, InvalidParameterError,
            ValueError) as exc:
        raise PriorFileError(f"path: '{path}' holds an invalid orientation prior: {exc}") \
            from None


def _file_version(path: Path, contents: dict[str, np.ndarray]) -> int | None:
    """The format version of a prior file's ``format`` entry (``NAME/VERSION``), None when the
    file has none (the layout before the entry, read as version 1). PriorFileError naming the
    file for another format and for a version newer than :data:`FILE_FORMAT_VERSION`."""
    if "format" not in contents:
        return None
    fmt = str(contents["format"])
    name, _, version = fmt.rpartition("/")
    if name != FILE_FORMAT_NAME or not version.isdigit() or int(version) < 1:
        raise PriorFileError(f"path: '{path}' has format '{fmt}', expected '{FILE_FORMAT}' (not a "
                             "CLAMP prior file)")
    if int(version) > FILE_FORMAT_VERSION:
        raise PriorFileError(f"path: '{path}' has format version {int(version)} ('{fmt}'), newer than "
                             f"this version reads (up to {FILE_FORMAT_VERSION}): update skillplan, or "
                             "learn and save the prior again with this version")
    return int(version)


class LinearGaussianPrior:
    """Discrete linear-Gaussian (LTV-SDE) trajectory prior over T support states of size D.

    Attributes (float64 arrays):
        time (T,) s; dt float (median step, s: the nominal step of recordings with a few
        irregular stamps, as scenes.Demonstrations.dt); T, D ints; num_axes = D // 2;
        Phi (T-1, D, D) transition matrices; u (T-1, D) biases; Q (T-1, D, D) process noise;
        mean0 (D,), cov0 (D, D) initial state; mean (T, D), cov (T, D, D) marginals;
        state_names tuple of D strings; kind str ("workspace", "joint", ...);
        info dict of JSON-serialisable learning settings (ridge, jitter, coupled, ...);
        posterior: the conjugate posterior (clamp.prior.conjugate.ConjugatePosterior) of a prior
        learned with method="incremental" (None otherwise), saved with it.
    The arrays are read-only copies (the marginals are cached from the parameters).
    The state is ordered ``[positions (D/2), velocities (D/2)]``.
    """

    default_kind: ClassVar[str] = "generic"
    #: the subclass of every kind (a subclass registers itself by its default_kind)
    _KINDS: ClassVar[dict[str, type["LinearGaussianPrior"]]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        LinearGaussianPrior._KINDS[cls.default_kind] = cls

    @staticmethod
    def of_kind(kind: str) -> type["LinearGaussianPrior"]:
        """The prior class of ``kind`` ("workspace", "orientation", ...; registered when its
        module was imported, as ``clamp.prior`` imports them all)."""
        return LinearGaussianPrior._KINDS.get(kind, LinearGaussianPrior)

    def __init__(self, time: np.ndarray, Phi: np.ndarray, u: np.ndarray, Q: np.ndarray,
                 mean0: np.ndarray, cov0: np.ndarray, *, state_names: tuple[str, ...] | None = None,
                 kind: str | None = None, info: dict[str, Any] | None = None,
                 posterior: ConjugatePosterior | None = None) -> None:
        Phi = as_array(Phi, "Phi", (None, "D", "D"))
        steps, D = Phi.shape[0], Phi.shape[1]
        if steps < 1:
            raise ShapeError("Phi: expected at least one transition (T >= 2), got shape "
                             f"{Phi.shape}")
        if D % 2:
            raise ShapeError(f"Phi: expected an even state size D = 2 * axes "
                             f"([positions, velocities]), got D = {D}")
        self.time = _frozen(as_time(time, "time", steps + 1))
        self.Phi = _frozen(Phi)
        self.u = _frozen(as_array(u, "u", (steps, D)))
        self.Q = _frozen(as_array(Q, "Q", (steps, D, D)))
        self.mean0 = _frozen(as_array(mean0, "mean0", (D,)))
        self.cov0 = _frozen(as_array(cov0, "cov0", (D, D)))
        for name, cov in (("Q", self.Q), ("cov0", self.cov0)):
            if not is_symmetric(cov):
                raise InvalidParameterError(f"{name}: expected symmetric covariance matrices")
        self.T, self.D = steps + 1, D
        self.num_axes = D // 2
        self.dt = float(np.median(np.diff(self.time)))
        self.kind = str(kind or self.default_kind)
        self.info = dict(info or {})
        self.posterior = posterior
        if state_names is None:
            state_names = self._default_state_names()
        if len(state_names) != D:
            raise ShapeError(f"state_names: expected {D} names, got {len(state_names)}")
        self.state_names = tuple(str(s) for s in state_names)
        # Whitening factors: L L^T = cov, W = L^{-1}, so ||W r||^2 is the squared Mahalanobis.
        chol_Q = cholesky(self.Q, "Q", _JITTER_HINT)
        chol_0 = cholesky(self.cov0, "cov0", _JITTER_HINT)
        eye = np.eye(D)
        self._white_Q = np.linalg.solve(chol_Q, np.broadcast_to(eye, chol_Q.shape))
        self._white_0 = np.linalg.solve(chol_0, eye)
        self._chol_Q, self._chol_0 = chol_Q, chol_0
        self._logdet_Q = 2.0 * np.log(np.diagonal(chol_Q, axis1=1, axis2=2)).sum(axis=1)
        self._logdet_0 = 2.0 * float(np.log(np.diag(chol_0)).sum())
        self.mean, self.cov = (_frozen(a) for a in self._marginals())

    def with_offsets(self, u: Any, mean0: Any, info: dict[str, Any] | None = None
                     ) -> "LinearGaussianPrior":
        """This chain with the offsets ``u`` (T-1, D) and initial mean ``mean0`` (D,) instead
        (``info`` instead too, when given): Phi, Q, cov0, their whitening and the marginal
        covariances, none of which depends on them, are shared; the marginal means are carried
        forward, mean_{i+1} = Phi_i mean_i + u_i (to rounding, the scan's). Same class."""
        u = as_array(u, "u", (self.T - 1, self.D))
        mean0 = as_array(mean0, "mean0", (self.D,))
        return self._with(u, mean0, chain.forward_means(self.Phi, u, mean0), info)

    def with_means(self, mean: Any, info: dict[str, Any] | None = None
                   ) -> "LinearGaussianPrior":
        """This chain with the marginal means ``mean`` (T, D) instead: the offsets that carry
        them, u_i = mean_{i+1} - Phi_i mean_i, and mean0 = mean_0 (``info`` instead too, when
        given); everything else shared as in :meth:`with_offsets`. Same class."""
        mean = as_array(mean, "mean", (self.T, self.D))
        u = mean[1:] - np.einsum("tij,tj->ti", self.Phi, mean[:-1])
        return self._with(u, mean[0], mean, info)

    def _with(self, u: np.ndarray, mean0: np.ndarray, mean: np.ndarray,
              info: dict[str, Any] | None) -> "LinearGaussianPrior":
        new = copy.copy(self)
        new.u, new.mean0, new.mean = _frozen(u), _frozen(mean0), _frozen(mean)
        new.info = dict(self.info if info is None else info)
        return new

    def _default_state_names(self) -> tuple[str, ...]:
        n = self.num_axes
        return tuple(f"x{k}" for k in range(n)) + tuple(f"xdot{k}" for k in range(n))

    # ------------------------------------------------------------------ marginals
    def _marginals(self) -> tuple[np.ndarray, np.ndarray]:
        """Marginal means (T, D) and covariances (T, D, D) of eq. (8), O(T log T) work
        (:func:`clamp.prior.chain.marginals`: a log-depth prefix scan of the steps)."""
        return chain.marginals(self.Phi, self.u, self.Q, self.mean0, self.cov0)

    @property
    def std(self) -> np.ndarray:
        """Marginal standard deviation of every coordinate, (T, D)."""
        return np.sqrt(np.diagonal(self.cov, axis1=1, axis2=2))

    def envelope(self, level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
        """Per-coordinate marginal envelope ``mean -+ z sigma`` with z = 1.96 for level 0.95.

        Returns (lower, upper), each (T, D): each coordinate lies inside its band with
        probability ``level`` under the prior (marginally, one coordinate at a time).
        """
        half = envelope_quantile(level) * self.std
        return self.mean - half, self.mean + half

    # ------------------------------------------------------------------ sampling
    def sample(self, count: int, rng: np.random.Generator | int) -> np.ndarray:
        """Draw ``count`` trajectories (count, T, D) by simulating the discrete LTV-SDE.

        ``rng`` is a numpy Generator or an integer seed.
        """
        count = as_count(count, "count")
        if isinstance(rng, (int, np.integer)) and not isinstance(rng, bool):
            rng = np.random.default_rng(int(rng))
        if not isinstance(rng, np.random.Generator):
            raise InvalidParameterError(f"rng: expected a numpy.random.Generator or an int seed, "
                                        f"got {type(rng).__name__}")
        noise = rng.standard_normal((count, self.T, self.D))
        x = np.empty((count, self.T, self.D))
        x[:, 0] = self.mean0 + noise[:, 0] @ self._chol_0.T
        for i in range(self.T - 1):
            x[:, i + 1] = x[:, i] @ self.Phi[i].T + self.u[i] + noise[:, i + 1] @ self._chol_Q[i].T
        return x

    # ------------------------------------------------------------------ densities
    def _as_trajectories(self, x: object, name: str = "x") -> tuple[np.ndarray, bool]:
        """x (T, D) or (K, T, D) -> ((K, T, D) array, whether a single trajectory was given)."""
        try:
            ndim = np.ndim(x)
        except ValueError:  # ragged nested sequences
            ndim = -1
        if ndim == 2:
            return as_array(x, name, (self.T, self.D))[None], True
        return as_array(x, name, (None, self.T, self.D)), False

    def _residuals(self, xs: np.ndarray) -> np.ndarray:
        """x_{i+1} - Phi_i x_i - u_i (K, T-1, D) of validated trajectories xs (K, T, D)."""
        return transition_residuals(self.Phi, self.u, xs[:, :-1], xs[:, 1:])

    def transition_residuals(self, x: np.ndarray) -> np.ndarray:
        """Residuals ``x_{i+1} - Phi_i x_i - u_i`` of trajectories x (T, D) or (K, T, D).

        Returns (T-1, D) or (K, T-1, D).
        """
        xs, single = self._as_trajectories(x)
        r = self._residuals(xs)
        return r[0] if single else r

    def step_mahalanobis_squared(self, x: np.ndarray) -> np.ndarray:
        """Squared Mahalanobis distance of every factor of the prior, (T,) or (K, T).

        Entry 0 is the initial term ``(x_0 - mean0)^T cov0^{-1} (x_0 - mean0)``; entry i >= 1
        is the transition i-1 -> i, ``r^T Q_{i-1}^{-1} r``. Under the prior each entry is
        chi-square distributed with D degrees of freedom, independently of the others.
        """
        xs, single = self._as_trajectories(x)
        white = np.einsum("tij,ktj->kti", self._white_Q, self._residuals(xs))
        white0 = (xs[:, 0] - self.mean0) @ self._white_0.T
        d2 = np.concatenate([np.sum(white0**2, axis=-1)[:, None], np.sum(white**2, axis=-1)],
                            axis=1)
        return d2[0] if single else d2

    def mahalanobis(self, x: np.ndarray, initial: bool = True) -> float | np.ndarray:
        """Mahalanobis distance of trajectories x (T, D) or (K, T, D) from the prior.

        ``sqrt(sum of step_mahalanobis_squared)``; with ``initial=False`` the initial-state
        term is left out (for plans that start away from the demonstrations).
        """
        d2 = self.step_mahalanobis_squared(x)
        d2 = d2 if initial else d2[..., 1:]
        out = np.sqrt(d2.sum(axis=-1))
        return float(out) if out.ndim == 0 else out

    def degrees_of_freedom(self, initial: bool = True) -> int:
        """Number of scalar Gaussian terms in the density: D T, or D (T-1) without initial."""
        return self.D * (self.T if initial else self.T - 1)

    def log_likelihood(self, x: np.ndarray, initial: bool = True) -> float | np.ndarray:
        """Log density of trajectories x (T, D) or (K, T, D) under the prior.

        Sum over the transitions i -> i+1 of ``log N(x_{i+1}; Phi_i x_i + u_i, Q_i)`` plus, if
        ``initial``, ``log N(x_0; mean0, cov0)``. Returns a float or (K,).
        """
        d2 = self.step_mahalanobis_squared(x)
        logdet = np.concatenate([[self._logdet_0], self._logdet_Q])
        terms = -0.5 * (d2 + logdet + self.D * np.log(2.0 * np.pi))
        terms = terms if initial else terms[..., 1:]
        out = terms.sum(axis=-1)
        return float(out) if out.ndim == 0 else out

    def success_probability(self, x: np.ndarray, initial: bool = False) -> float | np.ndarray:
        """Demonstration-based success likelihood of a plan x (T, D) (paper, section 6).

        Defined as the chi-square tail probability ``P(chi2_k >= d^2)`` of the plan's squared
        Mahalanobis distance d^2 (see :meth:`mahalanobis`) with k = :meth:`degrees_of_freedom`:
        the fraction of trajectories drawn from the prior that are *less* typical than x.
        It is calibrated: for trajectories drawn from the prior it is uniform on [0, 1], so
        rejecting plans below ``alpha`` rejects a fraction ``alpha`` of prior-like motions.
        ``initial=False`` (default) scores the shape of the motion only, not its start.
        Returns a float or (K,) for x (K, T, D).
        """
        d2 = self.step_mahalanobis_squared(x)
        d2 = d2 if initial else d2[..., 1:]
        out = special.chdtrc(self.degrees_of_freedom(initial), d2.sum(axis=-1))
        return float(out) if np.ndim(out) == 0 else np.asarray(out)

    def step_success_probabilities(self, x: np.ndarray) -> np.ndarray:
        """Per-factor tail probabilities ``P(chi2_D >= d_i^2)``, (T,) or (K, T).

        Entry 0 scores the initial state, entry i the transition i-1 -> i; each is uniform on
        [0, 1] under the prior, so small entries locate where a plan leaves the skill.
        """
        return special.chdtrc(self.D, self.step_mahalanobis_squared(x))

    # ------------------------------------------------------------------ learning on
    @classmethod
    def from_posterior(cls, posterior: ConjugatePosterior, time: np.ndarray, jitter: float, *,
                       kind: str | None = None, state_names: tuple[str, ...] | None = None,
                       info: dict[str, Any] | None = None) -> LinearGaussianPrior:
        """The prior of a conjugate posterior (:mod:`clamp.prior.conjugate`): posterior mean
        transitions, MAP noise S / (N + k + 1) plus jitter, weighted mean and covariance of
        the first states (floored where the demonstrations agree, as in batch learning)."""
        D = len(posterior.first_mean)
        Phi, u, Q = assemble_blocks(*posterior.transitions(), posterior.groups, D, jitter,
                                    posterior.next_variance())
        mean0, full0 = posterior.initial()
        cov0 = block_covariance(full0, posterior.groups, jitter)
        return cls(time, Phi, u, Q, mean0, cov0, kind=kind, info=info,
                   state_names=state_names, posterior=posterior)

    def update(self, demos: Any) -> LinearGaussianPrior:
        """A new prior that has also learned from ``demos`` (a scenes.Demonstrations, or
        anything with positions / velocities (M, T, A) and time (T,) on this prior's steps),
        by the conjugate update of :mod:`clamp.prior.conjugate`; needs a prior learned with
        method="incremental" (or loaded from its file). Weighted like the original when it
        was learned with obstacle_weighting. This prior is unchanged."""
        posterior = self.posterior
        if posterior is None:
            raise InvalidParameterError(f"prior: learned with method="
                                        f"{self.info.get('method', 'batch')!r}; only a prior "
                                        "learned with method='incremental' keeps the "
                                        "posterior that update() continues from")
        positions, velocities, time, obstacles = demo_arrays(demos, None, None, None)
        p = as_array(positions, "demos.positions", (None, self.T, self.num_axes))
        states, t = stack_states(p, velocities, time, ("demos.positions", "demos.velocities"),
                                 self.num_axes)
        if not np.allclose(t - t[0], self.time - self.time[0], rtol=0.0,
                           atol=1e-9 * max(self.dt, 1.0)):
            raise ShapeError("demos.time: expected the prior's time steps (resample the "
                             "demonstrations to the prior's T and dt)")
        settings = self.info.get("obstacle_weighting")
        weighting = None if settings is None else ObstacleWeighting(**settings)
        posterior = posterior.update(states, sample_weights(states, obstacles, weighting))
        info = {**self.info, "num_demos": int(self.info.get("num_demos", 0)) + len(states)}
        if self.kind == WorkspacePrior.default_kind:
            region = SkillRegion.of(self).merged(SkillRegion.from_positions(states[..., :3]))
            info["skill_region"] = region.to_info()
        return type(self).from_posterior(posterior, self.time,
                                         float(self.info.get("jitter", 0.0)), kind=self.kind,
                                         state_names=self.state_names, info=info)

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | os.PathLike[str], overwrite: bool = True) -> Path:
        """Write the prior (and its conjugate posterior, if any, as ``posterior_*`` entries:
        M, K, S, N and the factor learning resumes from) to an ``.npz`` file (suffix added if
        missing) of format :data:`FILE_FORMAT`. Written atomically
        (:func:`skillplan.command_line.atomic_write`: a temporary file in the same folder, moved
        over the target when complete); an existing file is replaced unless ``overwrite`` is
        False (then OutputPathError). Returns the path written."""
        path = Path(as_path(path, "path", ClampTypeError))
        if path.suffix != ".npz":
            path = path.with_name(path.name + ".npz")
        extra = {} if self.posterior is None else {
            f"posterior_{k}": v for k, v in self.posterior.arrays().items()}
        arrays = dict(format=np.array(FILE_FORMAT), kind=np.array(self.kind),
                      state_names=np.array(self.state_names), info=np.array(json.dumps(self.info)),
                      time=self.time, Phi=self.Phi, u=self.u, Q=self.Q, mean0=self.mean0,
                      cov0=self.cov0, **extra, **self._part_arrays())
        return atomic_write(path, lambda handle: np.savez(handle, **arrays), overwrite=bool(overwrite))

    def _part_arrays(self) -> dict[str, np.ndarray]:
        """Entries of the file beyond this chain's own (a workspace prior's orientation)."""
        return {}

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> LinearGaussianPrior:
        """Read a prior written by :meth:`save`, validating format, kind, shapes and values.

        ``LinearGaussianPrior.load`` returns a :class:`WorkspacePrior` for workspace files;
        ``WorkspacePrior.load`` rejects files of any other kind. Raises PriorFileError.
        """
        path = as_file(path, "path", PriorFileError, ClampTypeError)
        try:
            with np.load(path, allow_pickle=False) as data:
                contents = {key: data[key] for key in data.files}
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            raise PriorFileError(f"path: '{path}' is not a readable .npz prior file ({exc})") \
                from None
        version = _file_version(path, contents)
        missing = [k for k in _ARRAY_KEYS if k not in contents]
        if version is not None:
            missing += [k for k in ("kind", "state_names", "info") if k not in contents]
        if missing and version is None:
            raise PriorFileError(f"path: '{path}' is not a CLAMP prior file: it has no format entry "
                                 f"(read as version 1) and lacks entries {missing}")
        if missing:
            raise PriorFileError(f"path: '{path}' lacks entries {missing} (format {FILE_FORMAT_NAME}/"
                                 f"{version})")
        if version is None:                       # the layout before the format entry: version 1
            D = np.shape(contents["Phi"])[-1] if np.ndim(contents["Phi"]) == 3 else 0
            contents.setdefault("kind", np.array(cls.default_kind if cls is not LinearGaussianPrior
                                                 else WorkspacePrior.default_kind if D == 6
                                                 else LinearGaussianPrior.default_kind))
            contents.setdefault("info", np.array("{}"))
        kind = str(contents["kind"])
        target: type[LinearGaussianPrior] = cls
        if cls is LinearGaussianPrior and kind == WorkspacePrior.default_kind:
            target = WorkspacePrior
        if target is not LinearGaussianPrior and kind != target.default_kind:
            raise PriorFileError(f"path: '{path}' holds a '{kind}' prior, expected "
                                 f"'{target.default_kind}'")
        try:
            info = json.loads(str(contents["info"]))
        except (json.JSONDecodeError, RecursionError) as exc:
            raise PriorFileError(f"path: '{path}' has unreadable info ({exc})") from None
        if not isinstance(info, dict):
            raise PriorFileError(f"path: '{path}' has info {type(info).__name__}, expected a JSON "
                                 "object of learning settings")
        names = contents.get("state_names")       # absent: version 1 without a format entry
        if names is not None and (names.ndim != 1 or names.dtype.kind not in "US"):
            raise PriorFileError(f"path: '{path}' has state_names of dtype {names.dtype} and shape "
                                 f"{names.shape}, expected a list of names")
        posterior = None
        if "posterior_factor" in contents:
            try:
                posterior = ConjugatePosterior.from_arrays(
                    {k: contents[f"posterior_{k}"] for k in POSTERIOR_KEYS})
            except KeyError as exc:
                raise PriorFileError(f"path: '{path}' has an incomplete posterior (lacks "
                                     f"{exc})") from None
        parts = {}
        if any(key.startswith(ORIENTATION_PREFIX) for key in contents):
            parts["orientation"] = _orientation_part(path, contents)
        try:
            return target(*(contents[k] for k in _ARRAY_KEYS), kind=kind, info=info,
                          state_names=None if names is None else tuple(str(s) for s in names),
                          posterior=posterior, **parts)
        except (ShapeError, InvalidParameterError, ValueError) as exc:
            raise PriorFileError(f"path: '{path}' holds an invalid prior: {exc}") from None

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(kind={self.kind!r}, T={self.T}, D={self.D}, "
                f"dt={self.dt:.4g})")

    def summary(self) -> str:
        """What was learned and what the learner chose, one line each: size and steps, the
        learning settings of ``info`` (method, coupled, ridge, jitter, obstacle weighting), the
        start shrinkage (:mod:`clamp.prior.shrinkage`) with its leave-one-out prediction error,
        the demonstrations' spread about their mean (``info["skill_region"]``, learned workspace
        priors) or, without it, the prior's own marginal standard deviation of the positions."""
        info = self.info
        duration = float(self.time[-1] - self.time[0])
        lines = [f"{self!r}: {info.get('num_demos', '?')} demonstrations, {self.T} states over "
                 f"{duration:.3g} s (dt {self.dt:.4g} s)"]
        if "method" in info:
            lines.append(f"learned with method {info['method']}, coupled {info.get('coupled', '-')}, "
                         f"ridge {info.get('ridge', '-')}, jitter {info.get('jitter', '-')}, obstacle "
                         f"weighting {info.get('obstacle_weighting') or 'none'}")
        else:
            lines.append("learning settings: not recorded with this prior")
        shrink = info.get("start_shrinkage")
        if shrink is None:
            lines.append("start shrinkage: none (not applied by this learner)")
        else:
            blend = shrink.get("weights")
            shapes = ("" if not blend else " = " + " + ".join(
                f"{w:.3g} {name}" for name, w in blend.items() if w) if any(blend.values())
                else "")
            lines.append(f"start shrinkage: weight {shrink['weight']:.3g}{shapes} "
                         f"(setting {shrink['setting']!r}; {shrink['reason']})")
        region = info.get("skill_region")
        if region is not None:
            radius = np.asarray(region["radius"], dtype=float)
            spread = np.linalg.norm(np.asarray(region["spread"], dtype=float), axis=1)
            lines.append(f"demonstrations' spread about their mean: {1e3 * spread.mean():.1f} mm rms on "
                         f"average (max {1e3 * spread.max():.1f}), farthest {1e3 * radius.max():.1f} mm; "
                         f"at the start {1e3 * radius[0]:.1f} mm, at the end {1e3 * float(region['end_radius']):.1f} mm")
        else:
            std = np.linalg.norm(self.std[:, :self.num_axes], axis=1)
            lines.append(f"marginal position std: {std.mean():.4g} on average (max {std.max():.4g}; "
                         "the demonstrations' spread is not recorded with this prior)")
        if "conditioned_on" in info:
            lines.append(f"conditioned on {len(info['conditioned_on'])} position(s)")
        response = info.get("goal_response")
        if response and response.get("capped_states"):
            lines.append(f"the goal's response capped at its own offset on "
                         f"{response['capped_states']} states ({response['first']}-"
                         f"{response['last']}; the chain amplified it up to "
                         f"{response['largest_gain']:.3g}x)")
        return "\n".join(lines)


class WorkspacePrior(LinearGaussianPrior):
    """CLAMP's learned end-effector workspace prior: D = 6, x = [p (3) m, v (3) m/s].

    Same attributes and methods as :class:`LinearGaussianPrior`; ``position_mean`` (T, 3)
    and ``velocity_mean`` (T, 3) are views of ``mean``. ``orientation``: the hand's learned
    orientation chain on the same steps (a :class:`clamp.prior.orientation_prior.OrientationPrior`,
    a pose prior) when the demonstrations carried their rotations, None for a position-only
    prior; :meth:`mean_quaternions` is its mean orientation.
    """

    default_kind: ClassVar[str] = "workspace"

    def __init__(self, time: np.ndarray, Phi: np.ndarray, u: np.ndarray, Q: np.ndarray,
                 mean0: np.ndarray, cov0: np.ndarray, *, state_names: tuple[str, ...] | None = None,
                 kind: str | None = None, info: dict[str, Any] | None = None,
                 posterior: ConjugatePosterior | None = None,
                 orientation: LinearGaussianPrior | None = None) -> None:
        Phi = as_array(Phi, "Phi", (None, 6, 6))
        super().__init__(time, Phi, u, Q, mean0, cov0, state_names=state_names,
                         kind=kind or self.default_kind, info=info, posterior=posterior)
        self.orientation = self._checked_orientation(orientation)

    def _checked_orientation(self, orientation: Any) -> Any:
        if orientation is None:
            return None
        if not isinstance(orientation, LinearGaussianPrior.of_kind("orientation")):
            raise ClampTypeError(f"orientation: expected an OrientationPrior or None, got "
                                 f"{type(orientation).__name__}")
        if orientation.T != self.T:
            raise ShapeError(f"orientation: expected a chain over the prior's {self.T} steps, "
                             f"got {orientation.T}")
        return orientation

    def with_orientation(self, orientation: Any) -> "WorkspacePrior":
        """This prior with the orientation chain ``orientation`` (an OrientationPrior over the
        same steps, or None) instead; everything else shared."""
        new = copy.copy(self)
        new.orientation = self._checked_orientation(orientation)
        return new

    def mean_quaternions(self) -> np.ndarray:
        """The prior's mean orientation of the hand (T, 4), unit quaternions (x, y, z, w),
        sign-continuous: the (conditioned) orientation chain's mean rotations
        Rbar_t Exp(mean r_t). InvalidParameterError for a position-only prior."""
        from clamp.prior import so3
        from scenes.quaternions import continuous_quaternions
        if self.orientation is None:
            raise InvalidParameterError("prior: learned from position-only demonstrations; it "
                                        "has no orientation (learn from demonstrations with "
                                        "orientations)")
        return continuous_quaternions(so3.to_quaternions(self.orientation.mean_rotations))

    def _part_arrays(self) -> dict[str, np.ndarray]:
        part = self.orientation
        if part is None:
            return {}
        extra = {} if part.posterior is None else {
            f"posterior_{k}": v for k, v in part.posterior.arrays().items()}
        arrays = dict(Phi=part.Phi, u=part.u, Q=part.Q, mean0=part.mean0, cov0=part.cov0,
                      info=np.array(json.dumps(part.info)), **extra)
        return {ORIENTATION_PREFIX + k: v for k, v in arrays.items()}

    def update(self, demos: Any) -> LinearGaussianPrior:
        """:meth:`LinearGaussianPrior.update`, the orientation chain too for a pose prior (the
        demonstrations must then carry ``orientations`` (M, T, 4))."""
        quaternions = getattr(demos, "orientations", None)
        if self.orientation is not None and quaternions is None:
            raise InvalidParameterError("demos: this prior learned the hand's orientation; the "
                                        "demonstrations it updates from need orientations "
                                        "(M, T, 4) as well")
        new = super().update(demos)
        if self.orientation is None:
            return new
        return cast(WorkspacePrior, new).with_orientation(self.orientation.updated(quaternions))

    def summary(self) -> str:
        """:meth:`LinearGaussianPrior.summary`, with the orientation spread in degrees for a
        pose prior."""
        text = super().summary()
        part = self.orientation
        if part is None:
            return text
        radius = np.degrees(part.angle_radius)
        spread = np.degrees(np.linalg.norm(part.std[:, :3], axis=1))
        region = part.info.get("orientation_region")
        if region is not None:
            spread = np.degrees(np.linalg.norm(np.asarray(region["spread"]), axis=1))
        return (f"{text}\norientation: the demonstrations' spread about their mean rotation "
                f"{spread.mean():.1f} deg rms on average (max {spread.max():.1f}), farthest "
                f"{radius.max():.1f} deg; at the start {radius[0]:.1f} deg, at the end "
                f"{np.degrees(part.end_radius):.1f} deg")

    def _default_state_names(self) -> tuple[str, ...]:
        return ("px", "py", "pz", "vx", "vy", "vz")

    @property
    def position_mean(self) -> np.ndarray:
        """Prior mean end-effector position (T, 3), metres."""
        return self.mean[:, :3]

    @property
    def velocity_mean(self) -> np.ndarray:
        """Prior mean end-effector velocity (T, 3), m/s."""
        return self.mean[:, 3:]


def check_prior(prior: object, name: str = "prior", workspace: bool = False) -> LinearGaussianPrior:
    """``prior`` itself when it is a learned prior (``learn_prior``, ``learn_joint_prior`` or
    ``WorkspacePrior.load``); ClampTypeError naming ``name`` otherwise. ``workspace``: it must
    also be over x = [p, v] (D = 6), ShapeError otherwise."""
    if not isinstance(prior, LinearGaussianPrior):
        raise ClampTypeError(f"{name}: expected a clamp prior (learn_prior(...) or "
                                f"WorkspacePrior.load(path)), got {type(prior).__name__}")
    if workspace and prior.D != 6:
        raise ShapeError(f"{name}: expected a workspace prior over x = [p, v] (D = 6), "
                         f"got D = {prior.D}")
    return prior
