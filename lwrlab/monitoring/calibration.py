"""Detection thresholds per joint from contact-free data, for a stated false-alarm rate.

A threshold must hold two things a contact-free residual does: its noise, whose rare peaks set the
false alarms, and the model's error, which follows the motion. For a rate of ``A`` false alarms per
hour over N_J joints at sampling period Δt, each joint may exceed its threshold on a share
``p = A·Δt / (3600·N_J)`` of the samples (an exceedance counted per sample: an upper bound on the
alarms, which span several samples). A calibration log holds too few samples to see so rare an
event, so the level is the largest of

- the Gaussian level ``z(p)·rms`` (z the two-sided normal quantile, rms about zero: bias included),
- the empirical ``1 − p`` quantile of |r| where the data hold at least :data:`MIN_TAIL_SAMPLES`
  samples beyond it, otherwise the largest |r| seen,

times ``margin`` (≥ 1), which covers motions the calibration did not contain. Two kinds:

- :func:`calibrate_thresholds`, **constant** thresholds: the level of |r| itself, one value per
  joint whatever the robot does, and never below the friction band at rest (a joint that stands
  still may hold any friction within it, which calibration logs that hardly stop do not show);
- :func:`calibrate_state_thresholds`, **state** thresholds: the level of the normalised residual
  ``(|r| − ε)/spread``, times the spread of each sample, ``spread² = a + (ρ·φ)²``, plus ε (φ the
  friction band and ε the stamps' share, :mod:`lwrlab.monitoring.spread`: a computed error of the
  estimate, not a random one, so added as it is rather than scaled by the level). ``a`` and ``ρ``
  are fitted to the contact-free residual by maximum likelihood (``|r| − ε ~ |N(0, spread²)|``),
  ρ no lower than
  ``friction_drift / z(p)``: friction measured on one run may differ on the next by the share
  ``friction_drift`` of itself, which no calibration log shows, and the threshold, at least
  ``z(p)`` spreads, then covers it. At rest φ is the band of friction that holds still, which the
  residual may fill whole: no threshold is lower than ``margin·√((level·√a)² + band²)``, the noise's
  level and that band. Where the arm **stands still** (:func:`lwrlab.monitoring.spread.resting`)
  the threshold comes from the model at rest, not from the error of the fastest motion calibrated
  on: ``margin·√((level·s_rest)² + ((1 + friction_drift)·band + e_rest)²)`` (:func:`rest_terms`):
  ``s_rest`` the noise of the contact-free residual within each stretch the calibration logs stand
  still, the band as friction may hold it on another run, ``e_rest`` what the model's static torque
  (gravity and the friction band) left at rest beyond the band, when the logs stand still for at
  least :data:`MIN_REST_S` seconds; else ``√a`` as while moving. There a contact ends once every
  joint is back within what the standing arm may hold (:meth:`StateCalibration.release_shares`): a
  push moves the friction a standing joint holds, and its residual settles anywhere in that band.
  Where joints' encoders counted, the thresholds add what a count does to the observer's estimate
  (``margin·κ``, :mod:`lwrlab.monitoring.counts`).

Either way the calibration data themselves raise no alarm.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.optimize import minimize
from scipy.special import ndtri

from lwrlab.monitoring.counts import count_limit
from lwrlab.monitoring.rest_residual import rest_terms

MIN_TAIL_SAMPLES = 10
"""Samples beyond an empirical quantile for it to be trusted; fewer: the largest |r| is used."""
MIN_REST_S = 0.5
"""Seconds the calibration logs must stand still for their residual at rest to set the thresholds at
rest; less: the thresholds at rest come from the moving samples' spread."""


def exceedance_probability(false_alarm_rate: float, mean_period: float, n_joints: int) -> float:
    """``p = A·Δt / (3600·N_J)``: the share of samples each joint may exceed its threshold (≤ 0.5)."""
    return min(0.5, false_alarm_rate * mean_period / (3600.0 * n_joints))


def tail_level(magnitudes: np.ndarray, probability: float) -> np.ndarray:
    """(N_J,) the larger of the Gaussian level and the empirical quantile (or peak) of ``magnitudes``
    (N, N_J, ≥ 0) for the exceedance share ``probability``."""
    gaussian = -ndtri(probability / 2) * np.sqrt(np.mean(magnitudes**2, axis=0))
    if probability * magnitudes.shape[0] >= MIN_TAIL_SAMPLES:
        return np.maximum(gaussian, np.quantile(magnitudes, 1.0 - probability, axis=0))
    return np.maximum(gaussian, magnitudes.max(axis=0))


def _checked(false_alarm_rate: float, margin: float, residuals: Sequence[np.ndarray]) -> None:
    if false_alarm_rate <= 0:
        raise ValueError(f"false_alarm_rate must be positive (alarms per hour), got {false_alarm_rate}")
    if margin < 1:
        raise ValueError(f"margin must be at least 1, got {margin}")
    if not residuals:
        raise ValueError("no contact-free data to calibrate on")


@dataclass(frozen=True)
class Calibration:
    """Constant thresholds per joint and what they came from."""

    thresholds: np.ndarray
    """(N_J,) |τ_ext| above which a joint is in contact (N·m)."""
    rms: np.ndarray
    """(N_J,) RMS of the contact-free residual (N·m)."""
    peak: np.ndarray
    """(N_J,) largest contact-free |residual| (N·m)."""
    exceedance_probability: float
    """p: share of samples each joint may exceed its threshold."""
    false_alarm_rate: float
    """The stated rate (alarms per hour)."""
    margin: float
    """Safety factor on the levels."""
    samples: int
    """Contact-free samples calibrated on."""
    duration_s: float
    """Contact-free time calibrated on (s)."""

    kind = "constant"

    def thresholds_at(
        self,
        friction: np.ndarray,
        stamps: np.ndarray,
        resting: np.ndarray | None = None,
        displacement: np.ndarray | None = None,
    ) -> np.ndarray:
        """(N, N_J) the thresholds at samples of (N, N_J) state terms: the same at every sample."""
        return np.broadcast_to(self.thresholds, np.shape(friction)).copy()

    def release_shares(
        self, thresholds: np.ndarray, friction: np.ndarray, resting: np.ndarray | None, release: float
    ) -> np.ndarray | float:
        """The share of each threshold a contact's joints must fall below to end it: ``release``."""
        return release

    def table(self) -> dict[str, np.ndarray]:
        """Per joint: the threshold, the contact-free RMS and peak (N·m)."""
        return {"threshold": self.thresholds, "rms": self.rms, "peak": self.peak}


def calibrate_thresholds(
    residuals: Sequence[np.ndarray],
    periods: Sequence[float],
    false_alarm_rate: float,
    margin: float = 1.0,
    rest_friction: np.ndarray | None = None,
) -> Calibration:
    """Constant thresholds per joint from contact-free residuals (one (N, N_J) array per log):
    ``margin·max(level, band)``, the level of |r| for the stated rate and the friction band at rest.

    Parameters
    ----------
    residuals : external torque estimates of contact-free logs (N·m).
    periods : each log's sampling period (s).
    false_alarm_rate : the stated rate, alarms per hour (> 0).
    margin : factor ≥ 1 on the levels.
    rest_friction : (N_J,) the friction band at rest (N·m), which a joint standing still may fill;
        None: no floor.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> calibration = calibrate_thresholds([rng.normal(size=(10_000, 2))], [1e-3], 1.0)
    >>> bool(np.all(calibration.thresholds > 4))
    True
    """
    _checked(false_alarm_rate, margin, residuals)
    stacked = np.abs(np.vstack([np.asarray(r, dtype=float) for r in residuals]))
    n_samples, n_joints = stacked.shape
    duration = float(sum(len(r) * period for r, period in zip(residuals, periods, strict=True)))
    probability = exceedance_probability(false_alarm_rate, duration / n_samples, n_joints)
    level = tail_level(stacked, probability)
    if rest_friction is not None:
        level = np.maximum(level, np.asarray(rest_friction, dtype=float))
    return Calibration(
        thresholds=margin * level,
        rms=np.sqrt(np.mean(stacked**2, axis=0)),
        peak=stacked.max(axis=0),
        exceedance_probability=float(probability),
        false_alarm_rate=float(false_alarm_rate),
        margin=float(margin),
        samples=int(n_samples),
        duration_s=duration,
    )


@dataclass(frozen=True)
class StateCalibration:
    """State-dependent thresholds ``margin·level·spread`` and what they came from."""

    noise: np.ndarray
    """(N_J,) √a: the spread without friction (N·m)."""
    friction_share: np.ndarray
    """(N_J,) ρ: the spread's share of the friction band."""
    level: np.ndarray
    """(N_J,) level of the normalised residual |r|/spread for the stated rate."""
    floor: np.ndarray
    """(N_J,) the lowest threshold, ``margin·√((level·√a)² + band²)``: the noise's level and the
    whole friction band at rest, which friction holding still may fill (N·m)."""
    rest_band: np.ndarray
    """(N_J,) the friction band at rest (N·m)."""
    rest_noise: np.ndarray | None
    """(N_J,) s_rest: the contact-free residual's noise within the stretches where the arm stands still
    (N·m), or None: the calibration logs did not stand still long enough (the thresholds at rest use
    √a)."""
    rest_error: np.ndarray | None
    """(N_J,) e_rest: the largest mean residual of a stretch at rest beyond the friction band (N·m):
    the static model's error (gravity) there."""
    rms: np.ndarray
    """(N_J,) RMS of the contact-free residual (N·m)."""
    peak: np.ndarray
    """(N_J,) largest contact-free |residual| (N·m)."""
    exceedance_probability: float
    """p: share of samples each joint may exceed its threshold."""
    false_alarm_rate: float
    """The stated rate (alarms per hour)."""
    margin: float
    """Safety factor on the levels."""
    count_share: np.ndarray | None
    """(N_J, N_J) the most an encoder count of joint k (column) moves joint j's estimate (N·m,
    :mod:`lwrlab.monitoring.counts`), or None: not known (no share added)."""
    position_step: np.ndarray | None
    """(N_J,) δ, the encoders' step measured on the calibration logs (rad), or None."""
    friction_drift: float
    """Share of its friction by which a run may differ from the calibration's."""
    samples: int
    """Contact-free samples calibrated on."""
    duration_s: float
    """Contact-free time calibrated on (s)."""

    kind = "state"

    def spread(self, friction: np.ndarray) -> np.ndarray:
        """(N, N_J) ``√(a + (ρ·φ)²)`` (N·m) of friction bands φ (N·m)."""
        return np.sqrt(self.noise**2 + (self.friction_share * np.asarray(friction)) ** 2)

    def thresholds_at(
        self,
        friction: np.ndarray,
        stamps: np.ndarray,
        resting: np.ndarray | None = None,
        displacement: np.ndarray | None = None,
    ) -> np.ndarray:
        """(N, N_J) the thresholds (N·m) at samples of friction bands φ and stamps' shares ε (N·m):
        ``max(margin·level·spread, floor) + margin·ε``; at the samples ``resting`` (N,) marks (the arm
        standing still), ``margin·√((level·s_rest)² + static²) + margin·ε`` where s_rest is known;
        plus ``margin·κ``, κ the encoder counts' share of the joints whose positions moved more than
        a step over the observer's settling time (``displacement`` (N, N_J), rad;
        :mod:`lwrlab.monitoring.counts`)."""
        spread = self.margin * self.level * self.spread(friction)
        thresholds = np.maximum(spread, self.floor)
        if resting is not None and self.rest_noise is not None:
            still = np.asarray(resting, dtype=bool)
            thresholds[still] = self.rest_threshold(np.asarray(friction)[still])
        thresholds += self.margin * np.asarray(stamps)
        if displacement is not None and self._counts is not None:
            limit, squared = self._counts
            moved = np.asarray(displacement) > limit
            if moved.any():  # an arm that stood for the window: nothing to add
                thresholds += self.margin * np.sqrt(moved @ squared)
        return thresholds

    @cached_property
    def _counts(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The displacement beyond which a joint counts (rad) and the squared shares, transposed:
        made once, read at every sample."""
        if self.count_share is None or self.position_step is None:
            return None
        return count_limit(self.position_step), np.square(self.count_share).T.copy()

    def static_torque(self, band: np.ndarray) -> np.ndarray:
        """(…, N_J) what a standing arm's residual may hold with friction bands ``band`` (N·m): the band
        as another run may hold it and the gravity model's error at rest; zeros where the calibration
        did not measure the arm at rest."""
        if self.rest_noise is None:
            return np.zeros(np.shape(band))
        error = 0.0 if self.rest_error is None else self.rest_error
        return (1.0 + self.friction_drift) * np.asarray(band) + error

    def release_shares(
        self, thresholds: np.ndarray, friction: np.ndarray, resting: np.ndarray | None, release: float
    ) -> np.ndarray | float:
        """(N, N_J) the share of each threshold (N, N_J) a contact's joints must fall below to end it:
        ``release``, and where the arm stands still (``resting``, (N,)) at least the static torque it
        may hold, ``margin·static/threshold``: a push moves the friction a standing joint holds, and
        the residual settles anywhere within that band after it, not back to zero."""
        still = None if resting is None else np.asarray(resting, dtype=bool)
        if still is None or self.rest_noise is None or not still.any():
            return release
        shares = np.full(np.shape(thresholds), float(release))
        held = self.margin * self.static_torque(np.asarray(friction)[still])
        shares[still] = np.clip(held / np.asarray(thresholds)[still], release, 1.0)
        return shares

    def rest_threshold(self, band: np.ndarray) -> np.ndarray:
        """(…, N_J) the thresholds where the arm stands still with friction bands ``band`` (…, N_J; the
        band at rest, or at the posture for a law whose friction grows with the load), without the
        stamps' share (N·m): from the residual at rest where the calibration measured it, else the
        floor."""
        if self.rest_noise is None:
            return np.broadcast_to(self.floor, np.shape(band)).copy()
        static = self.static_torque(band)
        return self.margin * np.sqrt((self.level * self.rest_noise) ** 2 + static**2)

    @property
    def at_rest(self) -> np.ndarray:
        """(N_J,) the threshold at rest, with regular stamps (N·m)."""
        still = np.ones(1, dtype=bool)
        return self.thresholds_at(self.rest_band[None, :], np.zeros((1, self.rest_band.size)), still)[0]

    def table(self) -> dict[str, np.ndarray]:
        """Per joint: the threshold at rest and the floor (N·m), √a (N·m), ρ, the level, the friction
        band at rest, the noise and the static model's error at rest, the most every joint's encoder
        count together moves its estimate, the contact-free RMS and peak (N·m)."""
        return {
            "threshold_at_rest": self.at_rest,
            "floor": self.floor,
            "noise": self.noise,
            "friction_share": self.friction_share,
            "level": self.level,
            "rest_band": self.rest_band,
            "rest_noise": np.full_like(self.rest_band, np.nan)
            if self.rest_noise is None
            else self.rest_noise,
            "rest_error": np.full_like(self.rest_band, np.nan)
            if self.rest_error is None
            else self.rest_error,
            "count_share": np.full_like(self.rest_band, np.nan)
            if self.count_share is None
            else np.sqrt(np.sum(self.count_share**2, axis=1)),
            "rms": self.rms,
            "peak": self.peak,
        }


def fit_spread(residual: np.ndarray, friction: np.ndarray, min_share: float) -> tuple[float, float]:
    """``(a, ρ)`` of one joint by maximum likelihood of ``r ~ N(0, a + (ρ·φ)²)``, ρ ≥ ``min_share``.

    Residual and friction band are (N,) arrays (N·m); ``a`` is kept above 10⁻¹² of the mean square
    residual (a spread never vanishes).
    """
    r2 = np.square(np.asarray(residual, dtype=float))
    scale = max(float(np.mean(r2)), 1e-300)
    phi2 = np.square(np.asarray(friction, dtype=float))
    phi_scale = float(np.mean(phi2))
    if phi_scale <= 1e-12 * scale:  # no friction in the model: the noise alone
        return max(float(np.mean(r2)), 1e-12 * scale), float(min_share)
    g = phi2 / phi_scale
    rs2 = r2 / scale

    def objective(x: np.ndarray) -> tuple[float, np.ndarray]:
        s2 = x[0] + x[1] * g
        common = 1.0 / s2 - rs2 / s2**2
        return float(np.mean(np.log(s2) + rs2 / s2)), np.array([np.mean(common), np.mean(g * common)])

    lower = min_share**2 * phi_scale / scale
    start = np.array([0.5, max(lower, 0.5)])
    bounds = [(1e-12, None), (lower, None)]
    solution = minimize(objective, start, jac=True, method="L-BFGS-B", bounds=bounds).x
    return float(solution[0] * scale), float(np.sqrt(solution[1] * scale / phi_scale))


def calibrate_state_thresholds(
    residuals: Sequence[np.ndarray],
    frictions: Sequence[np.ndarray],
    stamps: Sequence[np.ndarray],
    periods: Sequence[float],
    false_alarm_rate: float,
    margin: float = 1.0,
    friction_drift: float = 0.0,
    rest_friction: np.ndarray | None = None,
    rests: Sequence[np.ndarray] | None = None,
    count_share: np.ndarray | None = None,
    position_step: np.ndarray | None = None,
) -> StateCalibration:
    """State-dependent thresholds from contact-free residuals and their state terms (see the module).

    Parameters
    ----------
    residuals : external torque estimates of contact-free logs, one (N, N_J) array each (N·m).
    frictions : the friction band φ of each log's samples, through the estimator's filter (N·m).
    stamps : the stamps' share ε of each log's samples (N·m; zeros for regular stamps).
    periods : each log's sampling period (s).
    false_alarm_rate : the stated rate, alarms per hour (> 0).
    margin : factor ≥ 1 on the levels.
    friction_drift : share (≥ 0) of its friction by which a run may differ from the calibration's.
    rest_friction : (N_J,) the friction band at rest (N·m), for the floor; None: the smallest φ seen.
    rests : (N,) bool per log, the samples where the arm stands still
        (:func:`lwrlab.monitoring.spread.resting`); None: none known.
    count_share : (N_J, N_J) the most an encoder count of joint k moves joint j's estimate (N·m,
        :func:`lwrlab.monitoring.counts.count_share`); None: no share.
    position_step : (N_J,) the encoders' step δ (rad, :func:`lwrlab.monitoring.counts.position_step`).

    Examples
    --------
    Noise whose spread grows with the friction band: the thresholds follow it.

    >>> rng = np.random.default_rng(0)
    >>> band = np.linspace(0.0, 2.0, 20_000)[:, None]
    >>> r = rng.normal(size=(20_000, 1)) * np.sqrt(0.01 + (0.3 * band) ** 2)
    >>> calibration = calibrate_state_thresholds([r], [band], [0 * band], [1e-3], 1.0)
    >>> round(float(calibration.friction_share[0]), 1), round(float(calibration.noise[0]), 2)
    (0.3, 0.1)
    >>> thresholds = calibration.thresholds_at(np.array([[0.0], [2.0]]), np.zeros((2, 1)))
    >>> bool(thresholds[1, 0] > 5 * thresholds[0, 0])
    True
    """
    _checked(false_alarm_rate, margin, residuals)
    if friction_drift < 0:
        raise ValueError(f"friction_drift must be ≥ 0, got {friction_drift}")
    r = np.vstack([np.asarray(x, dtype=float) for x in residuals])
    phi = np.vstack([np.asarray(x, dtype=float) for x in frictions])
    eps = np.vstack([np.asarray(x, dtype=float) for x in stamps])
    if not r.shape == phi.shape == eps.shape:
        raise ValueError(f"residuals {r.shape}, frictions {phi.shape} and stamps {eps.shape} disagree")
    n_samples, n_joints = r.shape
    duration = float(sum(len(x) * period for x, period in zip(residuals, periods, strict=True)))
    probability = exceedance_probability(false_alarm_rate, duration / n_samples, n_joints)
    min_share = friction_drift / -ndtri(probability / 2)
    beyond = np.maximum(np.abs(r) - eps, 0.0)  # what the stamps do not explain
    fitted = [fit_spread(beyond[:, j], phi[:, j], min_share) for j in range(n_joints)]
    noise = np.sqrt([a for a, _ in fitted])
    share = np.array([rho for _, rho in fitted])
    level = tail_level(beyond / np.sqrt(noise**2 + (share * phi) ** 2), probability)
    rest = phi.min(axis=0) if rest_friction is None else np.asarray(rest_friction, dtype=float)
    rest_noise, rest_error = None, None
    if rests is not None:
        if sum(len(x) for x in rests) != n_samples:
            raise ValueError(
                f"rests mark {sum(len(x) for x in rests)} samples, the residuals have {n_samples}"
            )
        still_s = sum(float(np.count_nonzero(x)) * p for x, p in zip(rests, periods, strict=True))
        if still_s >= MIN_REST_S:
            rest_noise, rest_error = rest_terms(residuals, rests, rest)
    return StateCalibration(
        noise=noise,
        friction_share=share,
        level=level,
        floor=margin * np.sqrt((level * noise) ** 2 + rest**2),
        rest_band=rest,
        rest_noise=rest_noise,
        rest_error=rest_error,
        rms=np.sqrt(np.mean(r**2, axis=0)),
        peak=np.abs(r).max(axis=0),
        exceedance_probability=float(probability),
        false_alarm_rate=float(false_alarm_rate),
        margin=float(margin),
        count_share=None if count_share is None else np.asarray(count_share, dtype=float),
        position_step=None if position_step is None else np.asarray(position_step, dtype=float),
        friction_drift=float(friction_drift),
        samples=int(n_samples),
        duration_s=duration,
    )
