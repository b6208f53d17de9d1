"""Planned joint motions with rests, evaluated exactly at any time: what a playback plant executes.

A real arm's logs hold still at times: before and after a motion, and in pauses between. A motion
here is a function of time with analytic velocity and acceleration (no numerical differentiation),
so a simulator can evaluate it on a fine integration grid as well as at the samples:

- :class:`MultisinePath` is a multisine in a *path parameter* ``s`` (s), scaled to stay inside
  given amplitudes, speeds and accelerations;
- :class:`RestSchedule` warps time into ``s``: ``ṡ = σ(t)`` is 1 while moving, 0 at rest, with
  smooth (C¹) ramps between, so the arm stops and starts again with continuous accelerations;
- :class:`WarpedMotion` is a path played on a schedule (a multisine with pauses);
- :class:`PointToPoint` goes from waypoint to waypoint with quintic (minimum-jerk) moves and dwells
  at each waypoint.

Every motion has ``duration`` (s), ``evaluate(t) -> (q, q̇, q̈)`` (rad, rad/s, rad/s²; arrays
(M, N_J) for M times) and ``at_rest(t)`` (M,) booleans: the times the plan holds still.

Examples
--------
>>> path = MultisinePath(center=np.zeros(1), amplitudes=np.ones((1, 1)),
...                      frequencies_hz=np.array([0.5]), phases=np.zeros((1, 1)))
>>> motion = WarpedMotion(path, RestSchedule((("rest", 0.5), ("up", 0.5), ("move", 2.0), ("down", 0.5))))
>>> motion.duration
3.5
>>> q, dq, ddq = motion.evaluate(np.array([0.0, 3.5]))
>>> float(abs(dq).max()), bool(motion.at_rest(np.array([0.2]))[0])
(0.0, True)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

SEGMENT_KINDS = ("rest", "up", "move", "down")
"""Kinds of schedule segments: at rest (σ = 0), ramping up (0 → 1), moving (σ = 1), ramping down."""


class PlannedMotion(Protocol):
    """A joint motion known exactly at any time."""

    @property
    def duration(self) -> float:
        """Duration (s); the motion starts at t = 0."""
        ...

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions (rad), velocities (rad/s) and accelerations (rad/s²), each (M, N_J), at times
        ``t`` (M,) s."""
        ...

    def at_rest(self, t: np.ndarray) -> np.ndarray:
        """(M,) whether the plan holds still at times ``t`` (s)."""
        ...


@dataclass(frozen=True)
class MultisinePath:
    """``p(s) = center + Σ_k a_jk·(sin(2π f_k s + φ_jk) − sin φ_jk)``: starts at ``center``."""

    center: np.ndarray
    """(N_J,) position at s = 0 (rad)."""
    amplitudes: np.ndarray
    """(N_J, K) amplitudes a_jk (rad)."""
    frequencies_hz: np.ndarray
    """(K,) frequencies f_k (Hz, in path time)."""
    phases: np.ndarray
    """(N_J, K) phases φ_jk (rad)."""

    def at(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``p``, ``dp/ds`` and ``d²p/ds²`` (M, N_J) at path times ``s`` (M,)."""
        omega = 2 * np.pi * np.asarray(self.frequencies_hz, dtype=float)
        angle = np.asarray(s, dtype=float)[:, None, None] * omega[None, None, :] + self.phases[None]
        sine, cosine = np.sin(angle), np.cos(angle)
        p = self.center + np.sum(self.amplitudes * (sine - np.sin(self.phases)), axis=-1)
        dp = np.sum(self.amplitudes * omega * cosine, axis=-1)
        ddp = -np.sum(self.amplitudes * omega**2 * sine, axis=-1)
        return p, dp, ddp

    @classmethod
    def random(
        cls,
        center: np.ndarray,
        frequencies_hz: Sequence[float],
        reach: np.ndarray,
        speed: np.ndarray,
        acceleration: np.ndarray,
        length_s: float,
        rng: np.random.Generator,
    ) -> MultisinePath:
        """Random amplitudes (∝ 1/f) and phases, each joint scaled so that over ``[0, length_s]`` its
        excursion from ``center``, speed and acceleration stay within ``reach`` (rad), ``speed``
        (rad/s) and ``acceleration`` (rad/s²), one of them reached."""
        frequencies = np.asarray(frequencies_hz, dtype=float)
        n = len(center)
        raw = cls(
            np.asarray(center, dtype=float),
            rng.uniform(0.5, 1.0, size=(n, len(frequencies))) / frequencies,
            frequencies,
            rng.uniform(0.0, 2 * np.pi, size=(n, len(frequencies))),
        )
        s = np.linspace(0.0, length_s, max(2000, int(200 * length_s * frequencies.max())))
        p, dp, ddp = raw.at(s)
        peaks = np.stack([np.abs(p - raw.center).max(0), np.abs(dp).max(0), np.abs(ddp).max(0)])
        bounds = np.stack([np.asarray(reach), np.asarray(speed), np.asarray(acceleration)], dtype=float)
        scale = np.min(bounds / np.maximum(peaks, 1e-12), axis=0)
        return cls(raw.center, raw.amplitudes * scale[:, None], frequencies, raw.phases)


@dataclass(frozen=True)
class RestSchedule:
    """A time warp ``s(t)``: segments of rest (σ = ṡ = 0), ramps and motion (σ = 1).

    Ramps are ``σ = ½(1 − cos(π τ/T))`` (up) and its mirror (down), τ the time into the ramp of
    length T: σ and σ̇ are continuous, so a warped path's acceleration is too.
    """

    segments: tuple[tuple[str, float], ...]
    """(kind, duration s) in order; kinds in :data:`SEGMENT_KINDS`."""

    def __post_init__(self) -> None:
        for kind, length in self.segments:
            if kind not in SEGMENT_KINDS or not length > 0:
                raise ValueError(
                    f"schedule segment ({kind!r}, {length}): kind in {SEGMENT_KINDS}, length > 0"
                )

    @property
    def duration(self) -> float:
        """Total duration (s)."""
        return float(sum(length for _, length in self.segments))

    def warp(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``s`` (s), ``σ = ds/dt`` and ``σ̇`` (1/s), each (M,), at times ``t`` (M,) s."""
        t = np.asarray(t, dtype=float)
        s, sigma, dsigma = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
        start, s_start = 0.0, 0.0
        for k, (kind, length) in enumerate(self.segments):
            last = k == len(self.segments) - 1
            inside = (t >= start) & ((t < start + length) | last)
            tau = np.clip(t[inside] - start, 0.0, length)
            if kind == "move":
                s[inside], sigma[inside] = s_start + tau, 1.0
            elif kind in ("up", "down"):
                phase = np.pi * tau / length
                ramp = 0.5 * (tau - length / np.pi * np.sin(phase))  # ∫ ½(1 − cos) dτ
                if kind == "up":
                    s[inside], sigma[inside] = s_start + ramp, 0.5 * (1 - np.cos(phase))
                    dsigma[inside] = 0.5 * np.pi / length * np.sin(phase)
                else:
                    s[inside], sigma[inside] = s_start + tau - ramp, 0.5 * (1 + np.cos(phase))
                    dsigma[inside] = -0.5 * np.pi / length * np.sin(phase)
            else:
                s[inside] = s_start
            s_start += {"move": length, "up": length / 2, "down": length / 2}.get(kind, 0.0)
            start += length
        return s, sigma, dsigma

    @property
    def path_length(self) -> float:
        """Path time ``s`` covered by the whole schedule (s)."""
        return float(self.warp(np.array([self.duration]))[0][0])


@dataclass(frozen=True)
class WarpedMotion:
    """A path played on a rest schedule: ``q(t) = p(s(t))``, ``q̇ = p'·σ``, ``q̈ = p''·σ² + p'·σ̇``."""

    path: MultisinePath
    schedule: RestSchedule

    @property
    def duration(self) -> float:
        """Duration (s)."""
        return self.schedule.duration

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations (M, N_J) at ``t`` (M,) s."""
        s, sigma, dsigma = self.schedule.warp(t)
        p, dp, ddp = self.path.at(s)
        return p, dp * sigma[:, None], ddp * sigma[:, None] ** 2 + dp * dsigma[:, None]

    def at_rest(self, t: np.ndarray) -> np.ndarray:
        """Where the schedule stands still (σ = 0)."""
        return self.schedule.warp(t)[1] == 0.0


@dataclass(frozen=True)
class PointToPoint:
    """Quintic moves ``q_i + (q_{i+1} − q_i)·(10u³ − 15u⁴ + 6u⁵)`` between waypoints, each followed
    by a dwell (the first waypoint is held for ``dwells_s[0]`` before the first move)."""

    waypoints: np.ndarray
    """(W, N_J) positions (rad)."""
    move_s: np.ndarray
    """(W − 1,) duration of each move (s)."""
    dwells_s: np.ndarray
    """(W,) rest at each waypoint (s), before leaving it (the last: at the end)."""

    def __post_init__(self) -> None:
        w = len(self.waypoints)
        if np.shape(self.move_s) != (w - 1,) or np.shape(self.dwells_s) != (w,):
            raise ValueError(f"{w} waypoints need {w - 1} move durations and {w} dwells")

    @classmethod
    def within(
        cls,
        waypoints: np.ndarray,
        speed: np.ndarray,
        acceleration: np.ndarray,
        dwells_s: np.ndarray,
        shortest_move_s: float,
    ) -> PointToPoint:
        """Moves as short as the joints' ``speed`` and ``acceleration`` (N_J,) allow (a quintic peaks at
        1.875·Δq/T and 5.77·Δq/T²), none shorter than ``shortest_move_s``."""
        steps = np.abs(np.diff(np.asarray(waypoints, dtype=float), axis=0))
        move_s = np.max(np.maximum(1.875 * steps / speed, np.sqrt(5.77 * steps / acceleration)), axis=1)
        return cls(np.asarray(waypoints, dtype=float), np.maximum(move_s, shortest_move_s), dwells_s)

    @property
    def duration(self) -> float:
        """Duration (s)."""
        return float(np.sum(self.move_s) + np.sum(self.dwells_s))

    def _moves(self) -> list[tuple[float, float, int]]:
        """(start time, length, index of the waypoint left) of each move."""
        moves, start = [], float(self.dwells_s[0])
        for i, length in enumerate(self.move_s):
            moves.append((start, float(length), i))
            start += float(length) + float(self.dwells_s[i + 1])
        return moves

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations (M, N_J) at ``t`` (M,) s."""
        t = np.asarray(t, dtype=float)
        q = np.repeat(self.waypoints[:1], len(t), axis=0).astype(float)
        dq, ddq = np.zeros_like(q), np.zeros_like(q)
        for start, length, i in self._moves():
            step = self.waypoints[i + 1] - self.waypoints[i]
            after = t >= start
            q[after] = self.waypoints[i + 1]
            inside = after & (t < start + length)
            u = (t[inside] - start) / length
            shape = 10 * u**3 - 15 * u**4 + 6 * u**5
            slope = (30 * u**2 - 60 * u**3 + 30 * u**4) / length
            curve = (60 * u - 180 * u**2 + 120 * u**3) / length**2
            q[inside] = self.waypoints[i] + shape[:, None] * step
            dq[inside] = slope[:, None] * step
            ddq[inside] = curve[:, None] * step
        return q, dq, ddq

    def at_rest(self, t: np.ndarray) -> np.ndarray:
        """Outside every move."""
        t = np.asarray(t, dtype=float)
        moving = np.zeros(len(t), dtype=bool)
        for start, length, _ in self._moves():
            moving |= (t > start) & (t < start + length)
        return ~moving
