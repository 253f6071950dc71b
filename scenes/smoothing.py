"""Positions and velocities of recorded trajectories: noise estimate, smoothing, derivative.

A recording of positions without velocities (a CSV without ``vx,vy,vz``, joint angles from
kinesthetic teaching) needs its velocities estimated. The derivative of an interpolating
cubic spline amplifies sensor noise by about sqrt(2) / dt: 1 mm of noise at 100 Hz becomes
0.14 m/s, more than the motion itself. Three ways (``smoothing=`` of the loaders):

* ``"auto"`` (default): the smoothing spline below where the noise test finds the recording
  noisy, else the interpolating spline (exact through clean samples, as before);
* ``"spline"``: always scipy's ``make_smoothing_spline`` (penalised cubic spline; the penalty
  chosen by generalized cross-validation, shared by the columns); positions are replaced by
  the smooth curve and velocities are its derivative;
* ``"none"``: the interpolating cubic spline through the samples; a logging warning gives the
  numbers when the noise test finds velocity noise significant.

Noise test: the noise standard deviation of every column is estimated from the 4th
differences of the samples (robust: 1.4826 x median |d4| / sqrt(70); a smooth motion sampled
at 10 Hz or faster contributes < 1 % of it), the velocity noise of the interpolating spline
is sigma sqrt(2) / dt, and the motion's speed scale is the largest column range / duration.
The recording is noisy when velocity noise > NOISE_RATIO x speed scale. The real data sets
score <= 0.004, five minimum-jerk reaches of 10 s at 100 Hz with 1 mm noise 5.5, with 0.1 mm
0.6.

Measured on those noisy reaches (seed 0, rms velocity error against the true velocity):
interpolating spline 0.117 m/s; Savitzky-Golay (cubic, window 51 / 101 / 151 / 201 samples)
2.4e-3 / 1.0e-3 / 4.4e-4 / 3.5e-4 m/s; the smoothing spline 3.0e-4 m/s with no window to
choose, so it is the method here. Sampling is assumed close to uniform.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from math import comb

import numpy as np
from scipy.interpolate import CubicSpline, make_smoothing_spline

from .errors import InvalidArgumentError
from .validation import as_array, as_time

log = logging.getLogger(__name__)

#: the loaders' ``smoothing`` choices (see the module docstring)
SMOOTHING = ("auto", "spline", "none")
#: velocity noise / speed scale above which a recording counts as noisy
NOISE_RATIO = 0.1
#: order of the differences the noise is estimated from
_ORDER = 4
#: fewest samples the noise test and the smoothing spline need (shorter: interpolated)
MIN_SAMPLES = 8


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
    smooth = len(values) >= MIN_SAMPLES and (smoothing == "spline"
                                             or (smoothing == "auto" and noise.noisy))
    if smooth:
        spline = make_smoothing_spline(time, values, axis=0)
        positions, derivative = spline(time), spline.derivative()(time)
        log.info("%s: smoothing spline (estimated noise %.3g %s, velocity noise %.3g %s/s "
                 "against a speed scale of %.3g %s/s); positions moved by %.3g %s rms", name,
                 noise.sigma.max(), unit, noise.velocity_noise, unit, noise.speed_scale, unit,
                 float(np.sqrt(np.mean((positions - values) ** 2))), unit)
        return positions, derivative
    if noise.noisy:
        log.warning("%s: velocity noise dominates: estimated position noise up to %.3g %s; "
                    "at a median step of %.3g s the spline derivative carries noise of about "
                    "%.3g %s/s, %.1f x the motion's speed scale %.3g %s/s (range / duration); "
                    "load with smoothing='auto' or 'spline' to smooth", name, noise.sigma.max(),
                    unit, float(np.median(np.diff(time))), noise.velocity_noise, unit,
                    noise.ratio, noise.speed_scale, unit)
    return values, CubicSpline(time, values, axis=0)(time, 1)
