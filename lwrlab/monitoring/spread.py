"""What a model's error on a contact-free motion grows with: the state terms of the thresholds.

State-dependent thresholds (:class:`~lwrlab.monitoring.calibration.StateCalibration`) scale with a
spread per joint and sample, ``spread_j² = a_j + (ρ_j·φ_j)²``, and add ``ε_j``; both terms come
from here:

- φ, the **friction band** (:func:`friction_band`): the magnitude of the model's friction torque
  at the joint speed — Coulomb, viscous and the law's own terms (Stribeck, breakaway, direction),
  not offsets nor rotor inertia — with the Coulomb-like terms at their full level at any speed:
  at rest the friction can hold anything within that band, and at a reversal the model flips from
  one edge of it to the other. Friction measured on one day or motion differs on another by a
  share of it (temperature, speed range: 30–50 % measured on the real LWR4+);
- ε, the **stamps' share** (:func:`stamp_deviation`, :func:`regularised`): a log recorded with
  jittered time stamps (a PC stamping samples a robot took regularly) is interpolated onto a
  regular grid by the log reader, which moves each position by ``q̇·δ`` where a stamp is off by δ;
  the observer turns that into a torque spike (up to 10 N·m on the real LWR4+ runs, from a 1.7 ms
  late stamp). ε is the difference between the estimate and the estimate of the same log read as
  regularly sampled: where the stamps were regular, zero. A computed error, not a random one: the
  thresholds add it as it is.

Both pass through the estimator's own filter (:func:`first_order_lowpass` for the momentum
observer, the direct residual's zero-phase low-pass), so that thresholds and estimates share one
bandwidth.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from scipy.ndimage import median_filter

from lwrlab.model.friction_laws import drive_basis, drive_loads, has_load, largest_basis, term_definitions
from lwrlab.model.robot import RobotModel
from lwrlab.numerics.recursion import first_order_recursion
from lwrlab.plants.core import Measurement
from lwrlab.signal.filters import central_difference

LEVEL_REACHED = 0.95
"""Share of its level the Coulomb shape has reached at the speed where sliding counts as begun."""
STAMP_TREND_SAMPLES = 11
"""Samples of the running median that separates a clock's drift from the stamps' jitter."""


def sliding_speed(robot: RobotModel) -> float:
    """The slowest joint-side speed (rad/s) at which every drive's Coulomb shape has reached
    :data:`LEVEL_REACHED` of its level: ~0 for ``sign(v)``, 1.8·ε for ``tanh(v/ε)``."""
    speeds = np.geomspace(1e-6, 10.0, 141)
    n = robot.drive_train.n_drives
    shape = np.abs(robot.friction_law.coulomb_shape(np.repeat(speeds[:, None], n, axis=1))).min(axis=1)
    reached = np.flatnonzero(shape >= LEVEL_REACHED)
    return float(speeds[reached[0]]) if reached.size else float(speeds[-1])


class FrictionBand:
    """The friction band of one model (:func:`friction_band`), its constants made once: called per
    sample in a live loop, per log offline, with the same numbers.

    Parameters
    ----------
    robot : the model whose friction law, coefficients and drive train set the band.
    """

    def __init__(self, robot: RobotModel) -> None:
        self.robot = robot
        self.sliding_speed = sliding_speed(robot)
        law = robot.friction_law
        definitions = term_definitions(law)
        self._terms = [
            (term, np.abs(robot.friction.value(term)))
            for term in robot.friction_terms
            if definitions[term].drifts  # offsets and rotor inertias are not friction
        ]
        self._extra = {t.name for t in law.extra_terms}
        self._load = has_load(law)
        self._data = robot.model.createData() if self._load else None
        drive = robot.drive_train
        self._spread = None if drive.is_direct else np.abs(drive.coupling)

    def __call__(self, dq: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """(N, N_J) the band (N·m) at velocities ``dq`` (N, N_J) and, for a law whose friction
        grows with the load, positions ``q`` (None: no load)."""
        robot, law = self.robot, self.robot.friction_law
        drive = robot.drive_train
        speed = np.maximum(np.abs(drive.drive_values(np.atleast_2d(dq))), self.sliding_speed)
        band = np.zeros_like(speed)
        load = None
        if q is not None and self._load:
            model, data = robot.model, self._data
            gravity = np.stack([pin.computeGeneralizedGravity(model, data, x) for x in np.atleast_2d(q)])
            load = drive_loads(drive, gravity)
        for term, coefficient in self._terms:
            if term == "coulomb":
                band += coefficient
            elif term == "viscous":
                band += coefficient * speed
            elif load is not None and term in self._extra:
                basis = np.maximum(
                    np.abs(drive_basis(law, term, speed, load=load)),
                    np.abs(drive_basis(law, term, -speed, load=load)),
                )
                band += coefficient * basis
            else:
                band += coefficient * largest_basis(law, term, speed)
        return band if self._spread is None else band @ self._spread


def friction_band(robot: RobotModel, dq: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
    """(N, N_J) the model's friction torque magnitude (N·m) at joint velocities ``dq`` (rad/s) and, for
    a law whose friction grows with the load, positions ``q`` (rad; the load: the gravity torque
    each drive holds there; None: no load).

    Per drive, each friction term's torque at the drive's speed ``s = max(|v|, v₀)`` (``v₀``:
    :func:`sliding_speed`), whichever direction is larger, summed in magnitude: Coulomb ``FC``,
    viscous ``FV·s``, and the law's own terms (a Stribeck excess at low speed, a direction's
    difference): the terms that drift (:attr:`~lwrlab.model.friction_laws.DriveTerm.drifts`, which
    the prediction intervals follow too); offsets and rotor inertia are not friction. A coupled
    drive train spreads each drive's band over the joints it turns (``|C|ᵀ``).

    Examples
    --------
    >>> from lwrlab.model.description import load_robot_yaml
    >>> from lwrlab.resources import config_group
    >>> robot = load_robot_yaml(config_group("robot")["kuka_lwr4"])
    >>> band = friction_band(robot, np.array([[0.0] * 7, [1.0] * 7]))
    >>> bool(np.allclose(band[0], robot.friction.coulomb))  # at rest: the Coulomb band
    True
    >>> bool(np.allclose(band[1], robot.friction.coulomb + robot.friction.viscous))
    True
    """
    return FrictionBand(robot)(dq, q)


def resting(t: np.ndarray, velocity: np.ndarray, speed: float, settle: float) -> np.ndarray:
    """(N,) where the arm stands still: every joint's speed (N, N_J) below ``speed`` (rad/s) for the
    last ``settle`` seconds (a log that starts still counts from its first stamp).

    Examples
    --------
    >>> t = np.arange(10) * 0.1
    >>> v = np.array([0, 0, 0, 0.5, 0, 0, 0, 0, 0, 0])[:, None]
    >>> resting(t, v, 0.01, 0.25).astype(int).tolist()
    [0, 0, 0, 0, 0, 0, 1, 1, 1, 1]
    """
    t = np.asarray(t, dtype=float)
    slow = np.all(np.abs(np.asarray(velocity, dtype=float)) < speed, axis=1)
    last_fast = np.maximum.accumulate(np.where(slow, -1, np.arange(len(t))))
    since = t - np.where(last_fast >= 0, t[np.maximum(last_fast, 0)], t[0])
    return slow & (since >= settle - 1e-12)


def first_order_lowpass(
    t: np.ndarray, x: np.ndarray, gain: float, initial: np.ndarray | float | None = None
) -> np.ndarray:
    """``x`` (N, N_J) through the observer's filter ``ṙ = K·(x − r)``, discretised as the observer is
    (interval means, exact at the stamps), starting at ``initial`` (None: ``x[0]``)."""
    x = np.asarray(x, dtype=float)
    filtered = np.empty_like(x)
    filtered[0] = x[0] if initial is None else initial
    if len(x) < 2:
        return filtered
    decay = gain * np.diff(np.asarray(t, dtype=float))[:, None] * np.ones((1, x.shape[1]))
    alpha = np.exp(-decay)
    interval_mean = 0.5 * (x[1:] + x[:-1])
    filtered[1:] = first_order_recursion(alpha, decay, (1.0 - alpha) * interval_mean, filtered[0])
    return filtered


def stamp_deviation(measurement: Measurement) -> np.ndarray | None:
    """(N,) how far (s) each regular sample's logged stamp was off a regular clock, interpolated
    at the measurement's stamps; None when the log was not resampled from irregular stamps.

    The logged stamps' offsets from a regular grid, less their running median over
    :data:`STAMP_TREND_SAMPLES` samples (a recording clock's slow drift is no jitter).
    """
    logged = measurement.logged_t
    if logged is None or len(logged) < 3:
        return None
    logged = np.asarray(logged, dtype=float)
    index = np.arange(len(logged))
    offset = logged - logged[0] - index * (logged[-1] - logged[0]) / (len(logged) - 1)
    jitter = offset - median_filter(offset, size=STAMP_TREND_SAMPLES, mode="nearest")
    return np.interp(measurement.t, logged, jitter)


def regularised(measurement: Measurement, deviation: np.ndarray) -> Measurement:
    """The measurement as if its samples had been taken regularly and only their stamps were off by
    ``deviation`` (s): ``q + q̇·δ`` and ``τ + τ̇·δ`` (first order, centred differences)."""
    period = float(np.mean(np.diff(measurement.t)))
    shift = np.asarray(deviation, dtype=float)[:, None]
    return Measurement(
        t=measurement.t,
        q=measurement.q + central_difference(measurement.q, period) * shift,
        tau=measurement.tau + central_difference(measurement.tau, period) * shift,
        metadata={**measurement.metadata, "stamps": "regularised"},
    )
