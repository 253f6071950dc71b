"""Positions and velocities of recorded trajectories: noise estimate, smoothing, derivative.

A recording of positions without velocities (a CSV without ``vx,vy,vz``, joint angles from
kinesthetic teaching) needs its velocities estimated. The derivative of an interpolating
cubic spline amplifies sensor noise by about sqrt(2) / dt: 1 mm of noise at 100 Hz becomes
0.14 m/s, more than the motion itself. The loaders' ``smoothing=``:

* ``"auto"`` (default): ``"savgol"`` where the noise test finds the recording noisy, else the
  interpolating cubic spline (exact through clean samples, as before);
* ``"savgol"``: scipy.signal.savgol_filter (cubic) on every column, its window chosen per
  column by generalized cross-validation (GCV(w) = mean squared residual / (1 - h_w)^2, h_w
  the filter's centre weight, over 25 odd windows from 5 samples to half the recording);
  positions are the filtered samples, velocities the filter's derivative;
* ``"spline"``: scipy.interpolate.make_smoothing_spline (penalty chosen by GCV per column);
  positions are the spline, velocities its derivative;
* ``"none"``: the interpolating cubic spline; a logging warning gives the numbers when the
  noise test finds the velocity noise dominating.

Noise test: the noise standard deviation of every column is estimated from the 4th
differences of the samples (robust: 1.4826 x median |d4| / sqrt(70); a smooth motion sampled
at 10 Hz or faster contributes < 1 % of it), the velocity noise of the interpolating spline
is sigma sqrt(2) / dt, and the motion's speed scale is the largest column range / duration.
The recording is noisy when velocity noise > NOISE_RATIO x speed scale. The real data sets
score <= 0.004, five minimum-jerk reaches of 10 s at 100 Hz with 1 mm noise about 6, with
0.1 mm 0.6.

Measured on one such reach (1001 samples, 3 columns; rms velocity error against the true
velocity, two seeds): 1 mm noise: interpolating spline 0.12 m/s; Savitzky-Golay with a fixed
window of 51 / 101 / 201 samples 2.4e-3 / 1.0e-3 / 3.5e-4 m/s; with the GCV window 3.7e-4 /
3.6e-4 m/s in 0.03-0.05 s; the GCV smoothing spline 3.0e-4 / 3.2e-4 m/s in 2.3 s. 0.1 mm:
GCV window 1.0e-4 / 6.9e-5, smoothing spline 1.0e-4 / 7.1e-5 m/s. The spline is at best 20 %
more accurate at 50 times the cost, so "auto" uses the filter. Both assume close to uniform
sampling (the filter takes the median step).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from math import comb

import numpy as np
from scipy.interpolate import CubicSpline, make_smoothing_spline

from .errors import InvalidArgumentError
from skillplan.validation import as_array, as_time

log = logging.getLogger(__name__)

#: the loaders' ``smoothing`` choices (see the module docstring)
SMOOTHING = ("auto", "savgol", "spline", "none")
#: velocity noise / speed scale above which a recording counts as noisy
NOISE_RATIO = 0.1
#: order of the differences the noise is estimated from
_ORDER = 4
#: fewest samples the noise test and the smoothers need (shorter: interpolated)
MIN_SAMPLES = 8
#: polynomial order of the Savitzky-Golay filter; number of windows GCV chooses from
_SAVGOL_ORDER = 3
_SAVGOL_CANDIDATES = 25


@dataclass(frozen=True)
class NoiseEstimate:
    """Noise of one recording: sigma (k,) per column [m or rad], velocity_noise [m/s or
    rad/s] of the interpolating spline's derivative (largest column), speed_scale [m/s or
    rad/s] (largest column range / duration), ratio = velocity_noise / speed_scale."""

    sigma: np.ndarray
    velocity_noise: float
    speed_scale: float
    ratio: float

    @property
    def noisy(self) -> bool:
        """True when the velocity noise exceeds NOISE_RATIO x the speed scale."""
        return self.ratio > NOISE_RATIO


def as_smoothing(smoothing: object, name: str = "smoothing") -> str:
    """A valid smoothing choice (InvalidArgumentError listing them otherwise)."""
    if not isinstance(smoothing, str) or smoothing not in SMOOTHING:
        raise InvalidArgumentError(f"{name}: expected one of {list(SMOOTHING)}, got "
                                   f"{smoothing!r:.60}")
    return smoothing


def estimate_noise(time: np.ndarray, values: np.ndarray) -> NoiseEstimate:
    """Noise of samples values (T, k) at time (T,) [s] (see the module docstring); T >=
    MIN_SAMPLES (fewer: sigma 0, not noisy)."""
    values = as_array(values, "values", InvalidArgumentError)
    if values.ndim != 2:
        raise InvalidArgumentError(f"values: expected shape (T, k), got {values.shape}")
    time = as_time(time, "time", len(values), InvalidArgumentError)
    if len(values) < MIN_SAMPLES:
        return NoiseEstimate(np.zeros(values.shape[1]), 0.0, 0.0, 0.0)
    differences = np.diff(values, _ORDER, axis=0)
    sigma = 1.4826 * np.median(np.abs(differences), axis=0) / np.sqrt(comb(2 * _ORDER, _ORDER))
    dt = float(np.median(np.diff(time)))
    velocity_noise = float(sigma.max()) * np.sqrt(2.0) / dt
    speed = float((values.max(axis=0) - values.min(axis=0)).max()) / float(time[-1] - time[0])
    ratio = velocity_noise / speed if speed > 0 else (np.inf if velocity_noise > 0 else 0.0)
    return NoiseEstimate(sigma, velocity_noise, speed, float(ratio))


def smooth_trajectory(time: np.ndarray, values: np.ndarray, smoothing: str = "auto",
                      name: str = "recording", unit: str = "m") -> tuple[np.ndarray, np.ndarray]:
    """Positions (T, k) and their time derivative (T, k) from samples values (T, k) [unit] at
    time (T,) [s], by ``smoothing`` (see :data:`SMOOTHING`). ``name`` labels the log
    messages, ``unit`` ("m", "rad") is the values' unit in them."""
    smoothing = as_smoothing(smoothing)
    values = as_array(values, f"{name}", InvalidArgumentError)
    time = as_time(time, f"{name} time", len(values), InvalidArgumentError)
    noise = estimate_noise(time, values)
    method = "savgol" if smoothing == "auto" and noise.noisy else smoothing
    if len(values) >= MIN_SAMPLES and method in ("savgol", "spline"):
        if method == "spline":
            spline = make_smoothing_spline(time, values, axis=0)
            positions, derivative = spline(time), spline.derivative()(time)
        else:
            positions, derivative = savgol_smooth(time, values)
        log.info("%s: smoothed (%s; estimated noise %.3g %s, velocity noise %.3g %s/s against "
                 "a speed scale of %.3g %s/s); positions moved by %.3g %s rms", name, method,
                 noise.sigma.max(), unit, noise.velocity_noise, unit, noise.speed_scale, unit,
                 float(np.sqrt(np.mean((positions - values) ** 2))), unit)
        return positions, derivative
    if noise.noisy:
        log.warning("%s: velocity noise dominates: estimated position noise up to %.3g %s; "
                    "at a median step of %.3g s the spline derivative carries noise of about "
                    "%.3g %s/s, %.1f x the motion's speed scale %.3g %s/s (range / duration); "
                    "load with smoothing='auto' to smooth", name, noise.sigma.max(),
                    unit, float(np.median(np.diff(time))), noise.velocity_noise, unit,
                    noise.ratio, noise.speed_scale, unit)
    return values, CubicSpline(time, values, axis=0)(time, 1)


def savgol_window(values: np.ndarray) -> np.ndarray:
    """Per column of values (T, k), the odd Savitzky-Golay window (k,) of least generalized
    cross-validation score (module docstring); T >= MIN_SAMPLES."""
    from scipy.signal import savgol_coeffs, savgol_filter   # deferred: scipy.signal loads SciPy's stats
    T = len(values)
    largest = max(_SAVGOL_ORDER + 2, T // 2)
    windows = np.unique(np.geomspace(_SAVGOL_ORDER + 2, largest, _SAVGOL_CANDIDATES)
                        .astype(int) // 2 * 2 + 1)
    windows = windows[(windows > _SAVGOL_ORDER) & (windows <= T)]
    scores = np.empty((len(windows), values.shape[1]))
    for k, window in enumerate(windows):
        fitted = savgol_filter(values, int(window), _SAVGOL_ORDER, axis=0)
        centre = savgol_coeffs(int(window), _SAVGOL_ORDER)[window // 2]
        scores[k] = np.mean((fitted - values) ** 2, axis=0) / (1.0 - centre) ** 2
    return windows[np.argmin(scores, axis=0)]


def savgol_smooth(time: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Savitzky-Golay positions and derivative (T, k) of values (T, k) at time (T,) [s], each
    column with its GCV window, at the median step."""
    from scipy.signal import savgol_filter
    step = float(np.median(np.diff(time)))
    positions, derivative = np.empty_like(values), np.empty_like(values)
    for column, window in enumerate(savgol_window(values)):
        positions[:, column] = savgol_filter(values[:, column], int(window), _SAVGOL_ORDER)
        derivative[:, column] = savgol_filter(values[:, column], int(window), _SAVGOL_ORDER,
                                              deriv=1, delta=step)
    return positions, derivative
