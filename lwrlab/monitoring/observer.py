"""De Luca's generalized-momentum observer, discrete-time and exact at the sample stamps.

With the generalized momentum ``p = M(q)·q̇`` and the external joint torque ``τ_ext = τ − τ̂`` (the
package's sign convention), the link dynamics give (``Ṁ = C + Cᵀ``)::

    ṗ = β − τ_ext,        β = τ + Cᵀ(q, q̇)·q̇ − g(q) − τ_f(q̇)

and the observer ``ṙ = K·(τ_ext − r)`` (De Luca and Mattone 2005) low-passes τ_ext with the
diagonal gain K (1/s) without any acceleration. Between two stamps t_{k−1}, t_k (any spacing) the
momentum difference is exact, ``p_k − p_{k−1} = ∫(β − τ_ext)``; with τ_ext constant over the
interval and β's mean taken by the trapezoid rule::

    e_k = (β_{k−1} + β_k)/2 − (p_k − p_{k−1})/Δt_k,        r_k = α_k·r_{k−1} + (1 − α_k)·e_k,
    α_k = exp(−K·Δt_k)

which is the continuous observer's exact (zero-order-hold) discretisation: for an external torque
constant between stamps and an exactly known β, r_k equals the continuous r(t_k) whatever the
stamps' spacing. K → ∞ gives e_k, the interval's mean external torque, unfiltered.

:func:`observer_step` is the real-time form (state in, torques and state out): three Pinocchio
calls (C, g, M·q̇) and a dozen numpy operations in place on 7-vectors, whose dispatch costs as much
as the calls. :meth:`MomentumObserver.observe` runs a whole log, the Pinocchio terms in one loop
and the rest vectorised, and gives the same numbers (tested).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from lwrlab.model.friction_laws import SignCoulomb
from lwrlab.model.robot import RobotModel
from lwrlab.numerics.recursion import first_order_recursion

CHUNK_SAMPLES = 4096
"""Samples whose Coriolis matrices are held at once by :meth:`MomentumObserver.observe`."""


class _StepScratch(NamedTuple):
    """What :func:`observer_step` reuses from one sample to the next instead of making it anew."""

    coriolis_transposed: np.ndarray
    """Cᵀ: a view of the Pinocchio scratch's C, rewritten by every ``computeCoriolisMatrix``."""
    zero: np.ndarray
    """(N_J,) zero velocities."""
    inverse_smoothing: np.ndarray
    """(N_J,) 1/ε."""
    negative_gains: np.ndarray
    """(N_J,) −K."""
    last_interval: list[float | np.ndarray]
    """[Δt, α = e^{−K·Δt}, 1/Δt per joint] of the last interval: a uniform log computes them once."""


class ObserverState(NamedTuple):
    """What the observer carries from one sample to the next (a tuple: cheap to make at 1 kHz)."""

    t: float
    """Stamp of the last sample (s)."""
    momentum: np.ndarray
    """(N_J,) p = M(q)·q̇ at the last sample (kg·m²/s, N·m·s)."""
    known_torque: np.ndarray
    """(N_J,) β = τ + Cᵀq̇ − g − τ_f at the last sample (N·m)."""
    external_torque: np.ndarray
    """(N_J,) r, the estimate of τ_ext = τ − τ̂ (N·m)."""


@dataclass(frozen=True)
class MomentumObserver:
    """The observer's constants: the model, the gain and the Coulomb smoothing.

    Parameters
    ----------
    robot : the model (identified or CAD), friction included.
    gain : K (1/s), one value or one per joint: the observer's bandwidth (K/2π Hz).
    coulomb_smoothing : ε (rad/s) of ``FC·tanh(q̇/ε)``: a velocity estimate's noise around a stop
        does not flip ±FC.

    Examples
    --------
    >>> from lwrlab.pipeline.build import build  # doctest: +SKIP
    >>> observer = MomentumObserver(build("robot", "kuka_lwr4"), gain=50.0)  # doctest: +SKIP
    >>> state = observer.start(t[0], q[0], dq[0], tau[0])  # doctest: +SKIP
    >>> r, state = observer_step(observer, state, t[1], q[1], dq[1], tau[1])  # doctest: +SKIP
    """

    robot: RobotModel
    gain: float | np.ndarray
    coulomb_smoothing: float = 0.01
    gains: np.ndarray = field(init=False, repr=False)
    """(N_J,) K per joint (1/s)."""
    friction_coefficients: tuple[np.ndarray, np.ndarray, np.ndarray] = field(init=False, repr=False)
    """FC, FV, FO per joint (zero for a term the model leaves out)."""
    rotor_inertia: np.ndarray | None = field(init=False, repr=False)
    """(N_J, N_J) ``Cᵀ·diag(IA)·C``, the drives' rotor inertia reflected to the joints (kg·m²), or None
    when the model has no rotor-inertia columns: it adds to M(q), constant, so to p only."""
    own_friction_law: bool = field(init=False, repr=False)
    """True when the model's friction is not the paper's law on uncoupled drives (a smooth, Stribeck,
    direction-dependent law, a coupled wrist): the model's own drive torque is used, as identified."""
    data: pin.Data = field(init=False, repr=False, compare=False)
    """Pinocchio scratch, rewritten by every call."""
    _scratch: _StepScratch = field(init=False, repr=False, compare=False)
    """Views and constants of the step function, made once: its numpy calls are its cost."""

    def __post_init__(self) -> None:
        n = self.robot.n_joints
        gains = np.broadcast_to(np.asarray(self.gain, dtype=float), (n,)).copy()
        if np.any(~np.isfinite(gains)) or np.any(gains <= 0):
            raise ValueError(f"observer gain must be positive and finite, got {self.gain}")
        if self.coulomb_smoothing <= 0:
            raise ValueError(f"coulomb_smoothing must be positive, got {self.coulomb_smoothing}")
        friction, terms = self.robot.friction, self.robot.friction_terms
        coefficients = tuple(
            np.asarray(getattr(friction, term), dtype=float) if term in terms else np.zeros(n)
            for term in ("coulomb", "viscous", "offset")
        )
        object.__setattr__(self, "gains", gains)
        object.__setattr__(self, "friction_coefficients", coefficients)
        drive = self.robot.drive_train
        rotor = None
        if "rotor" in terms:
            rotor = drive.coupling.T @ (friction.value("rotor")[:, None] * drive.coupling)
        object.__setattr__(self, "rotor_inertia", rotor)
        own = not isinstance(self.robot.friction_law, SignCoulomb) or not drive.is_direct
        own = own or bool(set(terms) - {"coulomb", "viscous", "offset", "rotor"})
        object.__setattr__(self, "own_friction_law", own)
        data = self.robot.model.createData()
        object.__setattr__(self, "data", data)
        scratch = _StepScratch(
            coriolis_transposed=data.C.T,
            zero=np.zeros(n),
            inverse_smoothing=np.full(n, 1.0 / self.coulomb_smoothing),
            negative_gains=-gains,
            last_interval=[float("nan"), np.ones(n), np.ones(n)],
        )
        object.__setattr__(self, "_scratch", scratch)

    def friction_torque(self, dq: np.ndarray) -> np.ndarray:
        """τ_f (N·m) at velocities ``dq`` (…, N_J), Coulomb smoothed (or the model's own law)."""
        if self.own_friction_law:
            return self.robot.drive_torque(dq)
        coulomb, viscous, offset = self.friction_coefficients
        return coulomb * np.tanh(dq / self.coulomb_smoothing) + viscous * dq + offset

    def momentum_and_known_torque(
        self, q: np.ndarray, dq: np.ndarray, tau: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """p = M(q)·q̇ and β = τ + Cᵀq̇ − g − τ_f at one sample (N·m·s, N·m)."""
        model, data, scratch = self.robot.model, self.data, self._scratch
        coulomb, viscous, offset = self.friction_coefficients
        pin.computeCoriolisMatrix(model, data, q, dq)  # read through scratch.coriolis_transposed
        gravity = pin.computeGeneralizedGravity(model, data, q)
        # rnea(q, 0, q̇) = M(q)·q̇ + g(q); it returns data.tau, which the subtraction copies
        momentum = pin.rnea(model, data, q, scratch.zero, dq) - gravity
        # β in place: on 7-vectors each numpy call costs more than its arithmetic
        known = scratch.coriolis_transposed.dot(dq)
        known += tau
        known -= gravity
        if self.rotor_inertia is not None:
            momentum += self.rotor_inertia.dot(dq)
        if self.own_friction_law:
            known -= self.robot.drive_torque(dq)  # without ddq: the rotor inertia is in p
            return momentum, known
        friction = np.multiply(dq, scratch.inverse_smoothing)
        np.tanh(friction, out=friction)
        friction *= coulomb
        known -= friction
        np.multiply(viscous, dq, out=friction)
        known -= friction
        known -= offset
        return momentum, known

    def interval_constants(self, period: float) -> tuple[np.ndarray, np.ndarray]:
        """α = e^{−K·Δt} and 1/Δt per joint for an interval of ``period`` (s); the last ones kept."""
        last = self._scratch.last_interval
        if last[0] != period:
            last[:] = [
                period,
                np.exp(self._scratch.negative_gains * period),
                np.full(len(self.gains), 1.0 / period),
            ]
        return last[1], last[2]  # type: ignore[return-value]

    def start(self, t: float, q: np.ndarray, dq: np.ndarray, tau: np.ndarray) -> ObserverState:
        """The state at the first sample, with no external torque estimated yet."""
        momentum, known = self.momentum_and_known_torque(*(np.asarray(x, dtype=float) for x in (q, dq, tau)))
        return ObserverState(float(t), momentum, known, np.zeros(self.robot.n_joints))

    def step(
        self, state: ObserverState, t: float, q: np.ndarray, dq: np.ndarray, tau: np.ndarray
    ) -> tuple[np.ndarray, ObserverState]:
        """:func:`observer_step` with this observer."""
        return observer_step(self, state, t, q, dq, tau)

    def terms(
        self,
        q: np.ndarray,
        dq: np.ndarray,
        tau: np.ndarray,
        progress: Callable[[int, int], None] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """p and β (N, N_J) of every sample: one Pinocchio loop, the products vectorised.

        ``progress(done, total)`` is called after each block of :data:`CHUNK_SAMPLES` samples.
        """
        model, data = self.robot.model, self.data
        n_samples, n = q.shape
        momentum, correction = np.empty((n_samples, n)), np.empty((n_samples, n))
        zero = np.zeros(n)
        coriolis = np.empty((min(CHUNK_SAMPLES, n_samples), n, n))
        for first in range(0, n_samples, CHUNK_SAMPLES):
            last = min(first + CHUNK_SAMPLES, n_samples)
            for k in range(first, last):
                coriolis[k - first] = pin.computeCoriolisMatrix(model, data, q[k], dq[k])
                gravity = pin.computeGeneralizedGravity(model, data, q[k])
                momentum[k] = pin.rnea(model, data, q[k], zero, dq[k]) - gravity
                correction[k] = gravity
            # Cᵀq̇ of the chunk in one product; correction = Cᵀq̇ − g
            block = slice(first, last)
            correction[block] = (
                np.einsum("kij,ki->kj", coriolis[: last - first], dq[block]) - correction[block]
            )
            if progress is not None:
                progress(last, n_samples)
        if self.rotor_inertia is not None:  # the rotors' momentum (a constant inertia: no Coriolis term)
            momentum += dq @ self.rotor_inertia
        return momentum, tau + correction - self.friction_torque(dq)

    def observe(
        self,
        t: np.ndarray,
        q: np.ndarray,
        dq: np.ndarray,
        tau: np.ndarray,
        state: ObserverState | None = None,
        progress: Callable[[int, int], None] | None = None,
    ) -> tuple[np.ndarray, ObserverState]:
        """The external torque estimate r (N, N_J) of a whole log, and the state after its last sample.

        Parameters
        ----------
        t : (N,) stamps (s), increasing, any spacing.
        q, dq, tau : (N, N_J) positions (rad), velocities (rad/s), link-side torques (N·m).
        state : the state before the log's first sample (a log continued); None: the first sample
            starts the observer (r = 0 there).
        progress : called as ``progress(done, total)`` while the samples go through (long logs).
        """
        t = np.asarray(t, dtype=float)
        q, dq, tau = (np.asarray(x, dtype=float) for x in (q, dq, tau))
        if np.any(np.diff(t) <= 0):
            raise ValueError("observer stamps must increase")
        momentum, known = self.terms(q, dq, tau, progress)
        if state is None:
            state = ObserverState(float(t[0]), momentum[0], known[0], np.zeros(q.shape[1]))
            start = 1
        else:
            start = 0
        previous_t = np.concatenate([[state.t], t[:-1]])[start:]
        previous_p = np.vstack([state.momentum[None], momentum[:-1]])[start:]
        previous_b = np.vstack([state.known_torque[None], known[:-1]])[start:]
        period = (t[start:] - previous_t)[:, None]
        interval_torque = 0.5 * (previous_b + known[start:]) - (momentum[start:] - previous_p) / period
        decay = self.gains * period  # K·Δt per sample and joint
        alpha = np.exp(-decay)
        r = np.empty_like(q)
        r[:start] = state.external_torque
        r[start:] = first_order_recursion(
            alpha, decay, (1.0 - alpha) * interval_torque, state.external_torque
        )
        final = ObserverState(float(t[-1]), momentum[-1].copy(), known[-1].copy(), r[-1].copy())
        return r, final


def observer_step(
    observer: MomentumObserver,
    state: ObserverState,
    t: float,
    q: np.ndarray,
    dq: np.ndarray,
    tau: np.ndarray,
) -> tuple[np.ndarray, ObserverState]:
    """One sample of the observer: the external torque estimate r_k (N·m) and the next state.

    Pure but for the observer's scratch (Pinocchio's, and α and 1/Δt of the last interval): the same
    state and sample give the same result.

    Parameters
    ----------
    observer : the constants (model, gain).
    state : the state after the previous sample.
    t : this sample's stamp (s), after ``state.t``.
    q, dq, tau : (N_J,) positions (rad), velocities (rad/s), link-side torques (N·m).
    """
    period = t - state.t
    if period <= 0:
        raise ValueError(f"observer stamps must increase: {t} after {state.t}")
    momentum, known = observer.momentum_and_known_torque(q, dq, tau)
    alpha, inverse_period = observer.interval_constants(period)
    # e = (β_{k−1} + β_k)/2 − (p_k − p_{k−1})/Δt, then r = α·r_{k−1} + (1 − α)·e = e + α·(r_{k−1} − e)
    interval_torque = state.known_torque + known
    interval_torque *= 0.5
    momentum_change = momentum - state.momentum
    momentum_change *= inverse_period
    interval_torque -= momentum_change
    r = state.external_torque - interval_torque
    r *= alpha
    r += interval_torque
    return r, ObserverState(t, momentum, known, r)
