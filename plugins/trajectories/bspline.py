"""Quintic B-spline through via points (config group ``trajectory``), the paper's parameterisation (§III.A).

The motion lasts T_F seconds and interpolates ``N_P = T_F/spacing + 1`` via points, one every
``via_point_spacing`` seconds (1 s in the paper) including both ends, with zero velocity and
acceleration at both ends. Every joint uses the same clamped degree-5 B-spline basis with a knot at
each via point: ``N_P + 4`` control points, fixed by the ``N_P`` interpolation conditions and the 4
boundary conditions, so the via points are the free coefficients (rad) and the boundary conditions
hold by construction. The map via points → control points is a constant matrix, so the motion stays
linear in the via points (see :mod:`lwrlab.trajectory.parameterisation`).

As a motion source (``trajectory=bspline``) it plays given via points, inline or from a motion file
written by the excitation task (``exciting_motion.yaml``).
"""

from __future__ import annotations

from functools import cached_property
from typing import Any

import numpy as np
from scipy.interpolate import BSpline

from lwrlab.model.position_ranges import range_center, range_span
from lwrlab.model.robot import RobotModel
from lwrlab.resources import resolve_data_path
from lwrlab.trajectory.parameterisation import LinearParameterisation

DEGREE = 5
"""Quintic: the lowest degree with continuous jerk that can also pin q̇ and q̈ at both ends."""


class BSplineMotion(LinearParameterisation):
    """Quintic B-spline through via points, at rest at both ends.

    Every setting is required: conf/trajectory/bspline.yaml gives their values (the ``optimal``
    motion's ``parameterisation`` node: ``via_point_spacing`` and ``from_file``; it passes the others).

    Parameters
    ----------
    duration : T_F (s), a multiple of ``via_point_spacing``.
    via_point_spacing : time between via points (s).
    coefficients : (N_P, N_J) via points (rad), or None (a bare parameterisation).
    from_file : a motion file (``exciting_motion.yaml``) to take duration, spacing and via points from,
        or None.
    """

    kind = "bspline"
    coefficients_are_positions = True
    """The coefficients are via points (rad): the position limits bound them directly."""

    def __init__(
        self,
        *,
        duration: float,
        via_point_spacing: float,
        coefficients: Any,
        from_file: str | None,
    ) -> None:
        if from_file is not None:
            from lwrlab.io.exciting_motion import load_motion_description

            # The file's motion replaces the configured one: its own duration, spacing and via points.
            description = load_motion_description(resolve_data_path(from_file), expected_kind=self.kind)
            if "via_point_spacing" not in description:
                raise ValueError(f"{from_file}: a B-spline motion file gives its via_point_spacing (s)")
            duration, via_point_spacing = description["duration"], description["via_point_spacing"]
            coefficients = description["coefficients"]
        super().__init__(duration, coefficients)
        if not via_point_spacing > 0:
            raise ValueError(f"via_point_spacing must be positive, got {via_point_spacing}")
        intervals = self.duration / via_point_spacing
        if abs(intervals - round(intervals)) > 1e-9 or round(intervals) < 1:
            raise ValueError(
                f"duration {self.duration} s must be a positive multiple of "
                f"via_point_spacing {via_point_spacing} s"
            )
        self.via_point_spacing = float(via_point_spacing)
        self.n_intervals = round(intervals)

    @property
    def n_coefficients(self) -> int:
        """N_P: the number of via points per joint."""
        return self.n_intervals + 1

    @property
    def via_times(self) -> np.ndarray:
        """Times of the via points (s)."""
        return np.linspace(0.0, self.duration, self.n_coefficients)

    @cached_property
    def _spline(self) -> BSpline:
        """The vector-valued spline whose components are the basis functions in via-point coordinates."""
        knots = np.r_[np.zeros(DEGREE), self.via_times, np.full(DEGREE, self.duration)]
        n_control = len(knots) - DEGREE - 1  # N_P + 4
        raw = BSpline(knots, np.eye(n_control), DEGREE)
        ends = np.array([0.0, self.duration])
        # Interpolation (N_P rows) and boundary (q̇, q̈ at both ends) conditions on the control points.
        conditions = np.vstack([raw(self.via_times), raw(ends, 1), raw(ends, 2)])
        right_hand = np.vstack([np.eye(self.n_coefficients), np.zeros((4, self.n_coefficients))])
        to_control = np.linalg.solve(conditions, right_hand)  # (N_P + 4, N_P)
        return BSpline(knots, to_control, DEGREE)

    def basis(self, t: np.ndarray, derivative: int = 0) -> np.ndarray:
        """(N, N_P) basis at times t (s): column i is the motion of via point i set to 1 rad, others 0."""
        t = np.asarray(t, dtype=float)
        if t.size and (t.min() < -1e-9 or t.max() > self.duration + 1e-9):
            raise ValueError(f"times must lie in [0, {self.duration}] s")
        return self._spline(np.clip(t, 0.0, self.duration), derivative)

    def initial_coefficients(
        self, robot: RobotModel, rng: np.random.Generator, amplitude: float
    ) -> np.ndarray:
        """Via points uniform in ``middle ± amplitude·half-range`` per joint (rad); a continuous joint:
        around 0, as if its range were one turn."""
        lim = robot.limits
        middle = range_center(lim.position_lower, lim.position_upper)
        half = 0.5 * range_span(lim.position_lower, lim.position_upper)
        return middle + amplitude * half * rng.uniform(-1.0, 1.0, size=(self.n_coefficients, robot.n_joints))

    def settings(self) -> dict[str, Any]:
        return {"via_point_spacing": self.via_point_spacing}
