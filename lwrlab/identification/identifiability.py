"""What the data can identify: rank, conditioning and weak directions of the base regressor.

An estimator fed a badly exciting motion still returns numbers; this module says whether they mean
anything. :func:`assess_identifiability` looks at the base regressor ``W_b`` of the processed data
and the joint states behind it and returns an :class:`IdentifiabilityReport`:

- the numerical rank and ``cond`` of the column-scaled ``W_b`` (every column divided by its norm, so
  that parameters of different units compare: the ``cond_`` the estimators report);
- the smallest singular values with their right singular vectors: a direction ``v`` with a small
  singular value is a combination ``Σ v_i·φ_i`` of (scaled) base parameters that the data hardly
  see, so the estimate of that combination is noise (or comes from a prior);
- per joint, how much it moved (range of q, peak |q̇|, peak |q̈|, also as fractions of the limits),
  and which joints never moved.

Status: ``rank_deficient`` when the rank is below the number of columns, ``poor`` when
``cond_scaled`` exceeds ``poor_cond`` or a joint never moved (its measured velocity is then noise, so
its friction columns look well conditioned and mean nothing), else ``good``. The defaults come from
the simulated identification (``task=identification``: 1 kHz with the plant's noise, filtered and
decimated to 50 Hz; the error is ‖β̂ − β‖/‖β‖ against the simulated truth):

======================================  ============  ======================  ==================
exciting motion (LWR4 unless named)     cond_scaled   base-parameter error    cross-val. NRMS
======================================  ============  ======================  ==================
shipped optimal motion (logdet, 10 s)   8.1           1.2 %                   3.6 % (noise floor)
multisine, 80 % of the limits           12.6          0.8 %                   3.6 %
multisine, 3 s                          140           3.3 %
Panda, multisine, 3 s                   172           5.4 %
multisine, 20 % of the limits           175           5.5 %                   4.2 %
multisine, 10 %                         743           30 %                    10 %
multisine, 7 %                          1.5e3         82 %                    19 %
multisine, 5 %                          3.0e3         220 %                   47 %
multisine, 0.1 %, 2 harmonics           3.5e6         2.2e8 %                 1.4e7 %
======================================  ============  ======================  ==================

The error grows about in proportion to the condition number (≈ 4e-4·cond at this noise level), so
``poor_cond = 500`` flags motions whose estimates are off by a fifth or more, while short but sound
motions (3 s, cond ≤ 175) stay ``good`` with a margin of 3 and the optimised motion with one of 60.
The rank tolerance ``rank_rtol = √ε ≈ 1.5e-8`` marks directions whose normal equations (``cond²``)
are singular in double precision.

Nothing here prints or logs: callers print :meth:`IdentifiabilityReport.warning_text` and tag
:attr:`IdentifiabilityReport.status`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pandas as pd

from lwrlab.model.position_ranges import range_span
from lwrlab.model.robot import FRICTION_TERMS, MotionLimits

STATUSES = ("good", "poor", "rank_deficient")
"""Possible values of :attr:`IdentifiabilityReport.status`, best first."""

DEFAULT_POOR_COND = 500.0
"""cond of the column-scaled ``W_b`` above which the identification is ``poor`` (see module doc)."""
DEFAULT_RANK_RTOL = float(np.sqrt(np.finfo(float).eps))
"""Singular values below ``rank_rtol·σ_max`` (column-scaled ``W_b``) count as zero."""
DEFAULT_STILL_RANGE = 1e-3
"""rad: a joint whose position range stays below this (and whose peak |q̇| below
:data:`DEFAULT_STILL_VELOCITY`) never moved; encoder noise and drift of a held joint stay below."""
DEFAULT_STILL_VELOCITY = 1e-2
"""rad/s: see :data:`DEFAULT_STILL_RANGE`."""
DEFAULT_LOW_FRACTION = 0.05
"""A joint moving over less than this fraction of its position range is named as weakly excited."""


class ExcitationLimits(MotionLimits, Protocol):
    """What is read of the robot's limits (:class:`lwrlab.model.robot.JointLimits` has it)."""

    @property
    def acceleration(self) -> np.ndarray:
        """(N_J,) largest absolute joint accelerations (rad/s²)."""
        ...


@dataclass(frozen=True)
class SingularDirection:
    """A right singular vector of the column-scaled base regressor."""

    relative_singular_value: float
    """σ_i / σ_max of the column-scaled ``W_b`` (0 for a direction the data do not see at all)."""
    vector: np.ndarray
    """(n_columns,) unit vector in column-scaled base-parameter coordinates, its largest entry
    positive: the data determine ``φ_b`` well except along ``Σ vector_i·‖w_i‖·φ_b,i``."""
    terms: tuple[tuple[str, float], ...]
    """The base parameters with the largest weights, largest first, ``(name, weight)``; as many as
    it takes to cover 90 % of the vector's squared norm (at most ``max_terms``)."""

    def describe(self) -> str:
        """The combination as text, e.g. ``"XX5R (0.71) - ZZ5R (0.70)"``; ``"FV5"`` for one parameter."""
        if len(self.terms) == 1 and abs(self.terms[0][1]) > 0.99:
            return self.terms[0][0]
        parts = []
        for position, (name, weight) in enumerate(self.terms):
            sign = "" if position == 0 and weight >= 0 else ("- " if weight < 0 else "+ ")
            parts.append(f"{sign}{name} ({abs(weight):.2f})")
        return " ".join(parts)


@dataclass(frozen=True)
class IdentifiabilityReport:
    """How well the data determine each base parameter; see :func:`assess_identifiability`."""

    status: str
    """``good``, ``poor`` or ``rank_deficient`` (:data:`STATUSES`)."""
    rank: int
    """Numerical rank of the column-scaled ``W_b`` (relative tolerance ``rank_rtol``)."""
    n_columns: int
    """Number of base parameters (columns of ``W_b``)."""
    cond_scaled: float
    """Condition number of the column-scaled ``W_b`` (inf when rank deficient to machine zero)."""
    singular_values: np.ndarray
    """(n_columns,) singular values of the column-scaled ``W_b`` over the largest, descending."""
    weak_directions: tuple[SingularDirection, ...]
    """Every direction with σ_i/σ_max below ``1/poor_cond`` or the rank tolerance, weakest first:
    what the data cannot determine (empty when ``good``)."""
    smallest_directions: tuple[SingularDirection, ...]
    """The few weakest directions, whatever the status (for the record of a good run too)."""
    still_joints: tuple[int, ...]
    """Joints (1-based) that never moved: position range and peak |q̇| below the thresholds."""
    per_joint: pd.DataFrame
    """Per joint (index ``joint``, 1-based): ``q_range`` (rad), ``dq_peak`` (rad/s), ``ddq_peak``
    (rad/s²), ``still`` (bool) and, with limits, ``q_range_fraction`` (of upper − lower),
    ``dq_peak_fraction``, ``ddq_peak_fraction`` (of the limits)."""
    messages: tuple[str, ...]
    """The findings as lines of text: summary, weak directions, still or weakly moving joints."""
    parameter_names: tuple[str, ...]
    """Names of the base parameters, in column order."""
    poor_cond: float
    """The threshold used for ``poor``."""

    @property
    def ok(self) -> bool:
        """Whether the status is ``good``."""
        return self.status == "good"

    def summary(self) -> str:
        """One line: status, rank, cond."""
        return self.messages[0]

    def warning_text(self) -> str:
        """A multi-line warning for the console, or ``""`` when the status is ``good``."""
        if self.ok:
            return ""
        head, *rest = self.messages
        return "\n".join([f"WARNING: {head}", *(f"  {line}" for line in rest)])

    def metrics(self) -> dict[str, float]:
        """Numbers worth logging: ``identifiability_rank``, ``identifiability_rank_deficiency``,
        ``cond_W_b_scaled``, ``smallest_relative_singular_value``, ``still_joints``."""
        return {
            "identifiability_rank": float(self.rank),
            "identifiability_rank_deficiency": float(self.n_columns - self.rank),
            "cond_W_b_scaled": float(self.cond_scaled),
            "smallest_relative_singular_value": float(self.singular_values[-1]) if self.n_columns else 0.0,
            "still_joints": float(len(self.still_joints)),
        }


def _column_scaled(w_base: np.ndarray) -> np.ndarray:
    # zero columns stay zero: their direction then has σ = 0 and names the parameter alone
    norms = np.linalg.norm(w_base, axis=0)
    return w_base / np.where(norms > 0, norms, 1.0)


def _direction(
    relative: float, vector: np.ndarray, names: Sequence[str], max_terms: int
) -> SingularDirection:
    order = np.argsort(-np.abs(vector), kind="stable")
    vector = vector * (1.0 if vector[order[0]] >= 0 else -1.0)
    covered, terms = 0.0, []
    for index in order[:max_terms]:
        terms.append((names[index], float(vector[index])))
        covered += float(vector[index] ** 2)
        if covered >= 0.9:
            break
    return SingularDirection(relative_singular_value=float(relative), vector=vector, terms=tuple(terms))


def joint_excitation(
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    limits: ExcitationLimits | None = None,
    still_range: float = DEFAULT_STILL_RANGE,
    still_velocity: float = DEFAULT_STILL_VELOCITY,
) -> pd.DataFrame:
    """Per-joint excitation of states ``q`` (rad), ``dq`` (rad/s), ``ddq`` (rad/s²), each (N, N_J).

    Returns the table described in :attr:`IdentifiabilityReport.per_joint`.
    """
    q, dq, ddq = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, dq, ddq))
    table = pd.DataFrame(
        {
            "q_range": np.ptp(q, axis=0),
            "dq_peak": np.abs(dq).max(axis=0),
            "ddq_peak": np.abs(ddq).max(axis=0),
        },
        index=pd.Index(range(1, q.shape[1] + 1), name="joint"),
    )
    table["still"] = (table["q_range"] < still_range) & (table["dq_peak"] < still_velocity)
    if limits is not None:
        with np.errstate(divide="ignore", invalid="ignore"):  # an infinite limit gives fraction 0
            # positions: a continuous joint's range is one turn (every angle it can take)
            table["q_range_fraction"] = table["q_range"] / range_span(
                limits.position_lower, limits.position_upper
            )
            table["dq_peak_fraction"] = table["dq_peak"] / np.asarray(limits.velocity)
            table["ddq_peak_fraction"] = table["ddq_peak"] / np.asarray(limits.acceleration)
    return table


def still_joint_friction(names: Sequence[str], joint: int) -> tuple[str, ...]:
    """Base parameters of ``joint``'s (1-based) velocity-driven friction, which a still joint cannot
    excite: Coulomb and viscous (a constant offset stays identifiable)."""
    wanted = {f"{FRICTION_TERMS[term]}{joint}" for term in ("coulomb", "viscous")}
    return tuple(name for name in names if name in wanted)


def _joint_messages(per_joint: pd.DataFrame, names: Sequence[str], low_fraction: float) -> list[str]:
    lines = []
    # The index holds the 1-based joint numbers (:func:`joint_excitation`).
    for joint in per_joint.index.to_numpy(dtype=int):
        row = per_joint.loc[joint]
        if row["still"]:
            friction = still_joint_friction(names, int(joint))
            lost = (
                f": its friction ({', '.join(friction)}) cannot be identified from these data"
                if friction
                else ""
            )
            lines.append(
                f"joint {joint} never moves "
                f"(range of q {row['q_range']:.2g} rad, peak |dq| {row['dq_peak']:.2g} rad/s){lost}"
            )
        elif "q_range_fraction" in row and row["q_range_fraction"] < low_fraction:
            lines.append(
                f"joint {joint} moves weakly: {100 * row['q_range_fraction']:.2g} % of its position range, "
                f"{100 * row['dq_peak_fraction']:.2g} % of its velocity limit, "
                f"{100 * row['ddq_peak_fraction']:.2g} % of its acceleration limit"
            )
    return lines


def assess_identifiability(
    w_base: np.ndarray,
    parameter_names: Sequence[str],
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    limits: ExcitationLimits | None = None,
    *,
    poor_cond: float = DEFAULT_POOR_COND,
    rank_rtol: float = DEFAULT_RANK_RTOL,
    still_range: float = DEFAULT_STILL_RANGE,
    still_velocity: float = DEFAULT_STILL_VELOCITY,
    low_fraction: float = DEFAULT_LOW_FRACTION,
    n_smallest: int = 3,
    max_listed: int = 6,
    max_terms: int = 4,
    factor: bool = False,
) -> IdentifiabilityReport:
    """Rank, conditioning, weak directions and joint excitation of an identification's data.

    Parameters
    ----------
    w_base : (N·N_J, N_B) base regressor of the processed data, sample-major (row ``k·N_J + j`` is
        joint ``j`` at sample ``k``), as the estimators receive it.
    parameter_names : the N_B base-parameter names (``BaseParameters.names``).
    q, dq, ddq : (N, N_J) the processed joint states the regressor was built from (rad, rad/s, rad/s²).
    limits : the robot's limits (``RobotModel.limits``) for the excitation fractions; None skips them.
    poor_cond : cond of the column-scaled ``W_b`` above which the status is ``poor``.
    rank_rtol : relative singular-value tolerance of the rank.
    still_range, still_velocity : a joint with position range below ``still_range`` (rad) and peak
        |q̇| below ``still_velocity`` (rad/s) never moved.
    low_fraction : below this fraction of its position range a moving joint is named as weak
        (only with ``limits`` and only in the messages).
    n_smallest : how many weakest directions :attr:`~IdentifiabilityReport.smallest_directions` keeps.
    max_listed : how many weak directions the messages list (the report keeps them all).
    max_terms : most parameters named per direction.
    factor : ``w_base`` is the R factor of the rows (``W_b = Q·R``: the same column norms and
        singular values, a few kB whatever the logs' length), not the rows themselves.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 1, 50)[:, None]
    >>> q = np.hstack([np.sin(2 * np.pi * t), 0 * t])   # joint 2 never moves
    >>> w = np.column_stack([np.ravel(np.hstack([q[:, :1], 0 * t])), np.ravel(np.hstack([0 * t, q[:, 1:]]))])
    >>> report = assess_identifiability(w, ["A", "B"], q, np.gradient(q, axis=0), np.gradient(q, axis=0))
    >>> report.status, report.rank, report.still_joints, report.weak_directions[0].describe()
    ('rank_deficient', 1, (2,), 'B')
    """
    w_base = np.asarray(w_base, dtype=float)
    names = tuple(parameter_names)
    if w_base.ndim != 2 or w_base.shape[1] != len(names):
        raise ValueError(
            f"w_base must be (rows, {len(names)}) for {len(names)} parameter names, got shape {w_base.shape}"
        )
    n_joints = np.shape(q)[1]
    if not factor and w_base.shape[0] != np.shape(q)[0] * n_joints:
        raise ValueError(
            f"w_base has {w_base.shape[0]} rows, expected {np.shape(q)[0]} samples × {n_joints} joints"
        )
    n_columns = w_base.shape[1]
    if n_columns == 0:
        raise ValueError("w_base has no columns")
    # a wide regressor (fewer rows than columns) has fewer singular values: the rest are zero
    wide = w_base.shape[0] < n_columns
    _, sigma, vt = np.linalg.svd(_column_scaled(w_base), full_matrices=wide)
    sigma = np.concatenate([sigma, np.zeros(n_columns - sigma.size)])
    relative = sigma / sigma[0] if sigma[0] > 0 else np.zeros(n_columns)
    rank = int(np.count_nonzero(relative > rank_rtol))
    cond = float(1.0 / relative[-1]) if relative[-1] > 0 else float("inf")
    per_joint = joint_excitation(q, dq, ddq, limits, still_range, still_velocity)
    still = tuple(int(j) for j in per_joint.index[per_joint["still"].to_numpy()])
    # A still joint's velocity is noise: its friction columns look well conditioned and mean nothing.
    status = "rank_deficient" if rank < n_columns else ("poor" if cond > poor_cond or still else "good")

    weak_limit = max(1.0 / poor_cond, rank_rtol)
    ascending = np.arange(n_columns)[::-1]
    weak = tuple(
        _direction(relative[i], vt[i], names, max_terms) for i in ascending if relative[i] <= weak_limit
    )
    smallest = tuple(_direction(relative[i], vt[i], names, max_terms) for i in ascending[:n_smallest])

    messages = [
        f"identifiability {status}: rank {rank} of {n_columns} base parameters, "
        f"cond of the column-scaled base regressor {cond:.3g} (poor above {poor_cond:.3g})"
    ]
    if weak:
        messages.append(
            f"the data cannot determine {len(weak)} combination(s) of base parameters "
            "(relative singular value: weights):"
        )
        messages += [f"  {d.relative_singular_value:.2g}: {d.describe()}" for d in weak[:max_listed]]
        if len(weak) > max_listed:
            messages.append(f"  … and {len(weak) - max_listed} more")
    if status != "good":
        messages += _joint_messages(per_joint, names, low_fraction)
    return IdentifiabilityReport(
        status=status,
        rank=rank,
        n_columns=n_columns,
        cond_scaled=cond,
        singular_values=relative,
        weak_directions=weak,
        smallest_directions=smallest,
        still_joints=still,
        per_joint=per_joint,
        messages=tuple(messages),
        parameter_names=names,
        poor_cond=poor_cond,
    )


def prior_determined_parameters(
    report: IdentifiabilityReport, min_share: float = 0.25
) -> tuple[tuple[str, float], ...]:
    """Base parameters that an estimator with a prior (the SDP's regularisation) took from it.

    The share of parameter ``i`` is ``Σ_d v_d,i²`` over the weak directions ``d``: the part of its
    (column-scaled) coordinate the data do not see, so 1 for a parameter the data never excite and
    0.5 for each of two parameters whose difference is unseen. Returns ``(name, share)`` for the
    shares ≥ ``min_share``, largest first (empty when the report is ``good``).
    """
    if not report.weak_directions:
        return ()
    share = np.sum([d.vector**2 for d in report.weak_directions], axis=0)
    order = np.argsort(-share, kind="stable")
    return tuple((report.parameter_names[i], float(share[i])) for i in order if share[i] >= min_share)


def format_prior_note(report: IdentifiabilityReport, min_share: float = 0.25) -> str:
    """One line naming the parameters taken (partly) from the prior, or ``""`` if none."""
    taken = prior_determined_parameters(report, min_share)
    if not taken:
        return ""
    listed = ", ".join(f"{name} ({100 * share:.0f} %)" for name, share in taken)
    return (
        "from the estimator's prior, not the data "
        f"(share of each parameter the data do not determine): {listed}"
    )
