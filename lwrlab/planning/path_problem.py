"""Painting-path problem, eq. (12): shortest, smoothest path painting the largest area.

Search ``x = [T_C, φ, Z_u, Z_l, Y_0, ΔY]`` minimising

    T_C + w_s·Σ_j Σ_k (q̈_jk^igm)² + 1 / ((Z_u − Z_l)·ΔY)                               (eq. 12)

(q̈ of the inverse-geometric joint trajectory sampled at ``rate_hz``, the painting task's 100 Hz: the
sum scales with the rate, so the rate is part of the problem's definition; ``w_s`` = 1 is the paper's
cost) subject to, along the whole trajectory and for every joint, the position, velocity,
acceleration and torque limits (torques by inverse dynamics of the robot *with its tool*, friction
included), the wall bounds (the roller, of width w_L, stays on the wall), Z_l ≤ Z_u, ΔY ≤ w_L (no
unpainted stripe between two strokes), the arm's reach, and a distance to the three
singularities of the analytic IK (|sin q2|, |sin q4|, |sin q6| ≥ ``singularity_margin``), which keeps
the chosen branch continuous: no branch flip along the path.

:class:`PathProblem` evaluates the cost and the constraints, and their analytic gradients
(:meth:`PathProblem.cost_gradient`, :meth:`PathProblem.constraint_jacobian`, computed in
:mod:`lwrlab.planning.path_gradients`). Every constraint is written ``g(x) ≥ 0`` and named, so an
infeasible problem ends with an error naming the violated constraints. The solver is
:func:`lwrlab.planning.path_optimisation.optimise_path`.
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass, field

import numpy as np

from lwrlab.kinematics.swivel_ik import Branch, SwivelIK
from lwrlab.model.robot import RobotModel
from lwrlab.planning import path_gradients
from lwrlab.planning.painting_path import (
    TOOL_ORIENTATION,
    PaintingPathParameters,
    SampledPath,
    sample_path,
)
from lwrlab.planning.path_gradients import TrajectoryDerivatives

PAPER_SMOOTHNESS_WEIGHT = 1.0
"""w_s of eq. (12) as the paper writes it: the three terms summed unweighted."""


@dataclass(frozen=True)
class WallBounds:
    """Where the tool centre point may go on the wall (m)."""

    x: float
    y_min: float
    y_max: float
    z_min: float
    z_max: float


@dataclass
class PathProblem:
    """Eq. (12) for one robot + tool and one wall.

    Parameters
    ----------
    robot : the robot with the tool's inertia (identified model), for the torque limits.
    ik : the analytic IK of the robot.
    tcp_in_flange : (4, 4) tool centre point in the flange frame.
    wall : the wall bounds.
    roller_width : w_L (m), from tool recognition.
    n_steps : N_r.
    branch : IK branch.
    rate_hz : sampling rate N_S/T_C of the sum of squared accelerations in the cost (Hz): the sum
        is computed as ``rate_hz·∫ q̈² dt`` on the search grid.
    search_rate_hz : sampling rate of the joint trajectory during the search (Hz); the solution is
        checked again at 1 kHz by the caller. The paths are slow (segments of seconds), 10 Hz resolves them.
    torque_stride : torques are checked every ``torque_stride`` samples of the search grid (they stay
        far from their limits on these slow paths).
    duration_bounds : bounds on T_C (s).
    min_stroke : smallest Z_u − Z_l (m).
    singularity_margin : smallest |sin q2|, |sin q4|, |sin q6| along the path.
    stripe_overlap : least overlap of two neighbouring stripes (m): ΔY ≤ w_L − overlap (the paper's
        ΔY ≤ w_L leaves no gap on the planned path; the overlap absorbs the tracking error in contact).
    smoothness_weight, rotation : constants, not settings: the paper's w_s (eq. 12) and the tool's
        orientation on a wall facing +x (:data:`~lwrlab.planning.painting_path.TOOL_ORIENTATION`).

    The settings from ``n_steps`` on are keyword-only, without defaults: the painting task's
    ``n_steps`` and ``path`` (conf/task/painting.yaml) hold their values.
    """

    robot: RobotModel
    ik: SwivelIK
    tcp_in_flange: np.ndarray
    wall: WallBounds
    roller_width: float
    _: KW_ONLY
    n_steps: int
    branch: Branch
    rate_hz: float
    search_rate_hz: float
    torque_stride: int
    duration_bounds: tuple[float, float]
    min_stroke: float
    singularity_margin: float
    stripe_overlap: float
    smoothness_weight: float = PAPER_SMOOTHNESS_WEIGHT
    rotation: np.ndarray = field(default_factory=lambda: TOOL_ORIENTATION.copy())
    _memo: tuple | None = field(default=None, init=False, repr=False)
    _derivative_memo: tuple | None = field(default=None, init=False, repr=False)
    _torque_memo: tuple | None = field(default=None, init=False, repr=False)
    flange_in_tcp: np.ndarray = field(init=False, repr=False)
    """(4, 4) inverse of ``tcp_in_flange``, computed once."""

    def __post_init__(self) -> None:
        self.flange_in_tcp = np.linalg.inv(self.tcp_in_flange)

    def parameters(self, x: np.ndarray) -> PaintingPathParameters:
        return PaintingPathParameters.from_vector(x, self.n_steps)

    def path(self, x: np.ndarray, rate_hz: float | None = None) -> SampledPath:
        return sample_path(self.parameters(x), self.wall.x, rate_hz or self.rate_hz, self.rotation)

    def flange_poses(self, path: SampledPath) -> np.ndarray:
        return path.poses() @ self.flange_in_tcp

    def joint_trajectory(
        self, x: np.ndarray, rate_hz: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """t, q, q̇, q̈ of the IK trajectory (s, rad, rad/s, rad/s²); q̇, q̈ by second-order differences.

        Sampled at ``rate_hz`` (default ``search_rate_hz``); memoised for the last ``x``.
        """
        key = (tuple(np.asarray(x, dtype=float)), rate_hz)
        if self._memo is not None and self._memo[0] == key:
            return self._memo[1]
        path = self.path(x, rate_hz or self.search_rate_hz)
        q = self.ik.solve_branch(self.flange_poses(path), float(x[1]), self.branch).q
        dt = path.t[1] - path.t[0]
        dq = np.gradient(q, dt, axis=0, edge_order=2)
        ddq = np.gradient(dq, dt, axis=0, edge_order=2)
        self._memo = (key, (path.t, q, dq, ddq))
        return path.t, q, dq, ddq

    def trajectory_derivatives(self, x: np.ndarray) -> TrajectoryDerivatives:
        """The search-grid trajectory with its derivatives in x (:mod:`lwrlab.planning.path_gradients`);
        memoised for the last ``x``."""
        key = tuple(np.asarray(x, dtype=float))
        if self._derivative_memo is not None and self._derivative_memo[0] == key:
            return self._derivative_memo[1]
        result = path_gradients.trajectory_derivatives(self, x)
        self._derivative_memo = (key, result)
        # the same trajectory for the constraints and the cost
        self._memo = ((key, None), (result.t, result.q, result.dq, result.ddq))
        return result

    def strided_torques(self, x: np.ndarray) -> np.ndarray:
        """(N / torque_stride, N_J) joint torques (N·m) every ``torque_stride`` samples.

        Memoised for the last ``x``.
        """
        key = tuple(np.asarray(x, dtype=float))
        if self._torque_memo is None or self._torque_memo[0] != key:
            _, q, dq, ddq = self.joint_trajectory(x)
            stride = self.torque_stride
            self._torque_memo = (key, self.robot.inverse_dynamics(q[::stride], dq[::stride], ddq[::stride]))
        return self._torque_memo[1]

    # --- eq. (12) --------------------------------------------------------------------------
    def geometric_constraints(self, x: np.ndarray) -> dict[str, float]:
        """Wall bounds, ordering, coverage (≥ 0 when satisfied), m."""
        p = self.parameters(x)
        half = self.roller_width / 2
        return {
            "Z_l ≥ Z⁻": p.z_lower - self.wall.z_min,
            "Z_u ≤ Z⁺": self.wall.z_max - p.z_upper,
            "Z_u − Z_l ≥ min stroke": p.z_upper - p.z_lower - self.min_stroke,
            "Y_0 − w_L/2 ≥ Y⁻": p.y_start - half - self.wall.y_min,
            "Y_0 + N_r·ΔY + w_L/2 ≤ Y⁺": self.wall.y_max - (p.y_end + half),
            "ΔY ≤ w_L − overlap": self.roller_width - self.stripe_overlap - p.y_step,
            "ΔY > 0": p.y_step - 1e-3,
        }

    def reach_constraints(self, x: np.ndarray) -> dict[str, float]:
        """Shoulder–wrist distance inside the reach, with 2 % margin (m)."""
        path = self.path(x, self.search_rate_hz)
        wrist = self.ik.wrist_pose(self.flange_poses(path))[:, :3, 3]
        distance = np.linalg.norm(wrist - [0.0, 0.0, self.ik.shoulder_height], axis=1)
        low, high = self.ik.reach
        return {
            "reach (outer)": 0.98 * high - distance.max(),
            "reach (inner)": distance.min() - 1.02 * low - 0.01,
        }

    def joint_constraints(self, x: np.ndarray) -> dict[str, float]:
        """Normalised margins of every joint limit along the trajectory (≥ 0 when satisfied)."""
        _, q, dq, ddq = self.joint_trajectory(x)
        lim = self.robot.limits
        tau = self.strided_torques(x)
        span = lim.position_upper - lim.position_lower
        margins = {}
        for j in range(self.robot.n_joints):
            margins[f"q{j + 1} ≥ lower"] = (q[:, j].min() - lim.position_lower[j]) / span[j]
            margins[f"q{j + 1} ≤ upper"] = (lim.position_upper[j] - q[:, j].max()) / span[j]
            margins[f"|q̇{j + 1}| ≤ limit"] = 1.0 - np.abs(dq[:, j]).max() / lim.velocity[j]
            margins[f"|q̈{j + 1}| ≤ limit"] = 1.0 - np.abs(ddq[:, j]).max() / lim.acceleration[j]
            margins[f"|Γ{j + 1}| ≤ limit"] = 1.0 - np.abs(tau[:, j]).max() / lim.torque[j]
        sines = np.abs(np.sin(q[:, [1, 3, 5]])).min(axis=0)
        for name, value in zip(("shoulder", "elbow", "wrist"), sines, strict=True):
            margins[f"{name} singularity margin"] = value - self.singularity_margin
        return margins

    def constraints(self, x: np.ndarray) -> dict[str, float]:
        """Every constraint of eq. (12) by name, ``≥ 0`` when satisfied."""
        values, _ = self.constraints_and_stage(x)
        return values

    @staticmethod
    def _is_degenerate(geometric: dict[str, float], min_stroke: float) -> bool:
        """Coinciding way points (Z_u = Z_l or ΔY ≤ 0): no path to evaluate."""
        return geometric["Z_u − Z_l ≥ min stroke"] + min_stroke <= 1e-6 or geometric["ΔY > 0"] < 0

    def constraints_and_stage(self, x: np.ndarray) -> tuple[dict[str, float], str]:
        """The constraints and how far they were evaluated: ``geometric``, ``reach`` or ``joints``."""
        values = self.geometric_constraints(x)
        if self._is_degenerate(values, self.min_stroke):
            # degenerate path (coinciding way points): nothing else can be evaluated
            return {
                **values,
                "reach (outer)": -1.0,
                "reach (inner)": -1.0,
                **dict.fromkeys(self.joint_constraint_names, -1.0),
            }, "geometric"
        values.update(self.reach_constraints(x))
        if min(values.values()) < -0.05 or values["reach (outer)"] < 0 or values["reach (inner)"] < 0:
            # out of reach: the joint trajectory does not exist; report it as violated
            values.update(dict.fromkeys(self.joint_constraint_names, -1.0))
            return values, "reach"
        values.update(self.joint_constraints(x))
        return values, "joints"

    def constraint_values(self, x: np.ndarray) -> np.ndarray:
        """The values of :meth:`constraints` as a vector, in its order (SLSQP's ``g(x) ≥ 0``)."""
        return np.array(list(self.constraints(x).values()))

    def constraint_jacobian(self, x: np.ndarray) -> np.ndarray:
        """(N_constraints, 6) ∂g/∂x of :meth:`constraints`, rows in its order (placeholders: zero rows)."""
        return path_gradients.constraint_jacobian(self, x)

    @property
    def joint_constraint_names(self) -> list[str]:
        names = []
        for j in range(1, self.robot.n_joints + 1):
            names += [
                f"q{j} ≥ lower",
                f"q{j} ≤ upper",
                f"|q̇{j}| ≤ limit",
                f"|q̈{j}| ≤ limit",
                f"|Γ{j}| ≤ limit",
            ]
        return names + [f"{n} singularity margin" for n in ("shoulder", "elbow", "wrist")]

    def cost_terms(self, x: np.ndarray) -> dict[str, float]:
        """The three terms of eq. (12)."""
        p = self.parameters(x)
        try:
            t, _, _, ddq = self.joint_trajectory(x)
            # ≈ Σ_k Σ_j q̈² at rate_hz
            smoothness = float(self.rate_hz * np.trapezoid(np.sum(ddq**2, axis=1), t))
        except ValueError:  # degenerate or unreachable path: the constraints say so
            smoothness = 1e6
        return {
            "duration": p.duration,
            "smoothness": self.smoothness_weight * smoothness,
            "inverse_area": 1.0 / max((p.z_upper - p.z_lower) * p.y_step, 1e-6),
        }

    def cost(self, x: np.ndarray) -> float:
        return float(sum(self.cost_terms(x).values()))

    def cost_gradient(self, x: np.ndarray) -> np.ndarray:
        """(6,) ∂cost/∂x of eq. (12) (:func:`lwrlab.planning.path_gradients.cost_gradient`)."""
        return path_gradients.cost_gradient(self, x)
