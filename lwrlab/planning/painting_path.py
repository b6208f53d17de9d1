"""The Cartesian painting path of Fig. 7: a vertical zig-zag on a wall, quintic between way points.

Way points, in the wall plane (y horizontal, z vertical), for ``N_r`` horizontal steps::

    (Y0, Z_l) → (Y0, Z_u) → (Y0+ΔY, Z_u) → (Y0+ΔY, Z_l) → (Y0+2ΔY, Z_l) → (Y0+2ΔY, Z_u) → …

ending at ``Y0 + N_r·ΔY``: N_r + 1 vertical strokes, each painting a stripe of the roller's width,
joined by horizontal steps ΔY. The Cartesian velocity and acceleration are zero at every way point
(§IV.A); between two way points the tool centre point follows a 5th-order Bernstein polynomial —
a 5th-order B-spline with knots of multiplicity 3 at the way points, i.e. the minimum-jerk profile
``s(τ) = 10τ³ − 15τ⁴ + 6τ⁵``. The duration T_C is split between segments in proportion to the
square root of their lengths (equal peak Cartesian acceleration on every segment).

The tool points into the wall (its z axis along −x, the wall normal reversed) with the roller axis
(its y axis) horizontal: the roller is perpendicular to the path plane and rolls on the vertical
strokes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TOOL_ORIENTATION = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
"""Rotation of the tool frame in the base frame while painting a wall facing +x: tool z = −x
(into the wall), tool y = +y (roller axis horizontal), tool x = +z."""


@dataclass(frozen=True)
class PaintingPathParameters:
    """The search variables of eq. (12) and the fixed stroke count."""

    duration: float
    """T_C, duration of the whole path (s)."""
    swivel: float
    """φ, swivel angle of the arm, constant along the path (rad)."""
    z_upper: float
    """Z_u, upper turning height of the tool centre point (m)."""
    z_lower: float
    """Z_l, lower turning height (m)."""
    y_start: float
    """Y_0, horizontal position of the first stroke (m)."""
    y_step: float
    """ΔY, horizontal step between strokes (m)."""
    n_steps: int
    """N_r, number of horizontal steps (N_r + 1 vertical strokes)."""

    @classmethod
    def from_vector(cls, x: np.ndarray, n_steps: int) -> PaintingPathParameters:
        """From ``x = [T_C, φ, Z_u, Z_l, Y_0, ΔY]`` (eq. 12)."""
        duration, swivel, z_upper, z_lower, y_start, y_step = (float(v) for v in x)
        return cls(duration, swivel, z_upper, z_lower, y_start, y_step, n_steps)

    def vector(self) -> np.ndarray:
        """``[T_C, φ, Z_u, Z_l, Y_0, ΔY]``."""
        return np.array([self.duration, self.swivel, self.z_upper, self.z_lower, self.y_start, self.y_step])

    @property
    def y_end(self) -> float:
        """Horizontal position of the last stroke, Y_0 + N_r·ΔY (m)."""
        return self.y_start + self.n_steps * self.y_step

    def way_points(self) -> np.ndarray:
        """(2·(N_r + 1), 2) way points [y, z] (m)."""
        points = []
        for stroke in range(self.n_steps + 1):
            y = self.y_start + stroke * self.y_step
            low_first = stroke % 2 == 0
            points += (
                [(y, self.z_lower), (y, self.z_upper)]
                if low_first
                else [(y, self.z_upper), (y, self.z_lower)]
            )
        return np.array(points)

    def painted_area(self, roller_width: float) -> float:
        """Area the path paints if ΔY ≤ roller width (m²): (Z_u − Z_l)·(N_r·ΔY + w_L)."""
        return (self.z_upper - self.z_lower) * (self.n_steps * self.y_step + roller_width)


@dataclass(frozen=True)
class SampledPath:
    """A painting path sampled on a uniform time grid (base frame)."""

    t: np.ndarray
    """(N,) time (s)."""
    position: np.ndarray
    """(N, 3) tool-centre-point position (m)."""
    velocity: np.ndarray
    """(N, 3) (m/s)."""
    acceleration: np.ndarray
    """(N, 3) (m/s²)."""
    rotation: np.ndarray
    """(3, 3) constant tool orientation."""

    def poses(self) -> np.ndarray:
        """(N, 4, 4) tool-centre-point poses."""
        poses = np.zeros((self.t.shape[0], 4, 4))
        poses[:, :3, :3] = self.rotation
        poses[:, :3, 3] = self.position
        poses[:, 3, 3] = 1.0
        return poses


def way_point_times(way_points: np.ndarray, duration: float) -> np.ndarray:
    """Times (s) of the way points: segment durations ∝ √length, summing to ``duration``."""
    lengths = np.linalg.norm(np.diff(way_points, axis=0), axis=1)
    if np.any(lengths <= 0):
        raise ValueError("painting path: two consecutive way points coincide (Z_u = Z_l or ΔY = 0)")
    weights = np.sqrt(lengths)
    return np.concatenate([[0.0], np.cumsum(weights) / weights.sum() * duration])


def minimum_jerk(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ and its first two derivatives in τ, for τ in [0, 1]."""
    return (
        tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2),
        30.0 * tau**2 * (1.0 - tau) ** 2,
        60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau),
    )


def _segments(
    parameters: PaintingPathParameters, rate_hz: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sample times t (s), way points, their times (s), each sample's segment and its normalised time τ."""
    if parameters.duration <= 0:
        raise ValueError(f"painting path duration must be positive, got {parameters.duration} s")
    points = parameters.way_points()
    times = way_point_times(points, parameters.duration)
    n = round(parameters.duration * rate_hz) + 1
    t = np.linspace(0.0, parameters.duration, n)
    segment = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    tau = np.clip((t - times[segment]) / (times[segment + 1] - times[segment]), 0.0, 1.0)
    return t, points, times, segment, tau


def sample_path(
    parameters: PaintingPathParameters, wall_x: float, rate_hz: float, rotation: np.ndarray = TOOL_ORIENTATION
) -> SampledPath:
    """The path of ``parameters`` on the wall plane ``x = wall_x`` sampled at ``rate_hz`` (Hz).

    Each segment is the quintic with the way points' positions and zero velocity and acceleration
    at both ends, written in closed form (the same polynomial as ``scipy.interpolate.BPoly.from_derivatives``
    with ``[p, 0, 0]`` at each way point, which the tests check).
    """
    t, points, times, segment, tau = _segments(parameters, rate_hz)
    n = t.size
    length = times[segment + 1] - times[segment]
    s, ds, dds = minimum_jerk(tau)
    step = points[segment + 1] - points[segment]
    position = np.empty((n, 3))
    velocity = np.zeros((n, 3))
    acceleration = np.zeros((n, 3))
    position[:, 0] = wall_x
    position[:, 1:] = points[segment] + step * s[:, None]
    velocity[:, 1:] = step * (ds / length)[:, None]
    acceleration[:, 1:] = step * (dds / length**2)[:, None]
    return SampledPath(
        t=t,
        position=position,
        velocity=velocity,
        acceleration=acceleration,
        rotation=np.asarray(rotation, dtype=float),
    )


def way_point_derivatives(parameters: PaintingPathParameters) -> np.ndarray:
    """(2·(N_r + 1), 2, 6) ∂[y, z]/∂x of the way points, x = [T_C, φ, Z_u, Z_l, Y_0, ΔY].

    The way points are linear in x.
    """
    derivative = np.zeros((2 * (parameters.n_steps + 1), 2, 6))
    for stroke in range(parameters.n_steps + 1):
        first, second = 2 * stroke, 2 * stroke + 1
        derivative[[first, second], 0, 4] = 1.0  # y = Y_0 + stroke·ΔY
        derivative[[first, second], 0, 5] = stroke
        low, high = (first, second) if stroke % 2 == 0 else (second, first)
        derivative[low, 1, 3] = 1.0  # z = Z_l
        derivative[high, 1, 2] = 1.0  # z = Z_u
    return derivative


def sample_path_derivatives(parameters: PaintingPathParameters, rate_hz: float) -> np.ndarray:
    """(N, 3, 6) ∂position/∂x of :func:`sample_path` at a fixed number of samples N.

    The samples sit at fixed fractions of T_C and the way-point times scale with T_C, so the
    positions do not depend on T_C (nor on φ); they move with the way points and with the
    way-point times' split of the duration (segments ∝ √length).
    """
    t, points, _times, segment, tau = _segments(parameters, rate_hz)
    d_points = way_point_derivatives(parameters)
    step = np.diff(points, axis=0)
    d_step = np.diff(d_points, axis=0)
    lengths = np.linalg.norm(step, axis=1)
    d_lengths = np.einsum("mc,mcx->mx", step, d_step) / lengths[:, None]
    weights = np.sqrt(lengths)
    d_weights = d_lengths / (2 * weights[:, None])
    cumulative = np.concatenate([[0.0], np.cumsum(weights)])
    d_cumulative = np.concatenate([np.zeros((1, 6)), np.cumsum(d_weights, axis=0)])
    total, d_total = cumulative[-1], d_cumulative[-1]
    fraction = cumulative / total  # way-point times / T_C
    d_fraction = (d_cumulative * total - cumulative[:, None] * d_total) / total**2
    # τ = (t/T_C − w_s)/(w_{s+1} − w_s)
    span = fraction[segment + 1] - fraction[segment]
    d_tau = (
        -(d_fraction[segment] + tau[:, None] * (d_fraction[segment + 1] - d_fraction[segment]))
        / span[:, None]
    )
    s, ds, _ = minimum_jerk(tau)
    derivative = np.zeros((t.size, 3, 6))
    derivative[:, 1:] = (
        d_points[segment]
        + d_step[segment] * s[:, None, None]
        + step[segment][:, :, None] * (ds[:, None] * d_tau)[:, None, :]
    )
    return derivative
