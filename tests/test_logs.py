"""Recorded logs: schema round trip, identification from a log, and every malformation's error."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from composing import compose_config

from lwrlab.io.logs import LogError, load_log, log_frame, write_log
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.pipeline.identification import identify
from lwrlab.plants.core import Measurement
from plugins.plants.log import LogPlant
from plugins.plants.simulated import SimulatedPlant


def _measurement(n: int = 200, n_joints: int = 2) -> Measurement:
    t = np.arange(n) * 1e-3
    q = np.column_stack([np.sin(t * (j + 1)) for j in range(n_joints)])
    return Measurement(t=t, q=q, tau=np.cos(q) + 0.1, metadata={})


def _write_frame(frame: pd.DataFrame, path: Path) -> Path:
    frame.to_csv(path, index=False, float_format="%.17g")
    return path


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_write_then_load_is_exact(tmp_path: Path, suffix: str) -> None:
    measurement = _measurement()
    log = load_log(write_log(measurement, tmp_path / f"log{suffix}"), n_joints=2)
    np.testing.assert_array_equal(log.t, measurement.t)
    np.testing.assert_array_equal(log.q, measurement.q)
    np.testing.assert_array_equal(log.tau, measurement.tau)
    assert not log.resampled and log.dq is None
    assert log.to_measurement().metadata["source"] == "log"


def test_identifying_from_a_log_equals_identifying_in_memory(lwr4: RobotModel, tmp_path: Path) -> None:
    """simulate → write log → load log → identify gives the in-memory identification's parameters."""
    motion = build("trajectory", "multisine", duration=3.0, harmonics=3, seed=0)
    validation = build("trajectory", "multisine", duration=3.0, harmonics=4, seed=5)
    rate, processing = 200.0, {"cutoff_hz": 10.0, "trim_s": 0.2}
    simulated = SimulatedPlant(lwr4, torque_noise_std=0.1, seed=4, show_progress=False)
    in_memory = identify(lwr4, motion, validation, simulated, build("estimator", "ols"), rate, processing)
    paths = [
        write_log(m, tmp_path / name)
        for m, name in ((in_memory.measurement, "id.csv"), (in_memory.validation_measurement, "val.csv"))
    ]
    plant = LogPlant(lwr4, str(paths[0]), validation_path=str(paths[1]))
    from_log = identify(lwr4, motion, validation, plant, build("estimator", "ols"), rate, processing)
    np.testing.assert_allclose(
        from_log.identified.base_values, in_memory.identified.base_values, rtol=1e-12, atol=1e-12
    )
    np.testing.assert_allclose(from_log.validation["rms"], in_memory.validation["rms"], rtol=1e-12)
    assert "truth" not in from_log.parameters.columns  # a log has no ground truth


def test_column_map_units_and_currents(tmp_path: Path) -> None:
    measurement = _measurement()
    frame = pd.DataFrame(
        {
            "timestamp_ms": measurement.t * 1e3,
            "pos_a": np.degrees(measurement.q[:, 0]),
            "pos_b": np.degrees(measurement.q[:, 1]),
            "current1": measurement.tau[:, 0] / 2.0,
            "current2": measurement.tau[:, 1] / 4.0,
        }
    )
    log = load_log(
        _write_frame(frame, tmp_path / "robot.csv"),
        n_joints=2,
        column_map={"t": "timestamp_ms", "q1": "pos_a", "q2": "pos_b"},
        time_unit="ms",
        position_unit="deg",
        drive_gains=[2.0, 4.0],
    )
    np.testing.assert_allclose(log.t, measurement.t, atol=1e-15)
    np.testing.assert_allclose(log.q, measurement.q, rtol=1e-13)
    np.testing.assert_allclose(log.tau, measurement.tau, rtol=1e-13)


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".npz"])
@pytest.mark.parametrize("first", [1, 0])
def test_a_block_in_the_column_map_is_the_prefix_of_its_joints_columns(
    tmp_path: Path, suffix: str, first: int
) -> None:
    """``{q: pos_, tau: eff_}`` reads ``pos_1, pos_2`` (or ``pos_0, pos_1``) in every format."""
    measurement = _measurement()
    columns = {"time": measurement.t}
    for j in range(2):
        columns[f"pos_{j + first}"] = measurement.q[:, j]
        columns[f"eff_{j + first}"] = measurement.tau[:, j]
    path = tmp_path / f"prefixed{suffix}"
    if suffix == ".npz":
        np.savez(path, **columns)
    elif suffix == ".parquet":
        pd.DataFrame(columns).to_parquet(path, index=False)
    else:
        _write_frame(pd.DataFrame(columns), path)
    log = load_log(path, n_joints=2, column_map={"t": "time", "q": "pos_", "tau": "eff_"})
    np.testing.assert_array_equal(log.q, measurement.q)
    np.testing.assert_array_equal(log.tau, measurement.tau)


def test_a_missing_column_names_the_setting_that_maps_it(tmp_path: Path) -> None:
    frame = log_frame(_measurement()).rename(columns={"tau1": "effort_1", "tau2": "effort_2"})
    with pytest.raises(LogError, match=r"missing column 'tau1'.*data\.column_map.*\{tau: <prefix>\}"):
        load_log(_write_frame(frame, tmp_path / "efforts.csv"), n_joints=2)


def test_irregular_time_is_resampled_onto_a_uniform_grid(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    t = np.cumsum(np.full(500, 1e-3) * (1 + 0.3 * rng.uniform(-1, 1, 500)))
    frame = pd.DataFrame({"t": t, "q1": 2 * t + 1, "tau1": -t})  # linear: interpolation is exact
    log = load_log(_write_frame(frame, tmp_path / "jitter.csv"), n_joints=1, rate_hz=1000.0)
    assert log.resampled
    np.testing.assert_allclose(np.diff(log.t), 1e-3, rtol=1e-9)
    np.testing.assert_allclose(log.q[:, 0], 2 * log.t + 1, rtol=1e-12)
    np.testing.assert_allclose(log.tau[:, 0], -log.t, atol=1e-15)


def _broken(tmp_path: Path, edit) -> Path:
    frame = log_frame(_measurement()).astype(object)
    edit(frame)
    return _write_frame(frame, tmp_path / "broken.csv")


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda f: f.pop("tau2"), r"broken.csv: missing column 'tau2'"),
        (
            lambda f: f.__setitem__("q1", f["q1"].where(f.index != 7, np.nan)),
            r"column 'q1', row 7 \(line 9 of the file\): missing value",
        ),
        (
            lambda f: f.__setitem__("tau1", f["tau1"].where(f.index != 12, "12,5 Nm")),
            r"column 'tau1', row 12 .*non-numeric value '12,5 Nm'",
        ),
        (
            lambda f: f.__setitem__("t", f["t"].where(f.index != 30, 0.0)),
            r"column 't', row 30 .*does not increase",
        ),
        (
            lambda f: f.__setitem__("t", f["t"] + np.where(f.index >= 50, 1.0, 0.0)),
            r"column 't', row 50 .*gap",
        ),
        (
            lambda f: f.__setitem__("q2", f["q2"].where(f.index != 3, "inf")),
            r"column 'q2', row 3 .*non-finite",
        ),
    ],
    ids=["missing-column", "nan", "non-numeric", "non-monotonic", "gap", "infinite"],
)
def test_malformed_logs_name_file_column_and_row(tmp_path: Path, edit, message: str) -> None:
    with pytest.raises(LogError, match=message):
        load_log(_broken(tmp_path, edit), n_joints=2)


def test_too_short_log_and_mapped_missing_column(tmp_path: Path) -> None:
    path = write_log(_measurement(n=50), tmp_path / "short.csv")
    with pytest.raises(LogError, match=r"short\.csv: 50 rows, too short"):
        load_log(path, n_joints=2)
    with pytest.raises(LogError, match="missing column 'stamp' \\(schema column 't'"):
        load_log(path, n_joints=2, column_map={"t": "stamp"}, min_samples=10)
    with pytest.raises(LogError, match="no such log file"):
        load_log(tmp_path / "absent.csv", n_joints=2)


def test_log_plant_splits_a_single_log_by_role(tmp_path: Path, lwr4: RobotModel) -> None:
    log_path = write_log(_measurement(n=1000, n_joints=7), tmp_path / "one.csv")
    plant = LogPlant(lwr4, str(log_path), validation_fraction=0.25)
    dummy = build("trajectory", "multisine", duration=1.0).sample(lwr4, 100.0)
    identification = plant.measure(dummy)
    validation = plant.measure(type(dummy)(dummy.t, dummy.q, dummy.dq, dummy.ddq, {"role": "validation"}))
    assert (len(identification.t), len(validation.t)) == (750, 250)
    assert validation.t[0] > identification.t[-1]


def test_plant_log_data_path_composes(tmp_path: Path) -> None:
    cfg = compose_config("plant=log", f"data.path={tmp_path / 'x.csv'}")
    assert cfg.plant._target_ == "plugins.plants.log.LogPlant"
    assert cfg.plant.path == str(tmp_path / "x.csv")
