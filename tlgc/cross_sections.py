"""Cross-section boundaries of a generalized cylinder, all N sections of one type at once.

Every type describes, for each cross-section k, the boundary radius r_k(angle) around the
directrix point in the section's normal plane (2-D coordinates along [normal, binormal]; angle
measured from the normal towards the binormal). Each boundary encloses all effective points of
its section and touches the farthest one exactly (largest ratio = 1):

- ``circle``:  radius = distance of the farthest effective point;
- ``ellipse``: axes along the principal directions of the effective points, scaled so that the
  largest normalised radius of the points is exactly 1;
- ``spline``:  closed (periodic) cubic spline of the radius against the angle, passing through
  every effective point (C2), so each point lies on the boundary. Where the C2 spline would dip
  below half the smallest point radius the section uses shape-preserving periodic cubic
  Hermite slopes instead (C1, stays between neighbouring point radii), which keeps it positive.

Radii and their slopes d r / d angle are evaluated exactly (analytic circle/ellipse, piecewise
cubic coefficients (N, K, 4) for splines) and vectorized over any broadcastable (index, angle)
arrays.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from .errors import TLGCArgumentError, UnknownCrossSectionError
from .validation import as_array

TWO_PI = 2.0 * np.pi
MIN_RADIUS = 1e-6          # [m] radius of a section whose effective points all sit on the centre
MIN_AXIS_RATIO = 1e-3      # minor/major axis floor for ellipses of collinear points
ANGLE_TOLERANCE = 1e-9     # [rad] effective points closer in angle than this share one spline knot


def polar(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Radius and angle in [0, 2 pi) of 2-D points (..., 2)."""
    radius = np.hypot(points[..., 0], points[..., 1])
    angle = np.arctan2(points[..., 1], points[..., 0])
    angle += TWO_PI * (angle < 0.0)
    return radius, angle


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Angles (...) [rad] wrapped into [0, 2 pi)."""
    a = np.mod(np.asarray(angle, dtype=float), TWO_PI)
    return np.where(a >= TWO_PI, 0.0, a)


class CrossSections(ABC):
    """Boundaries of N cross-sections of one type; see the module docstring."""

    kind: ClassVar[str]

    @property
    @abstractmethod
    def num_sections(self) -> int:
        """Number N of cross-sections."""

    @classmethod
    @abstractmethod
    def fit(cls, effective_points: np.ndarray) -> "CrossSections":
        """Fit boundaries to effective points (M, N, 2) [m] around each section's centre."""

    @abstractmethod
    def radius(self, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
        """Boundary radius [m] of sections ``index`` at ``angle`` [rad]; broadcast shapes."""

    @abstractmethod
    def radius_derivative(self, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
        """Slope d radius / d angle [m/rad] of sections ``index`` at ``angle`` [rad]; broadcast."""

    @abstractmethod
    def to_arrays(self) -> dict[str, np.ndarray]:
        """Arrays that :meth:`from_arrays` turns back into an equal object (for npz files)."""

    @classmethod
    @abstractmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> "CrossSections":
        """Inverse of :meth:`to_arrays`."""

    @abstractmethod
    def select(self, indices: np.ndarray) -> "CrossSections":
        """The sections at ``indices`` (1-D integer array), in that order."""

    def check_index(self, index: np.ndarray) -> np.ndarray:
        """Integer array of section indices in [0, N); raise TLGCArgumentError otherwise."""
        idx = np.asarray(index)
        if idx.dtype.kind not in "iu":
            if idx.dtype.kind == "f" and np.all(np.isfinite(idx)) and np.all(idx == np.round(idx)):
                idx = idx.astype(np.intp)
            else:
                raise TLGCArgumentError(f"index: expected integers, got dtype {idx.dtype}")
        if idx.size and (idx.min() < 0 or idx.max() >= self.num_sections):
            raise TLGCArgumentError(
                f"index: expected values in [0, {self.num_sections}), "
                f"got range [{idx.min()}, {idx.max()}]")
        return idx

    def boundary(self, num_angles: int = 64) -> np.ndarray:
        """Boundary polygons (N, A, 2) [m] sampled at A equally spaced angles from 0."""
        angles = np.linspace(0.0, TWO_PI, num_angles, endpoint=False)
        r = self.radius(np.arange(self.num_sections)[:, None], angles[None, :])
        return r[..., None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)

    def ratio(self, index: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Radius of 2-D points (..., 2) over the boundary radius of sections ``index`` (...)."""
        r, a = polar(np.asarray(points, dtype=float))
        return r / self.radius(index, a)


class CircleSections(CrossSections):
    """Circular sections: ``radii`` (N,) [m]."""

    kind = "circle"

    def __init__(self, radii: np.ndarray) -> None:
        self.radii = as_array(radii, "radii")
        if self.radii.ndim != 1 or np.any(self.radii <= 0):
            raise TLGCArgumentError(f"radii: expected positive values of shape (N,), got {self.radii.shape}")

    @property
    def num_sections(self) -> int:
        return len(self.radii)

    @classmethod
    def fit(cls, effective_points: np.ndarray) -> "CircleSections":
        r = np.hypot(effective_points[..., 0], effective_points[..., 1])
        return cls(np.maximum(r.max(axis=0), MIN_RADIUS))

    def radius(self, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
        idx = self.check_index(index)
        return np.broadcast_to(self.radii[idx], np.broadcast_shapes(idx.shape, np.shape(angle))).copy()

    def radius_derivative(self, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
        idx = self.check_index(index)
        return np.zeros(np.broadcast_shapes(idx.shape, np.shape(angle)))

    def to_arrays(self) -> dict[str, np.ndarray]:
        return {"radii": self.radii}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> "CircleSections":
        return cls(arrays["radii"])

    def select(self, indices: np.ndarray) -> "CircleSections":
        return CircleSections(self.radii[self.check_index(indices)])


class EllipseSections(CrossSections):
    """Elliptic sections centred on the directrix: semi-axes ``major``, ``minor`` (N,) [m] and
    ``orientation`` (N,) [rad], the angle of the major axis from the normal."""

    kind = "ellipse"

    def __init__(self, major: np.ndarray, minor: np.ndarray, orientation: np.ndarray) -> None:
        self.major = as_array(major, "major")
        self.minor = as_array(minor, "minor")
        self.orientation = as_array(orientation, "orientation")
        n = self.major.shape
        if len(n) != 1 or self.minor.shape != n or self.orientation.shape != n:
            raise TLGCArgumentError(
                f"major, minor, orientation: expected equal shapes (N,), got "
                f"{self.major.shape}, {self.minor.shape}, {self.orientation.shape}")
        if np.any(self.major <= 0) or np.any(self.minor <= 0):
            raise TLGCArgumentError("major, minor: expected positive semi-axes")
        # 1 / r(angle)^2 = A cos^2 + B cos sin + C sin^2 (quadratic form of the ellipse).
        co, so = np.cos(self.orientation), np.sin(self.orientation)
        ia, ib = 1.0 / self.major**2, 1.0 / self.minor**2
        self._quadratic = (co * co * ia + so * so * ib, 2.0 * co * so * (ia - ib),
                           so * so * ia + co * co * ib)

    @property
    def num_sections(self) -> int:
        return len(self.major)

    @classmethod
    def fit(cls, effective_points: np.ndarray) -> "EllipseSections":
        p = np.moveaxis(effective_points, 1, 0)                       # (N, M, 2)
        second_moment = np.einsum("nmi,nmj->nij", p, p) / p.shape[1]
        eigenvalues, eigenvectors = np.linalg.eigh(second_moment)    # ascending
        axis = eigenvectors[:, :, 1]                                  # major direction (N, 2)
        orientation = np.arctan2(axis[:, 1], axis[:, 0])
        a0 = np.sqrt(np.maximum(eigenvalues[:, 1], 0.0))
        a0 = np.maximum(a0, MIN_RADIUS)
        b0 = np.maximum(np.sqrt(np.maximum(eigenvalues[:, 0], 0.0)), MIN_AXIS_RATIO * a0)
        u = np.einsum("nmi,ni->nm", p, axis)
        v = p[..., 1] * axis[:, None, 0] - p[..., 0] * axis[:, None, 1]
        scale = np.sqrt((u / a0[:, None]) ** 2 + (v / b0[:, None]) ** 2).max(axis=1)
        empty = scale * a0 < MIN_RADIUS       # all points on the centre: tiny circle
        scale = np.where(empty, 1.0, scale)
        a0 = np.where(empty, MIN_RADIUS, a0)
        b0 = np.where(empty, MIN_RADIUS, b0)
        return cls(scale * a0, scale * b0, orientation)

    def radius(self, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
        idx = self.check_index(index)
        ang = np.asarray(angle, dtype=float)
        c, s = np.cos(ang), np.sin(ang)
        a, b, cc = (q[idx] for q in self._quadratic)
        inverse_square = np.asarray(a * (c * c))
        inverse_square += b * (c * s)
        inverse_square += cc * (s * s)
        np.sqrt(inverse_square, out=inverse_square)
        return np.divide(1.0, inverse_square, out=inverse_square)

    def radius_derivative(self, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
        """With q = 1 / r^2 = A c^2 + B c s + C s^2: r' = -r^3 q' / 2, where
        q' = (C - A) sin(2 angle) + B cos(2 angle)."""
        idx = self.check_index(index)
        ang = np.asarray(angle, dtype=float)
        a, b, cc = (q[idx] for q in self._quadratic)
        r = self.radius(idx, ang)
        slope = (cc - a) * np.sin(2.0 * ang) + b * np.cos(2.0 * ang)
        return -0.5 * r**3 * slope

    def to_arrays(self) -> dict[str, np.ndarray]:
        return {"major": self.major, "minor": self.minor, "orientation": self.orientation}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> "EllipseSections":
        return cls(arrays["major"], arrays["minor"], arrays["orientation"])

    def select(self, indices: np.ndarray) -> "EllipseSections":
        i = self.check_index(indices)
        return EllipseSections(self.major[i], self.minor[i], self.orientation[i])


def _periodic_spline_slopes(h: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """Knot slopes (B, K) of C2 periodic cubic splines; h, delta (B, K) interval widths/slopes."""
    batch, k = h.shape
    h_prev = np.roll(h, 1, axis=1)
    d_prev = np.roll(delta, 1, axis=1)
    system = np.zeros((batch, k, k))
    rows = np.arange(k)
    np.add.at(system, (slice(None), rows, (rows - 1) % k), h)
    np.add.at(system, (slice(None), rows, rows), 2.0 * (h_prev + h))
    np.add.at(system, (slice(None), rows, (rows + 1) % k), h_prev)
    rhs = 3.0 * (h * d_prev + h_prev * delta)
    return np.linalg.solve(system, rhs[..., None])[..., 0]


def _shape_preserving_slopes(h: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """Periodic Fritsch-Carlson (PCHIP) knot slopes (B, K): no overshoot between knots."""
    h_prev = np.roll(h, 1, axis=1)
    d_prev = np.roll(delta, 1, axis=1)
    w1 = 2.0 * h + h_prev
    w2 = h + 2.0 * h_prev
    same_sign = d_prev * delta > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        harmonic = (w1 + w2) / (w1 / d_prev + w2 / delta)
    return np.where(same_sign, harmonic, 0.0)


def _hermite_coefficients(y: np.ndarray, slopes: np.ndarray, h: np.ndarray,
                          delta: np.ndarray) -> np.ndarray:
    """Power-basis coefficients (B, K, 4) [c0, c1, c2, c3] of each piece in t in [0, h]."""
    m0, m1 = slopes, np.roll(slopes, -1, axis=1)
    c2 = (3.0 * delta - 2.0 * m0 - m1) / h
    c3 = (m0 + m1 - 2.0 * delta) / h**2
    return np.stack([y, m0, c2, c3], axis=-1)


def _piece_minimum(coefficients: np.ndarray, h: np.ndarray, samples: int = 17) -> np.ndarray:
    """Approximate minimum (B,) of piecewise cubics (B, K, 4) sampled on each piece."""
    t = np.linspace(0.0, 1.0, samples)[None, None, :] * h[..., None]
    c = coefficients[..., None, :]
    values = ((c[..., 3] * t + c[..., 2]) * t + c[..., 1]) * t + c[..., 0]
    return values.min(axis=(1, 2))


def _fit_polar_splines(angles: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Periodic cubics r(angle) through sorted distinct knots (B, K), K >= 1.

    Returns breaks (B, K+1) (last = first + 2 pi) and coefficients (B, K, 4).
    """
    breaks = np.concatenate([angles, angles[:, :1] + TWO_PI], axis=1)
    k = angles.shape[1]
    if k == 1:
        coefficients = np.zeros((len(angles), 1, 4))
        coefficients[:, 0, 0] = radii[:, 0]
        return breaks, coefficients
    h = np.diff(breaks, axis=1)
    delta = (np.roll(radii, -1, axis=1) - radii) / h
    safe_slopes = _shape_preserving_slopes(h, delta)
    coefficients = _hermite_coefficients(radii, safe_slopes, h, delta)
    if k >= 3:
        smooth = _hermite_coefficients(radii, _periodic_spline_slopes(h, delta), h, delta)
        keep_smooth = _piece_minimum(smooth, h) >= 0.5 * radii.min(axis=1)
        coefficients[keep_smooth] = smooth[keep_smooth]
    return breaks, coefficients


def _section_knots(radius: np.ndarray, angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct knots (angle, radius) of one section's effective points (M,), sorted by angle.

    Points on the centre are dropped; points sharing an angle keep the largest radius.
    """
    keep = radius > MIN_RADIUS
    if not keep.any():
        return np.zeros(1), np.full(1, MIN_RADIUS)
    a, r = angle[keep], radius[keep]
    order = np.lexsort((-r, a))
    a, r = a[order], r[order]
    new_knot = np.concatenate([[True], np.diff(a) > ANGLE_TOLERANCE])
    a, r = a[new_knot], np.maximum.reduceat(r, np.flatnonzero(new_knot))
    if len(a) > 1 and a[0] + TWO_PI - a[-1] <= ANGLE_TOLERANCE:     # wrap-around duplicate
        r[0] = max(r[0], r[-1])
        a, r = a[:-1], r[:-1]
    return a, r


class SplineSections(CrossSections):
    """Closed periodic cubic spline sections in polar form.

    ``breaks`` (N, K+1) [rad]: sorted knot angles of each section, the last equal to the first
    plus 2 pi; sections with fewer knots repeat the last break (zero-width pieces).
    ``coefficients`` (N, K, 4): r = c0 + c1 t + c2 t^2 + c3 t^3 [m] on piece j, t = angle - break j.
    """

    kind = "spline"

    def __init__(self, breaks: np.ndarray, coefficients: np.ndarray) -> None:
        self.breaks = as_array(breaks, "breaks")
        self.coefficients = as_array(coefficients, "coefficients")
        n, k1 = self.breaks.shape if self.breaks.ndim == 2 else (None, None)
        if n is None or k1 < 2 or self.coefficients.shape != (n, k1 - 1, 4):
            raise TLGCArgumentError(
                f"breaks, coefficients: expected shapes (N, K+1) and (N, K, 4), got "
                f"{self.breaks.shape} and {self.coefficients.shape}")
        widths = np.diff(self.breaks, axis=1)
        if np.any(widths < 0) or np.any(np.abs(self.breaks[:, -1] - self.breaks[:, 0] - TWO_PI) > 1e-9):
            raise TLGCArgumentError(
                "breaks: expected non-decreasing rows whose last entry is the first plus 2 pi")
        self._build_tables(widths > 0)

    def _build_tables(self, real: np.ndarray) -> None:
        """Evaluation tables over the absolute angle in [0, 2 pi).

        Piece starts wrapped into [0, 2 pi) and sorted (N, K) (inf for zero-width pieces); the
        extended tables (N, K+1) prepend the piece that wraps around past 2 pi, shifted by
        -2 pi, so the piece holding angle a is entry #(starts <= a) of the extended tables.
        """
        n, k = real.shape
        starts = np.where(real, np.mod(self.breaks[:, :-1], TWO_PI), np.inf)
        order = np.argsort(starts, axis=1, kind="stable")
        self._sorted_starts = np.take_along_axis(starts, order, axis=1)
        coefficients = np.take_along_axis(self.coefficients, order[..., None], axis=1)
        last = real.sum(axis=1) - 1                                    # (N,) last real piece
        rows = np.arange(n)
        extended_starts = np.concatenate(
            [self._sorted_starts[rows, last][:, None] - TWO_PI, self._sorted_starts], axis=1)
        self._extended_starts = np.where(np.isinf(extended_starts), 0.0, extended_starts)
        extended = np.concatenate([coefficients[rows, last][:, None], coefficients], axis=1)
        self._columns = [np.ascontiguousarray(extended[..., j]) for j in range(4)]

    @property
    def num_sections(self) -> int:
        return len(self.breaks)

    @classmethod
    def fit(cls, effective_points: np.ndarray) -> "SplineSections":
        num_demos, n = effective_points.shape[:2]
        radius, angle = polar(np.moveaxis(effective_points, 1, 0))        # (N, M)
        order = np.argsort(angle, axis=1, kind="stable")
        angle = np.take_along_axis(angle, order, axis=1)
        radius = np.take_along_axis(radius, order, axis=1)
        gaps = np.diff(np.concatenate([angle, angle[:, :1] + TWO_PI], axis=1), axis=1)
        regular = np.all(radius > MIN_RADIUS, axis=1) & np.all(gaps > ANGLE_TOLERANCE, axis=1)

        breaks = np.empty((n, num_demos + 1))
        coefficients = np.zeros((n, num_demos, 4))
        if regular.any():
            breaks[regular], coefficients[regular] = _fit_polar_splines(angle[regular], radius[regular])
        for i in np.flatnonzero(~regular):        # rare: centre or coinciding points
            a, r = _section_knots(radius[i], angle[i])
            b, c = _fit_polar_splines(a[None], r[None])
            k = len(a)
            breaks[i, : k + 1] = b[0]
            breaks[i, k + 1:] = b[0, -1]
            coefficients[i, :k] = c[0]
        return cls(breaks, coefficients)

    def _locate(self, index: np.ndarray, angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Flat entry (...) of the extended tables holding each (index, angle) and the offset
        t = angle - piece start (...) [rad] into that piece."""
        idx = self.check_index(index)
        ang = wrap_angle(angle)
        starts = self._sorted_starts[idx]                              # idx.shape + (K,)
        small = starts.shape[-1] < 255                                  # piece count fits uint8
        piece = np.zeros(np.broadcast_shapes(idx.shape, ang.shape), dtype=np.uint8 if small else np.int32)
        for j in range(starts.shape[-1]):                              # K comparisons
            above = ang >= starts[..., j]
            piece += above.view(np.uint8) if small else above
        flat = idx.astype(np.int32) * np.int32(starts.shape[-1] + 1) + piece
        return flat, ang - np.take(self._extended_starts, flat)

    def radius(self, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
        flat, t = self._locate(index, angle)
        c = self._columns
        r = np.take(c[3], flat)
        r *= t
        r += np.take(c[2], flat)
        r *= t
        r += np.take(c[1], flat)
        r *= t
        r += np.take(c[0], flat)
        return r

    def radius_derivative(self, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
        """r' = c1 + 2 c2 t + 3 c3 t^2 of the piece holding ``angle`` (C2 or C1 sections alike)."""
        flat, t = self._locate(index, angle)
        c = self._columns
        slope = 3.0 * np.take(c[3], flat)
        slope *= t
        slope += 2.0 * np.take(c[2], flat)
        slope *= t
        slope += np.take(c[1], flat)
        return slope

    def to_arrays(self) -> dict[str, np.ndarray]:
        return {"breaks": self.breaks, "coefficients": self.coefficients}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> "SplineSections":
        return cls(arrays["breaks"], arrays["coefficients"])

    def select(self, indices: np.ndarray) -> "SplineSections":
        i = self.check_index(indices)
        return SplineSections(self.breaks[i], self.coefficients[i])


CROSS_SECTION_TYPES: dict[str, type[CrossSections]] = {
    cls.kind: cls for cls in (CircleSections, EllipseSections, SplineSections)
}


def cross_section_type(name: str) -> type[CrossSections]:
    """The CrossSections class for ``name``; UnknownCrossSectionError lists the valid names."""
    try:
        return CROSS_SECTION_TYPES[name]
    except (KeyError, TypeError):
        raise UnknownCrossSectionError(
            f"cross_section: unknown type {name!r}; expected one of "
            f"{', '.join(sorted(CROSS_SECTION_TYPES))}") from None


def fit_cross_sections(name: str, effective_points: np.ndarray) -> CrossSections:
    """Fit cross-sections of type ``name`` to effective points (M, N, 2) [m]."""
    return cross_section_type(name).fit(effective_points)
