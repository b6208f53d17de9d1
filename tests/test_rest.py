"""Joints standing still: rest speeds from the positions' noise, zero speed at rest, rows at rest."""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.plants.planned_motions import PointToPoint
from lwrlab.signal.processing import process
from lwrlab.signal.rest import REST_FLOOR, at_rest, rest_speeds, speed_noise

RATE = 1000.0


def test_speed_noise_is_the_spread_of_a_standing_joints_processed_speed() -> None:
    """The formula's σ_v (white position noise through the states' filter and a derivative) is what a
    standing joint's processed speed really spreads by, whatever the noise."""
    rng = np.random.default_rng(1)
    t = np.arange(20_000) / RATE
    for sigma_q in (1e-6, 1e-5, 1e-4):
        q = 0.3 + sigma_q * rng.standard_normal((t.size, 2))
        data = process(t, q, np.zeros_like(q), cutoff_hz=10.0, state_cutoff_hz=20.0, rest_sigmas=None)
        measured = data.dq[data.index].std(axis=0)
        predicted = speed_noise(q, RATE, 20.0)
        np.testing.assert_allclose(measured / predicted, 1.0, atol=0.25)


def test_a_standing_joint_reads_zero_speed_and_a_moving_one_keeps_its_own() -> None:
    """With ``rest_sigmas`` σ, a noisy standing joint reads zero speed at nearly every sample; a moving
    joint's speed, far above its noise, is untouched."""
    rng = np.random.default_rng(2)
    t = np.arange(10_000) / RATE
    moving = 0.5 * np.sin(2 * np.pi * 0.4 * t)
    q = np.column_stack([np.full_like(t, 0.3), moving]) + 1e-5 * rng.standard_normal((t.size, 2))
    kept = process(t, q, np.zeros_like(q), cutoff_hz=5.0, rest_sigmas=None)
    rested = process(t, q, np.zeros_like(q), cutoff_hz=5.0, rest_sigmas=3.0)
    rows = rested.index  # past the filter's edge transients
    assert np.mean(rested.dq[rows, 0] == 0.0) > 0.95  # 3 σ: 99.7 % of Gaussian noise, σ_v within 25 %
    assert np.mean(kept.dq[rows, 0] == 0.0) < 0.01
    fast = np.abs(kept.dq[:, 1]) > 10 * rested.rest_speeds[1]
    np.testing.assert_array_equal(rested.dq[fast, 1], kept.dq[fast, 1])
    np.testing.assert_array_equal(rested.ddq, kept.ddq)  # accelerations are not stepped at the threshold


def test_exact_positions_at_rest_give_exactly_zero_speed_by_default() -> None:
    """Positions that do not change (exact, or quantised without noise) read zero speed, not the
    rounding of a filter whose sign a Coulomb column would take."""
    t = np.arange(3000) / RATE
    q = np.tile([0.7, -1.3], (t.size, 1))
    data = process(t, q, np.zeros_like(q), cutoff_hz=5.0)
    assert np.all(data.dq == 0.0)
    assert np.all(data.rest_speeds == REST_FLOOR)


def test_rest_speeds_grow_with_the_noise_and_at_rest_zeroes_below_them() -> None:
    rng = np.random.default_rng(3)
    quiet, loud = (s * rng.standard_normal((5000, 1)) for s in (1e-6, 1e-4))
    assert rest_speeds(loud, RATE, 20.0, 3.0)[0] > 50 * rest_speeds(quiet, RATE, 20.0, 3.0)[0]
    v = np.array([[1e-3, -2e-3, 5e-2]]).T
    np.testing.assert_array_equal(at_rest(v, np.array([3e-3])), [[0.0], [0.0], [5e-2]])
    assert at_rest(v, None) is v
    with pytest.raises(ValueError, match="non-negative"):
        rest_speeds(quiet, RATE, 20.0, sigmas=-1.0)


def _friction_log(motion: PointToPoint) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact positions and ``τ = Fc·sign(q̇) + Fv·q̇`` of a one-joint motion (friction zero at rest:
    the middle of the static band)."""
    t = np.arange(int(motion.duration * RATE)) / RATE
    q, dq, _ = motion.evaluate(t)
    return t, q, 0.4 * np.sign(dq) + 0.3 * dq


def test_more_data_with_rests_and_exact_positions_never_hurts_the_friction_fit() -> None:
    """A point-to-point cycle that stands most of the time, added to a motion, leaves the fit of a
    noiseless friction model as exact as the motion alone (its standing rows hold no sign of
    rounding), and alone fits it as well."""

    def friction(q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        return np.column_stack([np.sign(dq[:, 0]), dq[:, 0]])

    motion = PointToPoint(np.array([[0.0], [0.8], [-0.4], [0.5]]), np.full(3, 0.9), np.full(4, 0.3))
    cycle = PointToPoint(np.array([[0.1], [0.6], [0.2]]), np.full(2, 1.2), np.array([2.0, 3.0, 4.0]))
    errors = {}
    for name, logs in {"motion": [motion], "motion + cycle": [motion, cycle], "cycle": [cycle]}.items():
        rows = [process(*_friction_log(m), cutoff_hz=5.0) for m in logs]
        blocks = [d.rows(friction) for d in rows]
        w, y = np.vstack([b[0] for b in blocks]), np.concatenate([b[1] for b in blocks])
        errors[name] = np.abs(np.linalg.lstsq(w, y, rcond=None)[0] - [0.4, 0.3]).max()
    assert errors["motion + cycle"] <= 1.05 * errors["motion"] + 1e-6
    assert errors["cycle"] < 0.02
