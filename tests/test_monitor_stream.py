"""The monitor's streaming form (lwrlab/monitoring/stream.py) equals the offline monitor sample by sample.

The offline monitor is the streaming computation vectorised over a log: on pushed MuJoCo logs, with
state and constant thresholds, one sample at a time gives the same estimates, thresholds and
contacts (start, raising, end, joint, peak). The causal low-pass equals scipy's ``sosfilt``; the
detector equals :func:`~lwrlab.monitoring.detection.detect_contacts` on random ratios.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from pushed_logs import SETTINGS, pushed_log
from scipy.signal import butter, sosfilt, sosfilt_zi

from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.detection import detect_contacts
from lwrlab.monitoring.estimates import (
    calibrate,
    detect,
    estimate_external_torques,
    thresholds_of,
)
from lwrlab.monitoring.stream import CausalLowpass, ContactDetector, MonitorStream, replay
from lwrlab.plants.core import Measurement
from lwrlab.plants.pushed_arm import ExternalForce


@pytest.fixture(scope="module")
def pushed(lwr4: RobotModel):
    """A contact-free log and one with three pushes, 3 s each."""
    pushes = [
        ExternalForce(1.0, 0.3, 4, np.array([0.0, 0.05, 0.1]), np.array([0.0, 30.0, 0.0])),
        ExternalForce(1.8, 0.2, 6, np.array([0.0, 0.0, 0.05]), np.array([20.0, 0.0, 0.0])),
        ExternalForce(2.75, 0.5, 4, np.array([0.0, 0.05, 0.1]), np.array([0.0, 80.0, 0.0])),
    ]
    return pushed_log(lwr4, 5, [], "free"), pushed_log(lwr4, 6, pushes, "pushed")


def test_causal_lowpass_equals_sosfilt() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=(400, 3, 7)).cumsum(axis=0)
    sos = butter(2, 30.0, fs=1000.0, output="sos")
    expected = sosfilt(sos, x, axis=0, zi=sosfilt_zi(sos)[:, :, None, None] * x[0][None, None])[0]
    stepped = CausalLowpass(30.0, 1e-3)
    stepped.start(x[0])
    got = np.array([stepped.step(row) for row in x])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(x).max())


@pytest.mark.parametrize("seed", range(5))
def test_the_detector_equals_detect_contacts(seed: int) -> None:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 3000))
    # a slowly wandering ratio crossing 1 and the release often, two joints
    torque = np.abs(np.cumsum(rng.normal(0, 0.08, (3000, 2)), axis=0)) % 2.0
    torque[-50:, 1] = 5.0  # a contact still on at the end
    thresholds = np.array([1.0, 1.2])
    expected = detect_contacts(t, torque, thresholds, min_duration=0.004, release=0.5)
    detector = ContactDetector(0.004, 0.5)
    for k in range(len(t)):
        detector.update(k, float(t[k]), np.abs(torque[k]) / thresholds, torque[k])
    detector.finish(len(t), float(t[-1]))
    assert len(expected) > 3 and expected[-1].end_index == len(t)
    _assert_same_detections(detector.detections, expected)


def _assert_same_detections(got: list, expected: list) -> None:
    """The same contacts: samples exactly, times and torques to rounding."""
    assert len(got) == len(expected)
    for a, b in zip(got, expected, strict=True):
        assert (a.start_index, a.peak_index, a.end_index, a.joint) == (
            b.start_index,
            b.peak_index,
            b.end_index,
            b.joint,
        )
        np.testing.assert_allclose(
            [a.start, a.raised, a.end, a.peak_torque, a.peak_ratio],
            [b.start, b.raised, b.end, b.peak_torque, b.peak_ratio],
            rtol=1e-9,
        )


def _coarse(measurement: Measurement, step: float) -> Measurement:
    """The log read by encoders of ``step`` rad."""
    return replace(measurement, q=np.round(measurement.q / step) * step)


@pytest.mark.parametrize(("thresholds", "step"), [("state", 0.0), ("constant", 0.0), ("state", 1e-4)])
def test_the_stream_equals_the_offline_monitor(
    lwr4: RobotModel, pushed, thresholds: str, step: float
) -> None:
    """Also on coarse encoders (0.1 mrad), where the counts' share moves the thresholds."""
    settings = replace(SETTINGS, thresholds=thresholds)
    free, monitored = pushed
    if step:
        free, monitored = _coarse(free, step), _coarse(monitored, step)
    calibrations = calibrate([estimate_external_torques(lwr4, free, settings)], settings)
    offline = estimate_external_torques(lwr4, monitored, settings)
    found = detect(offline, calibrations, settings)["observer"]
    stream = MonitorStream.of(lwr4, settings, calibrations["observer"], float(np.mean(np.diff(monitored.t))))
    record = replay(stream, monitored.t, monitored.q, monitored.tau)

    np.testing.assert_array_equal(record.t, monitored.t)
    np.testing.assert_array_equal(record.monitored, offline.watched("observer"))
    expected = np.where(offline.watched("observer")[:, None], offline.observer, 0.0)
    scale = np.abs(expected).max()
    np.testing.assert_allclose(record.external_torque, expected, rtol=0, atol=1e-9 * scale)
    limits = thresholds_of(offline, calibrations, "observer")
    np.testing.assert_allclose(record.thresholds, limits, rtol=1e-9)
    if step:  # the counts' share is in both
        unshared = replace(calibrations["observer"], count_share=None)
        assert np.any(
            limits > 1.01 * unshared.thresholds_at(*offline.state_terms("observer"), offline.resting)
        )
    assert len(found) == 3
    _assert_same_detections(record.detections, found)
    assert record.in_contact[found[0].start_index + 5] and not record.in_contact[found[0].end_index]


def test_a_restart_begins_a_new_start_up(lwr4: RobotModel, pushed) -> None:
    free, monitored = pushed
    calibrations = calibrate([estimate_external_torques(lwr4, free, SETTINGS)], SETTINGS)
    stream = MonitorStream.of(lwr4, SETTINGS, calibrations["observer"], 1e-3)
    half = len(monitored.t) // 2
    first = replay(stream, monitored.t[:half], monitored.q[:half], monitored.tau[:half])
    stream.reset()
    again = [
        e
        for k in range(half, half + 200)
        for e in stream.update(monitored.t[k], monitored.q[k], monitored.tau[k])
    ]
    assert first.monitored[-1] and not any(e.monitored for e in again[:100])
    assert stream.samples == half + 200
