"""The optimal-exciting-motion problem, eq. (10): criterion, constraints and parameterisation.

Decision variables: the coefficients ``C`` (n_coefficients, N_J) of a linear parameterisation (the
via points of the paper's B-spline), flattened row-major into ``x``. On the optimisation grid (100 Hz
in the paper) the motion is ``q = B·C``, ``q̇ = Ḃ·C``, ``q̈ = B̈·C`` and the criterion is evaluated on the
column-scaled base regressor. Its gradient is chained exactly::

    ∂J/∂C = Bᵀ·∂J/∂q + Ḃᵀ·∂J/∂q̇ + B̈ᵀ·∂J/∂q̈,    ∂J/∂(q, q̇, q̈) = Σ_{j,p} (∂J/∂W)[k, j, p]·∂W[k, j, p]/∂(q, q̇, q̈)

with ``∂J/∂W`` the criterion's gradient scaled back and spread onto the base columns, and the
vector–Jacobian product of :func:`lwrlab.dynamics.regressor_vjp.regressor_vjp`.

Constraints: each column of each family of :class:`~lwrlab.excitation.constraints.ConstraintSet` is
aggregated over time windows of ``window_s`` seconds into the window's smallest slack (divided by
the column's scale), ``g ≥ 0``. This is exact on the grid (every sample is inside some window) while
keeping a few hundred constraints instead of tens of thousands; its gradient is that of the
minimising sample, computed only there.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.dynamics.regressor_vjp import regressor_vjp
from lwrlab.errors import ConfigError
from lwrlab.excitation.constraints import ConstraintSet, ConstraintSettings
from lwrlab.excitation.criteria import Criterion, DesignSpace, bound_criterion, column_scales
from lwrlab.excitation.known_information import ConditionedCriterion, KnownInformation
from lwrlab.model.position_ranges import finite_range, range_center
from lwrlab.model.robot import RobotModel
from lwrlab.trajectory.parameterisation import LinearParameterisation


def require_motion_limits(robot: RobotModel) -> None:
    """Stop at once, in one line naming the setting, when a limit the optimiser needs is unknown."""
    lim = robot.limits
    for name, values, setting in (
        ("acceleration", lim.acceleration, "robot.acceleration_limits=<rad/s², one value or one per joint> "
         "or robot.joint_limits=<MoveIt joint_limits.yaml>"),
        ("velocity", lim.velocity, "the URDF's <limit velocity> or robot.joint_limits"),
        ("torque", lim.torque, "the URDF's <limit effort>"),
    ):  # fmt: skip
        unknown = [robot.joint_names[j] for j in np.flatnonzero(~(np.isfinite(values) & (values > 0)))]
        if unknown:
            raise ConfigError(
                f"{robot.name}: no {name} limit for joint(s) {unknown}, which an exciting motion must "
                f"respect: set {setting}"
            )


@dataclass
class _Evaluation:
    """Everything computed at one point x (cached: optimisers ask for value and gradient separately)."""

    x: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    full_regressor: np.ndarray
    """(N, N_J, P)."""
    cost: float | None = None
    cost_error: str | None = None
    cost_gradient: np.ndarray | None = None
    slacks: dict[str, np.ndarray] | None = None
    windowed: list[WindowedSlack] | None = None
    extras: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class WindowedSlack:
    """The aggregated constraints of one family: smallest scaled slack per (window, column)."""

    family: str
    values: np.ndarray
    """(windows, columns) smallest slack / scale in each window."""
    samples: np.ndarray
    """(windows, columns) the sample index where it is reached."""


class ExcitationProblem:
    """Criterion + constraints + parameterisation for one robot (see the module docstring).

    The settings (constraints, grid, window, smoothing) are those of the ``optimal`` trajectory
    (conf/trajectory/optimal.yaml), which builds the problem (``OptimalExcitingMotion.problem``).

    Parameters
    ----------
    robot : the nominal (CAD) robot: its regressor, limits, friction and collision spheres.
    parameterisation : a bare linear parameterisation (its duration is the motion's).
    criterion : the criterion plugin.
    constraints : the constraint settings.
    rate_hz : optimisation grid rate (Hz), 100 in the paper.
    window_s : constraint aggregation window (s).
    base : the robot's base parameters (computed if None).
    coulomb_smoothing : ε (rad/s): the Coulomb columns ``sign(q̇)`` of the regressor become
        ``tanh(q̇/ε)`` during the optimisation. A sign flips whenever a velocity sample crosses zero,
        which makes the criterion and the torques jump and stalls SLSQP's line search; the smooth
        version differs only on the few samples with |q̇| ≲ ε. None keeps the sign.
    known : information already in hand (:mod:`lwrlab.excitation.known_information`), in these base
        parameters: the criterion then scores the known rows stacked on the motion's
        (:class:`~lwrlab.excitation.known_information.ConditionedCriterion`). None: nothing known.

    A criterion with a ``bind(space)`` method (one aimed at target motions) is bound to this robot's
    :class:`~lwrlab.excitation.criteria.DesignSpace` first; ``criterion`` is the one optimised.
    """

    def __init__(
        self,
        robot: RobotModel,
        parameterisation: LinearParameterisation,
        criterion: Criterion,
        constraints: ConstraintSettings,
        *,
        rate_hz: float,
        window_s: float,
        coulomb_smoothing: float | None,
        base: BaseParameters | None = None,
        known: KnownInformation | None = None,
    ) -> None:
        require_motion_limits(robot)
        self.robot = robot
        self.parameterisation = parameterisation
        self.coulomb_smoothing = coulomb_smoothing if "coulomb" in robot.friction_terms else None
        self.constraint_set = ConstraintSet(robot, constraints, self.coulomb_smoothing)
        if self.coulomb_smoothing is not None:
            start = 10 * robot.n_links + robot.friction_terms.index("coulomb") * robot.n_joints
            self._coulomb_columns = start + np.arange(robot.n_joints)
        self.rate_hz = float(rate_hz)
        self.base = base if base is not None else compute_base_parameters(robot)
        self.scales = column_scales(robot, self.base)
        self.design_criterion = bound_criterion(criterion, DesignSpace(robot, self.base, self.scales))
        """The criterion bound to this robot, before conditioning (its targets, if it has some)."""
        self.criterion = self.design_criterion
        self.known = known
        if known is not None:
            if known.names != self.base.names:
                raise ValueError(
                    "the known information is about other base parameters than the design's "
                    f"({len(known.names)} vs {self.base.count}): build it with this robot's base parameters"
                )
            rows = known.rows(self.scales, self.rate_hz)
            self.criterion = ConditionedCriterion(self.criterion, rows, known.joint_weights())
        self.times = parameterisation.times(rate_hz)
        self.bases = parameterisation.bases(self.times)
        self.parameters = robot.parameters
        samples_per_window = max(1, round(window_s * rate_hz))
        # The last sample (at rest) joins the last window rather than making one of its own.
        self.window_starts = np.arange(0, max(len(self.times) - 1, 1), samples_per_window)
        self._cache: _Evaluation | None = None
        self._safe_poses: dict[tuple[int, int], np.ndarray] = {}
        self._safe_slacks: dict[tuple[int, int], float] = {}

    # --- variables ------------------------------------------------------------------------------

    @property
    def coefficient_shape(self) -> tuple[int, int]:
        return self.parameterisation.n_coefficients, self.robot.n_joints

    @property
    def n_variables(self) -> int:
        return int(np.prod(self.coefficient_shape))

    def coefficients(self, x: np.ndarray) -> np.ndarray:
        """``C`` (n_coefficients, N_J) from the flat variables."""
        return np.asarray(x, dtype=float).reshape(self.coefficient_shape)

    def bounds(self) -> list[tuple[float | None, float | None]] | None:
        """Box bounds of the variables if the parameterisation's coefficients are positions (B-spline);
        None for a continuous joint's."""
        if not self.parameterisation.coefficients_are_positions:
            return None
        low, high = self.constraint_set.position_bounds
        joint_bounds = [
            (float(lo) if np.isfinite(lo) else None, float(hi) if np.isfinite(hi) else None)
            for lo, hi in zip(low, high, strict=True)
        ]
        return [joint_bounds[j] for _ in range(self.coefficient_shape[0]) for j in range(self.robot.n_joints)]

    # --- starting points ------------------------------------------------------------------------

    @property
    def middle_pose(self) -> np.ndarray:
        """(N_J,) the middle of every joint's position range (rad), 0 for a continuous joint."""
        return range_center(self.robot.limits.position_lower, self.robot.limits.position_upper)

    def still_motion(self, pose: np.ndarray) -> np.ndarray:
        """The flat coefficients of the motion that stays at ``pose`` (least squares on the grid: exact
        for parameterisations that can stand still)."""
        b = self.bases[0]
        target = np.broadcast_to(np.asarray(pose, dtype=float), (len(self.times), self.robot.n_joints))
        return np.linalg.lstsq(b, target, rcond=None)[0].ravel()

    def safe_pose(self, n_candidates: int = 500, seed: int = 0) -> np.ndarray:
        """The random pose (within the position bounds; one turn around 0 for a continuous joint) farthest
        from violating any constraint at rest: the largest smallest scaled slack over every family,
        distances in metres. Found once per problem (every start of an optimiser asks for it)."""
        if (n_candidates, seed) in self._safe_poses:
            return self._safe_poses[(n_candidates, seed)]
        rng = np.random.default_rng(seed)
        low, high = finite_range(*self.constraint_set.position_bounds)
        poses = np.vstack(
            [self.middle_pose, rng.uniform(low, high, size=(n_candidates, self.robot.n_joints))]
        )
        still = np.zeros_like(poses)
        slacks = self.constraint_set.slacks(poses, still, still)
        worst = np.min(
            [np.min(slack / self.constraint_set.scales(family), axis=1) for family, slack in slacks.items()],
            axis=0,
        )
        best = int(np.argmax(worst))
        self._safe_poses[(n_candidates, seed)] = poses[best]
        self._safe_slacks[(n_candidates, seed)] = float(worst[best])
        return self._safe_poses[(n_candidates, seed)]

    def safe_pose_slack(self, n_candidates: int = 500, seed: int = 0) -> float:
        """The smallest scaled slack of :meth:`safe_pose` at rest (distances in metres, the limits as
        fractions of them): below the distance margin, even the safest pose rests against a
        constraint, and the feasible region around any still motion is narrow."""
        self.safe_pose(n_candidates, seed)
        return self._safe_slacks[(n_candidates, seed)]

    # --- evaluation -----------------------------------------------------------------------------

    def _evaluate(self, x: np.ndarray) -> _Evaluation:
        x = np.asarray(x, dtype=float)
        if self._cache is not None and np.array_equal(self._cache.x, x):
            return self._cache
        c = self.coefficients(x)
        q, dq, ddq = (b @ c for b in self.bases)
        full = regressor(self.robot, q, dq, ddq, stacked=False)
        if self.coulomb_smoothing is not None:
            joints = np.arange(self.robot.n_joints)
            full[:, joints, self._coulomb_columns] = np.tanh(dq / self.coulomb_smoothing)
        self._cache = _Evaluation(x.copy(), q, dq, ddq, full)
        return self._cache

    def scaled_base_regressor(self, x: np.ndarray) -> np.ndarray:
        """``W_b·diag(s)`` (N·N_J, N_B) of the motion ``x`` on the optimisation grid."""
        ev = self._evaluate(x)
        return self.base.base_regressor(ev.full_regressor.reshape(-1, self.robot.n_parameters)) * self.scales

    def _criterion(self, ev: _Evaluation) -> None:
        if ev.cost is None and ev.cost_error is None:
            try:
                ev.cost, ev.extras["criterion_gradient"] = self.criterion.value_and_gradient(
                    self.scaled_base_regressor(ev.x)
                )
            except np.linalg.LinAlgError as error:
                ev.cost_error = str(error)

    def objective(self, x: np.ndarray) -> float:
        """The criterion J of the motion ``x`` (unit-free); +inf where W_b loses rank."""
        ev = self._evaluate(x)
        self._criterion(ev)
        return float(ev.cost) if ev.cost is not None else float("inf")

    def objective_gradient(self, x: np.ndarray) -> np.ndarray:
        """``∂J/∂x`` by the exact chain of the module docstring."""
        ev = self._evaluate(x)
        self._criterion(ev)
        if ev.cost is None:
            raise np.linalg.LinAlgError(f"no gradient where the criterion is undefined: {ev.cost_error}")
        if ev.cost_gradient is None:
            n, p = self.robot.n_joints, self.robot.n_parameters
            weights = np.zeros((len(self.times) * n, p))
            weights[:, self.base.columns] = ev.extras["criterion_gradient"] * self.scales
            grad_q, grad_dq, grad_ddq = regressor_vjp(self.robot, ev.q, ev.dq, ev.ddq, weights)
            if self.coulomb_smoothing is not None:  # the VJP differentiates sign(q̇): add tanh's slope
                joints = np.arange(self.robot.n_joints)
                weight = weights.reshape(len(self.times), self.robot.n_joints, -1)[
                    :, joints, self._coulomb_columns
                ]
                grad_dq = (
                    grad_dq
                    + weight * (1.0 - np.tanh(ev.dq / self.coulomb_smoothing) ** 2) / self.coulomb_smoothing
                )
            ev.cost_gradient = self.parameterisation.pull_back(self.bases, grad_q, grad_dq, grad_ddq).ravel()
        return ev.cost_gradient.copy()

    # --- constraints ----------------------------------------------------------------------------

    def _slacks(self, ev: _Evaluation) -> dict[str, np.ndarray]:
        if ev.slacks is None:
            torque = ev.full_regressor @ self.parameters
            ev.slacks = self.constraint_set.slacks(ev.q, ev.dq, ev.ddq, torque, windows=self.window_starts)
        return ev.slacks

    def windowed_slacks(self, x: np.ndarray) -> list[WindowedSlack]:
        """Each family's smallest scaled slack per (window, column), and where it is reached."""
        ev = self._evaluate(x)
        if ev.windowed is None:
            ev.windowed = [
                self._windowed(family, slack / self.constraint_set.scales(family))
                for family, slack in self._slacks(ev).items()
            ]
        return ev.windowed

    def _windowed(self, family: str, scaled: np.ndarray) -> WindowedSlack:
        """Smallest ``scaled`` slack (N, columns) per window: every window but the last has the same
        length, so they are one reshape and one argmin; the last (with the final sample) is another."""
        starts = self.window_starts
        length = starts[1] - starts[0] if len(starts) > 1 else len(scaled)
        whole = scaled[: starts[-1]].reshape(len(starts) - 1, length, -1)
        samples = np.vstack(
            [
                starts[:-1, None] + np.argmin(whole, axis=1),
                starts[-1] + np.argmin(scaled[starts[-1] :], axis=0),
            ]
        )
        return WindowedSlack(family, np.take_along_axis(scaled, samples, axis=0), samples)

    def constraint_values(self, x: np.ndarray) -> np.ndarray:
        """All aggregated constraints ``g(x) ≥ 0`` (unit-free), family by family, window-major."""
        return np.concatenate([w.values.ravel() for w in self.windowed_slacks(x)])

    def constraint_jacobian(self, x: np.ndarray) -> np.ndarray:
        """``∂g/∂x`` (n_constraints, n_variables): each row the derivative at its minimising sample."""
        ev = self._evaluate(x)
        b, db, ddb = self.bases
        rows = []
        for windowed in self.windowed_slacks(x):
            samples = windowed.samples.ravel()
            columns = np.tile(np.arange(windowed.samples.shape[1]), windowed.samples.shape[0])
            d_q, d_dq, d_ddq = self.constraint_set.slack_derivatives(
                windowed.family, ev.q, ev.dq, ev.ddq, samples, columns
            )
            scale = self.constraint_set.scales(windowed.family)[columns][:, None, None]
            # ∂g/∂C[i, l] = B[k, i]·∂g/∂q_l + Ḃ[k, i]·∂g/∂q̇_l + B̈[k, i]·∂g/∂q̈_l at the minimising sample k
            jac = (
                b[samples][:, :, None] * d_q[:, None]
                + db[samples][:, :, None] * d_dq[:, None]
                + ddb[samples][:, :, None] * d_ddq[:, None]
            )
            rows.append((jac / scale).reshape(len(samples), -1))
        return np.vstack(rows)

    def constraint_labels(self) -> list[str]:
        """A label per aggregated constraint: family, column, window (for reports)."""
        labels = []
        window = self.window_starts / self.rate_hz
        for family in self.constraint_set.families():
            columns = self.constraint_set.column_labels(family)
            labels += [f"{family} {c} (window from t = {t:.2f} s)" for t in window for c in columns]
        return labels
