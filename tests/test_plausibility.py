"""Plausibility of a log against its robot: limits, units, dead sensors, corrupt cells, dtypes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lwrlab.io.column_types import check_column_dtypes, column_dtype_finding
from lwrlab.io.log_findings import Finding, LogColumns, raise_for_errors
from lwrlab.io.logs import LogError
from lwrlab.io.plausibility import check_plausibility
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from plugins.plants.simulated import SimulatedPlant

N_SAMPLES = 2000  # 2 s at 1 kHz
CSV = Path("robot_log.csv")


def _log(robot: RobotModel, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A plausible 1 kHz log: every joint moves within its limits, torques within theirs, with noise."""
    t = np.arange(N_SAMPLES) * 1e-3
    limits = robot.limits
    center = 0.5 * (limits.position_lower + limits.position_upper)
    phase = rng.uniform(0, 2 * np.pi, robot.n_joints)
    q = center + 0.3 * (limits.position_upper - limits.position_lower) * np.sin(
        2 * np.pi * 0.5 * t[:, None] + phase
    )
    tau = 0.4 * limits.torque * np.cos(2 * np.pi * 0.5 * t[:, None] + phase) + 0.05 * rng.normal(size=q.shape)
    return t, q, tau


def _checks(findings: list[Finding]) -> set[tuple[str, str | None, str]]:
    return {(f.severity, f.column, f.check) for f in findings}


def test_plausible_log_has_no_finding(lwr4, rng):
    t, q, tau = _log(lwr4, rng)
    assert check_plausibility(t, q, tau, lwr4.limits, CSV) == []
    assert raise_for_errors([]) == []


def test_simulated_robot_log_has_no_finding(lwr4):
    """The simulated plant (CAD ± 10 %, sensor noise) on a motion at 80 % of the limits: no false alarm."""
    motion = build("trajectory", "multisine", duration=4.0, seed=0).sample(lwr4, 1000.0)
    measurement = SimulatedPlant(lwr4, seed=0, show_progress=False).measure(motion)
    assert (
        check_plausibility(measurement.t, measurement.q, measurement.tau, lwr4.limits, CSV, dq=motion.dq)
        == []
    )


def test_positions_in_degrees_are_an_error_with_the_hint(lwr4, rng):
    t, q, tau = _log(lwr4, rng)
    columns = LogColumns.schema(lwr4.n_joints, column_map={"q2": "pos_1"})
    findings = check_plausibility(t, np.degrees(q), tau, lwr4.limits, CSV, columns)
    assert findings and all(f.severity == "error" and f.check == "position_limit" for f in findings)
    by_column = {f.column: f for f in findings}
    assert "pos_1" in by_column and "q2" not in by_column  # the column's name in the file
    message = str(by_column["pos_1"])
    assert message.startswith("robot_log.csv: column 'pos_1': joint 2 position")
    assert "set data.position_unit=deg" in message and "line " in message


@pytest.mark.parametrize(("excess", "severity"), [(0.01, "warning"), (0.3, "error")])
def test_position_beyond_the_limit_says_by_how_much(lwr4, rng, excess, severity):
    t, q, tau = _log(lwr4, rng)
    q[777, 3] = lwr4.limits.position_upper[3] + excess
    (finding,) = check_plausibility(t, q, tau, lwr4.limits, CSV)
    assert (finding.severity, finding.column, finding.check) == (severity, "q4", "position_limit")
    assert f"by {excess:.3g} rad" in finding.message and "row 777 (line 779 of the file)" in finding.message
    assert "degrees" not in finding.message  # small values: no degree hint


def test_radians_declared_as_degrees_warn(lwr4, rng):
    t, q, tau = _log(lwr4, rng)
    findings = check_plausibility(t, np.radians(q), tau, lwr4.limits, CSV, position_unit="deg")
    assert _checks(findings) == {("warning", None, "position_unit")}
    assert "data.position_unit=rad" in findings[0].message


@pytest.mark.parametrize(("factor", "severity"), [(2.0, "warning"), (10.0, "error")])
def test_torques_beyond_the_limit(lwr4, rng, factor, severity):
    t, q, tau = _log(lwr4, rng)
    tau[:, 5] *= factor / 0.4  # peak = factor × limit
    (finding,) = check_plausibility(t, q, tau, lwr4.limits, CSV)
    assert (finding.severity, finding.column, finding.check) == (severity, "tau6", "torque_limit")
    ratio = float(finding.message.split("× its limit 38 N·m")[0].rsplit(" ", 1)[1])
    assert ratio == pytest.approx(factor, rel=0.02)
    assert ("currents" in finding.message) == (severity == "error")


def test_current_log_hint_names_the_drive_gains(lwr4, rng):
    t, q, tau = _log(lwr4, rng)
    columns = LogColumns.schema(lwr4.n_joints, torque_from_current=True)
    (finding,) = check_plausibility(t, q, tau * [1, 1, 1, 1, 1, 1, 20], lwr4.limits, CSV, columns)
    assert finding.column == "current7" and "data.drive_gains" in finding.message


def test_dead_sensors_and_still_joints(lwr4, rng):
    t, q, tau = _log(lwr4, rng)
    tau[:, 1] = 0.0  # torque sensor not recorded
    tau[:, 2] = 3.5  # stuck
    q[:, 4] = 0.3 + 1e-5 * rng.normal(size=len(t))  # held by the controller
    q[:, 6] = 0.0  # encoder not recorded
    findings = check_plausibility(t, q, tau, lwr4.limits, CSV)
    assert _checks(findings) == {
        ("error", "tau2", "zero_torque"),
        ("warning", "tau3", "constant_torque"),
        ("warning", "q5", "still_joint"),
        ("warning", "q7", "zero_position"),
    }
    assert findings[0].severity == "error"  # errors first


@pytest.mark.parametrize(
    ("period", "declared", "suggested"),
    [(1.0, "s", "ms"), (1e6, "s", "ns"), (1e-6, "ms", "s"), (1.0, "ms", "us")],
)
def test_time_unit_is_named_when_the_period_is_implausible(lwr4, rng, period, declared, suggested):
    """``period``: the median step after conversion from the declared unit (1 ms stamps in ms read as
    s: 1.0 s)."""
    _, q, tau = _log(lwr4, rng)
    t = np.arange(N_SAMPLES) * period
    (finding,) = check_plausibility(t, q, tau, lwr4.limits, CSV, time_unit=declared)
    assert (finding.severity, finding.column, finding.check) == ("error", "t", "sampling_period")
    assert (
        f"data.time_unit={suggested}" in finding.message
        and f"data.time_unit={declared} is implausible" in finding.message
    )


def test_absurd_value_names_the_row_and_hides_the_consequences(lwr4, rng):
    t, q, tau = _log(lwr4, rng)
    tau[1234, 2] = 1e30
    q[10, 0] = -np.inf
    findings = check_plausibility(t, q, tau, lwr4.limits, Path("log.parquet"))
    assert _checks(findings) == {("error", "tau3", "absurd_value"), ("error", "q1", "absurd_value")}
    tau_finding = next(f for f in findings if f.column == "tau3")
    assert (
        "row 1234:" in tau_finding.message
        and "1e+30" in tau_finding.message
        and "line" not in tau_finding.message
    )


def test_velocities_in_degrees_per_second(lwr4, rng):
    t, q, tau = _log(lwr4, rng)
    dq = np.gradient(q, t, axis=0)
    assert check_plausibility(t, q, tau, lwr4.limits, CSV, dq=dq) == []
    dq[:, 0] = np.degrees(dq[:, 0]) + 10 * lwr4.limits.velocity[0]
    (finding,) = check_plausibility(t, q, tau, lwr4.limits, CSV, dq=dq)
    assert (finding.column, finding.check) == (
        "dq1",
        "velocity_limit",
    ) and "degrees per second" in finding.message


def test_raise_for_errors_lists_every_error_and_returns_warnings(lwr4, rng):
    t, q, tau = _log(lwr4, rng)
    tau[:, 0] = 0.0
    tau[:, 1] = 0.0
    q[:, 4] = 0.3
    findings = check_plausibility(t, q, tau, lwr4.limits, CSV)
    with pytest.raises(LogError) as caught:
        raise_for_errors(findings)
    message = str(caught.value)
    assert message.startswith("implausible log robot_log.csv: 2 error(s)")
    assert (
        "'tau1'" in message
        and "'tau2'" in message
        and "[zero_torque]" in message
        and "never moves" in message
    )
    warnings = raise_for_errors([f for f in findings if f.severity == "warning"])
    assert [(f.column, f.check) for f in warnings] == [("q5", "still_joint")]


def test_limits_are_optional(rng, lwr4):
    t, q, tau = _log(lwr4, rng)
    assert check_plausibility(t, np.degrees(q), 100 * tau, None, CSV) == []  # nothing to compare with


def test_shapes_and_units_are_checked(lwr4, rng):
    t, q, tau = _log(lwr4, rng)
    with pytest.raises(ValueError, match="shapes disagree"):
        check_plausibility(t[:-1], q, tau, lwr4.limits, CSV)
    with pytest.raises(ValueError, match="time_unit"):
        check_plausibility(t, q, tau, lwr4.limits, CSV, time_unit="h")
    with pytest.raises(ValueError, match="severity"):
        Finding("fatal", "f", None, "x", "y")


# --- dtypes of typed (Parquet) files ---------------------------------------------------------------


def test_parquet_dtypes_that_are_not_numbers(tmp_path):
    n = 5
    frame = pd.DataFrame(
        {
            "t": pd.date_range("2024-01-01", periods=n, freq="ms"),
            "q1": np.linspace(0, 1, n),
            "q2": np.arange(n),  # integers are numbers
            "tau1": [True, False, True, True, False],
            "tau2": pd.array([1, 2, None, 4, 5], dtype="Int64"),  # nullable integers too
            "dq1": ["a", "b", "c", "d", "e"],
            "dq2": pd.to_timedelta(np.arange(n), unit="s"),
        }
    )
    path = tmp_path / "log.parquet"
    frame.to_parquet(path, index=False)
    columns = LogColumns(t="t", q=("q1", "q2"), tau=("tau1", "tau2"), dq=("dq1", "dq2"))
    findings = {f.column: f for f in check_column_dtypes(pd.read_parquet(path), columns, path)}
    assert set(findings) == {"t", "tau1", "dq1", "dq2"}
    assert all(f.severity == "error" and f.check == "dtype" for f in findings.values())
    assert "convert it to seconds" in findings["t"].message and "data.time_unit" in findings["t"].message
    assert "booleans" in findings["tau1"].message and "N·m" in findings["tau1"].message
    assert "not numbers" in findings["dq1"].message
    assert "total_seconds" in findings["dq2"].message
    assert column_dtype_finding(pd.Series([1.0, 2.0]), "q1", path) is None
    assert (
        check_column_dtypes(frame.drop(columns=["t", "tau1", "dq1", "dq2"]), columns, path) == []
    )  # absent columns are the loader's business


def test_torques_held_on_a_faster_grid_warn_with_their_own_rate(lwr4, rng):
    """Torques recorded at 250 Hz and forward-filled onto the 1 kHz grid of the positions (two topics
    merged): a warning naming the torques' rate; the same log with fresh torques has none."""
    t, q, tau = _log(lwr4, rng)
    held = tau[(np.arange(len(t)) // 4) * 4]
    (finding,) = check_plausibility(t, q, held, lwr4.limits, CSV)
    assert (finding.severity, finding.column, finding.check) == ("warning", None, "held_torques")
    assert "about 250 Hz" in finding.message and "1000 Hz grid" in finding.message
    assert "row 1 (line 3 of the file)" in finding.message
    # a joint whose torque is not fitted does not hide the others' repeats, nor raise them alone
    columns = LogColumns.schema(lwr4.n_joints)
    alone = tau.copy()
    alone[:, 6] = held[:, 6]
    assert check_plausibility(t, q, alone, lwr4.limits, CSV, columns) == []
    assert check_plausibility(t, q, held, lwr4.limits, CSV, unfitted=[6])[0].check == "held_torques"
