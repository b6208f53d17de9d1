"""The highest cut-off the positions' noise allows: where a log's motion sinks into its encoders' noise.

Differentiating positions twice multiplies their noise by (2πf)², so above some frequency the
acceleration of a log is mostly noise: a low-pass on the positions must stop there, and need not stop
lower. :func:`noise_limited_cutoff` finds that frequency from the log itself, joint by joint:

1. the spectrum ``S(f)`` of the raw second differences of the positions (Welch: Hann segments of
   :data:`SEGMENT_S`, half overlapping, at most :data:`MAX_SEGMENTS` of them spread over the log, so a
   long log costs no more than a short one);
2. the noise level: white position noise of variance σ² gives second differences the spectrum
   ``σ²·(2/f_s)·(2 sin(πf/f_s))⁴·f_s⁴``; its level is the lowest median of ``S`` over that shape
   among the top octaves (``f_s/16 … f_s/2``, where a motion has least), an upper bound of the noise
   that is tight where the motion has none;
3. the motion's spectrum, ``S`` less the noise where ``S`` stands clear of it (``S > 3 N``);
4. per joint, the cut-off ``f_c`` of the zero-phase Butterworth low-pass (gain
   ``H = 1/(1 + (f/f_c)^2n)``) that minimises the acceleration's error
   ``Σ motion·(1 − H)² + noise·H²``: the motion it removes against the noise it keeps; the joints'
   lowest over the joints that move (at least :data:`MOVING_SHARE` of the most moving joint's
   acceleration power).

Noise-free positions (a simulation, motor encoders through a gear) give the highest candidate,
``f_s/5``. Pure numpy; O(N) in the log's samples.

Examples
--------
>>> rng = np.random.default_rng(0)
>>> t = np.arange(20000) / 1000.0
>>> q = np.sin(2 * np.pi * 0.5 * t)[:, None] + 1e-5 * rng.standard_normal((20000, 1))
>>> 2.0 < noise_limited_cutoff(q, 1000.0) < 20.0
True
>>> noise_limited_cutoff(np.sin(2 * np.pi * 0.5 * t)[:, None], 1000.0)
200.0
"""

from __future__ import annotations

import numpy as np

SEGMENT_S = 4.0
"""Seconds of a Welch segment (its frequency resolution is 1/4 Hz)."""
MAX_SEGMENTS = 64
"""At most this many segments are averaged, spread over the log."""
MOVING_SHARE = 0.05
"""A joint counts when its acceleration power is at least this share of the most moving joint's."""
CLEAR_OF_NOISE = 3.0
"""The spectrum counts as motion where it exceeds the noise this many times."""
LOWEST_HZ = 0.5
"""The lowest candidate cut-off (Hz)."""
HIGHEST_PER_RATE = 0.2
"""The highest candidate cut-off, as a share of the log's rate (f_s/5)."""
CANDIDATES = 60
"""Candidate cut-offs, spaced evenly in log frequency."""


def acceleration_spectrum(q: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """``(f, S)``: frequencies (Hz) and the one-sided spectrum (rad²/s⁴/Hz) of each column of the
    second differences of ``q`` (N, N_J) (Welch, Hann segments, see the module docstring)."""
    positions = np.asarray(q, dtype=float)
    n = positions.shape[0] - 2  # second differences; taken segment by segment (no copy of a long log)
    length = int(2 ** np.floor(np.log2(max(8, min(n, SEGMENT_S * rate_hz)))))
    window = np.hanning(length)
    starts = np.arange(0, n - length + 1, length // 2)
    if starts.size > MAX_SEGMENTS:
        starts = starts[np.linspace(0, starts.size - 1, MAX_SEGMENTS).round().astype(int)]
    power = np.zeros((length // 2 + 1, positions.shape[1]))
    for start in starts:
        segment = np.diff(positions[start : start + length + 2], n=2, axis=0) * rate_hz**2
        segment = (segment - segment.mean(axis=0)) * window[:, None]
        power += np.abs(np.fft.rfft(segment, axis=0)) ** 2
    scale = 2.0 / (rate_hz * np.sum(window**2) * max(starts.size, 1))
    return np.fft.rfftfreq(length, 1.0 / rate_hz), power * scale


def noise_spectrum(f: np.ndarray, spectrum: np.ndarray, rate_hz: float) -> np.ndarray:
    """(F, N_J) the white position noise's part of ``spectrum`` (see the module docstring, step 2)."""
    shape = (2.0 * np.sin(np.pi * f / rate_hz)) ** 4
    levels = []
    for low, high in ((rate_hz / 16, rate_hz / 8), (rate_hz / 8, rate_hz / 4), (rate_hz / 4, rate_hz / 2)):
        band = (f >= low) & (f <= high) & (shape > 0)
        if np.any(band):
            levels.append(np.median(spectrum[band] / shape[band, None], axis=0))
    if not levels:
        return np.zeros_like(spectrum)
    return np.min(levels, axis=0)[None, :] * shape[:, None]


def cutoff_errors(q: np.ndarray, rate_hz: float, order: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(candidates, errors, power)``: candidate cut-offs (C,) (Hz), the acceleration's error
    (C, N_J) of each joint filtered at each (rad²/s⁴), and each joint's motion power (N_J,)."""
    f, spectrum = acceleration_spectrum(q, rate_hz)
    noise = noise_spectrum(f, spectrum, rate_hz)
    motion = np.where(spectrum > CLEAR_OF_NOISE * noise, spectrum - noise, 0.0)
    candidates = np.geomspace(LOWEST_HZ, HIGHEST_PER_RATE * rate_hz, CANDIDATES)
    gain = 1.0 / (1.0 + (f[None, :] / candidates[:, None]) ** (2 * order))  # (C, F)
    errors = (1.0 - gain) ** 2 @ motion + gain**2 @ noise
    return candidates, errors, motion.sum(axis=0)


def noise_limited_cutoff(q: np.ndarray, rate_hz: float, order: int = 5) -> float:
    """The highest cut-off (Hz) the noise of the positions ``q`` (N, N_J), sampled at ``rate_hz``, allows
    (see the module docstring); ``f_s/5`` where no noise shows, or for a log too short to tell."""
    highest = HIGHEST_PER_RATE * rate_hz
    if q.shape[0] < 64 or rate_hz / 16 <= LOWEST_HZ:
        return float(highest)
    candidates, errors, power = cutoff_errors(q, rate_hz, order)
    moving = power >= MOVING_SHARE * power.max() if power.max() > 0 else np.zeros(power.size, bool)
    if not np.any(moving):
        return float(highest)
    best = candidates[np.argmin(errors[:, moving], axis=0)]
    return float(np.min(best))


__all__ = ["acceleration_spectrum", "cutoff_errors", "noise_limited_cutoff", "noise_spectrum"]
