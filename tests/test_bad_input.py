"""Bad input, table-driven: every case ends in a clear error or a printed warning, never a silent number.

Each row is a case a hostile tester tried: its overrides (files it needs are written from one clean
simulated log), and the error class and message fragment expected — or, for data that runs but
cannot be trusted, the warning fragment printed beside the result. Rows run in process through the
entry point's ``run`` (the same checks as ``lwrlab``); a few run ``lwrlab`` as a subprocess to check
the one-line message and the exit status.
"""

from __future__ import annotations

import functools
import os
import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from composing import compose_config
from hydra.errors import CompactHydraException, ConfigCompositionException

from lwrlab.cli import _user_error, run
from lwrlab.errors import ConfigError, IdentifiabilityError, MissingFileError, UnknownNameError, UserError
from lwrlab.io.logs import LogError, log_frame
from lwrlab.pipeline.build import build
from lwrlab.plants.core import Measurement
from plugins.plants.simulated import SimulatedPlant

REPOSITORY = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def clean(lwr4) -> Measurement:
    """A sound 4 s log of the simulated LWR4 at 500 Hz."""
    motion = build("trajectory", "multisine", duration=4.0, harmonics=3, seed=0).sample(lwr4, 500.0)
    return SimulatedPlant(lwr4, seed=1, show_progress=False).measure(motion)


def _frame(clean: Measurement) -> pd.DataFrame:
    return log_frame(clean)


def _still_joint_5(clean: Measurement) -> pd.DataFrame:
    frame = _frame(clean)
    frame["q5"] = 0.3  # joint 5 held by its brake
    return frame


def _degrees(clean: Measurement) -> pd.DataFrame:
    frame = _frame(clean)
    for j in range(1, 8):
        frame[f"q{j}"] = np.degrees(frame[f"q{j}"])
    return frame


def _cell(column: str, row: int, value: object) -> Callable[[Measurement], pd.DataFrame]:
    def edit(clean: Measurement) -> pd.DataFrame:
        frame = _frame(clean).astype(object)
        frame.loc[row, column] = value
        return frame

    return edit


def _zero_torques(clean: Measurement) -> pd.DataFrame:
    frame = _frame(clean)
    for j in range(1, 8):
        frame[f"tau{j}"] = 0.0
    return frame


def _milliseconds(clean: Measurement) -> pd.DataFrame:
    frame = _frame(clean)
    frame["t"] = frame["t"] * 1e3  # written in ms, declared in s
    return frame


def _boolean_torque(clean: Measurement) -> pd.DataFrame:
    frame = _frame(clean)
    frame["tau3"] = frame["tau3"] > 0
    return frame


def _datetime_time(clean: Measurement) -> pd.DataFrame:
    frame = _frame(clean)
    frame["t"] = pd.Timestamp("2026-01-01") + pd.to_timedelta(frame["t"], unit="s")
    return frame


def _missing_column(clean: Measurement) -> pd.DataFrame:
    return _frame(clean).drop(columns=["tau4"])


def _time_backwards(clean: Measurement) -> pd.DataFrame:
    frame = _frame(clean)
    frame.loc[300, "t"] = frame.loc[298, "t"]
    return frame


@dataclass(frozen=True)
class Case:
    """One bad input: what the user typed (and the log it names), what must come back."""

    name: str
    overrides: tuple[str, ...] = ()
    log: Callable[[Measurement], pd.DataFrame] | None = None
    """The identification log, edited from the clean one (None: no log)."""
    suffix: str = ".csv"
    error: type[Exception] | None = None
    fragment: str = ""
    """In the error's message, or (without error) in what the run prints."""
    files: tuple[tuple[str, str], ...] = ()
    """Other files the case needs (a robot description): name in the test's folder, text."""


LOG = ("task=identification", "plant=log", "tracking=none")
CASES = [
    # confident garbage before: now a printed warning beside the result
    Case(
        "tiny multisine motion",
        (
            "task=identification",
            "tracking=none",
            "trajectory=multisine",
            "trajectory.harmonics=2",
            "trajectory.limit_fraction=0.001",
            "trajectory.duration=4",
            "validation.duration=4",
        ),
        fragment="WARNING: identifiability poor",
    ),
    Case("joint 5 never moves", LOG, _still_joint_5, fragment="joint 5"),
    # implausible logs: errors naming the file, the column, the check
    Case("positions in degrees", LOG, _degrees, error=LogError, fragment="data.position_unit=deg"),
    Case("one 1e30 cell", LOG, _cell("tau2", 321, "1e30"), error=LogError, fragment="'tau2'"),
    Case("all torques zero", LOG, _zero_torques, error=LogError, fragment="zero_torque"),
    Case(
        "boolean torque column (Parquet)",
        LOG,
        _boolean_torque,
        suffix=".parquet",
        error=LogError,
        fragment="'tau3'",
    ),
    Case("time in ms declared as s", LOG, _milliseconds, error=LogError, fragment="data.time_unit=ms"),
    Case(
        "datetime time column (Parquet)",
        LOG,
        _datetime_time,
        suffix=".parquet",
        error=LogError,
        fragment="seconds",
    ),
    Case("NaN cell", LOG, _cell("q6", 40, "nan"), error=LogError, fragment="column 'q6', row 40"),
    Case(
        "text in a number column",
        LOG,
        _cell("tau1", 7, "n/a"),
        error=LogError,
        fragment="non-numeric value 'n/a'",
    ),
    Case("missing torque column", LOG, _missing_column, error=LogError, fragment="missing column 'tau4'"),
    Case("time going backwards", LOG, _time_backwards, error=LogError, fragment="does not increase"),
    Case("empty CSV", LOG, lambda clean: pd.DataFrame(), error=LogError, fragment="empty file"),
    Case("no log named", LOG, error=LogError, fragment="data.paths"),
    Case("a directory as the log", (*LOG, "data.path={tmp}"), error=LogError, fragment="a directory"),
    Case(
        "unknown log format",
        LOG,
        _frame,
        suffix=".xlsx",
        error=LogError,
        fragment="unknown log format '.xlsx'",
    ),
    Case(
        "velocity logged but none in the log",
        (*LOG, "data.velocity=logged"),
        _frame,
        error=ConfigError,
        fragment="the log has no velocities",
    ),
    Case(
        "cut-off beyond Nyquist",
        (*LOG, "measurement.processing.cutoff_hz=400"),
        _frame,
        error=ConfigError,
        fragment="data.time_unit",
    ),
    Case(
        "simulated tool stage on logs",
        ("task=table3_tools", "plant=log", "tracking=none"),
        _frame,
        error=ConfigError,
        fragment="task=payload",
    ),
    # settings of the wrong type or misspelt: Hydra refuses them while composing (lwrlab/config/ schemas)
    Case(
        "seed not an integer",
        ("task=identification", "tracking=none", "seed=1.5"),
        error=ConfigCompositionException,
        fragment="full_key: seed",
    ),
    Case(
        "filter order not an integer",
        ("task=identification", "tracking=none", "measurement.processing.order=2.5"),
        error=ConfigCompositionException,
        fragment="full_key: measurement.processing.order",
    ),
    Case(
        "parameter spread not a number",
        ("task=identification", "tracking=none", "plant.parameter_spread=abc"),
        error=ConfigCompositionException,
        fragment="full_key: plant.parameter_spread",
    ),
    Case(
        "misspelt setting",
        ("task=identification", "tracking=none", "plant.torque_noise_stdd=0.1"),
        error=ConfigCompositionException,
        fragment="full_key: plant.torque_noise_stdd",
    ),
    # settings checked where the job starts (lwrlab/pipeline/config_checks.py)
    Case(
        "setting forced into a typed option",
        ("task=identification", "tracking=none", "+plant.torque_noise_stdd=0.1"),
        error=ConfigError,
        fragment="plant.torque_noise_stdd: no such setting",
    ),
    Case(
        "noise not a number",
        ("task=identification", "tracking=none", "plant.torque_noise_std=abc"),
        error=ConfigError,
        fragment="plant.torque_noise_std",
    ),
    Case(
        "negative noise",
        ("task=identification", "tracking=none", "plant.torque_noise_std=-1"),
        error=ConfigError,
        fragment="must be a number ≥ 0",
    ),
    Case(
        "zero duration",
        ("task=identification", "tracking=none", "trajectory=multisine", "trajectory.duration=0"),
        error=ConfigError,
        fragment="trajectory.duration=0",
    ),
    Case(
        "cut-off beyond the simulated sensors' Nyquist frequency",
        ("task=identification", "tracking=none", "measurement.processing.cutoff_hz=600"),
        error=ConfigError,
        fragment="measurement.processing.cutoff_hz=600: must be below the Nyquist frequency",
    ),
    Case(
        "negative decimated rate",
        ("task=identification", "tracking=none", "measurement.processing.rate_hz=-50"),
        error=ConfigError,
        fragment="measurement.processing.rate_hz",
    ),
    Case(
        "unknown velocity source",
        (*LOG, "data.velocity=encoder"),
        _frame,
        error=ConfigError,
        fragment="data.velocity='encoder'",
    ),
    Case(
        "validation fraction out of range",
        (*LOG, "data.validation_fraction=1.5"),
        _frame,
        error=ConfigError,
        fragment="data.validation_fraction=1.5",
    ),
]


def _more_joints(clean: Measurement) -> pd.DataFrame:
    frame = _frame(clean)
    frame["q8"], frame["tau8"] = 0.1, 1.0  # the log of an eight-joint robot
    return frame


ONE_JOINT_URDF = """<robot name="one_joint">
  <link name="base"/>
  <link name="arm">
    <inertial><origin xyz="0.1 0 0"/><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" velocity="1" effort="10"/></joint>
</robot>
"""
"""A sound one-joint URDF: what a user's own robot file looks like at its smallest."""

URDF = ("task=identification", "tracking=none", "robot=urdf", "robot.path={tmp}/arm.urdf")
"""A user's own URDF robot (the file written from the case's ``files``)."""
MISTAKES = [
    # a user's own robot: every mistake in its description is one line naming the key or the file
    Case(
        "URDF robot without a path",
        ("task=identification", "tracking=none", "robot=urdf"),
        error=ConfigError,
        fragment="robot.path: must be set",
    ),
    Case(
        "URDF file missing",
        ("task=identification", "tracking=none", "robot=urdf", "robot.path={tmp}/no_such.urdf"),
        error=MissingFileError,
        fragment="no_such.urdf: the URDF file does not exist",
    ),
    Case("not a URDF", URDF, error=ConfigError, fragment="could not parse", files=(("arm.urdf", "not xml"),)),
    Case(
        "URDF without a moving joint",
        URDF,
        error=ConfigError,
        fragment="no joint that moves",
        files=(("arm.urdf", '<robot name="x"><link name="a"/></robot>'),),
    ),
    Case(
        "unknown flange frame",
        (*URDF, "robot.flange_frame=tool0"),
        error=UnknownNameError,
        fragment="robot.flange_frame 'tool0' is not a frame",
        files=(("arm.urdf", ONE_JOINT_URDF),),
    ),
    Case(
        "unknown locked joint",
        (*URDF, "robot.locked_joints=[finger]"),
        error=UnknownNameError,
        fragment="robot.locked_joints ['finger']",
        files=(("arm.urdf", ONE_JOINT_URDF),),
    ),
    Case(
        "acceleration limits of another robot",
        (*URDF, "robot.acceleration_limits=[1,2]"),
        error=ConfigError,
        fragment="robot.acceleration_limits: expected 1 values",
        files=(("arm.urdf", ONE_JOINT_URDF),),
    ),
    Case(
        "MoveIt joint limits missing",
        (*URDF, "robot.joint_limits={tmp}/joint_limits.yaml"),
        error=MissingFileError,
        fragment="robot.joint_limits file",
        files=(("arm.urdf", ONE_JOINT_URDF),),
    ),
    Case(
        "gravity not a 3-vector",
        ("task=identification", "tracking=none", "robot.gravity=[0,-9.81]"),
        error=ConfigError,
        fragment="robot.gravity: expected 3 values",
    ),
    Case(
        "unknown friction term",
        ("task=identification", "tracking=none", "robot.friction_terms=[coulomb,stiction]"),
        error=ConfigError,
        fragment="robot.friction_terms: unknown terms ['stiction']",
    ),
    Case(
        "robot description missing",
        ("task=identification", "tracking=none", "robot=mdh_file", "robot.path={tmp}/arm.yaml"),
        error=MissingFileError,
        fragment="the robot description does not exist",
    ),
    Case(
        "robot description not YAML",
        ("task=identification", "tracking=none", "robot=mdh_file", "robot.path={tmp}/arm.yaml"),
        error=ConfigError,
        fragment="not valid YAML",
        files=(("arm.yaml", "mdh: [1, 2"),),
    ),
    Case(
        "identified model missing",
        (
            "task=identification",
            "tracking=none",
            "robot=identified",
            "robot.source={tmp}/identified_model.yaml",
        ),
        error=MissingFileError,
        fragment="identified_model.yaml does not exist",
    ),
    Case(
        "exciting-motion file missing",
        ("task=identification", "tracking=none", "trajectory.from_file={tmp}/motion.yaml"),
        error=MissingFileError,
        fragment="motion.yaml not found",
    ),
    # logs and the robot they belong to
    Case(
        "log of a robot with more joints",
        LOG,
        _more_joints,
        error=LogError,
        fragment="columns ['q8', 'tau8'] beyond the robot's 7 joints",
    ),
    Case(
        "column map from a name outside the schema",
        (*LOG, "data.column_map={time: stamp}"),
        _frame,
        error=ConfigError,
        fragment="data.column_map={'time': 'stamp'}",
    ),
    Case(
        "payload truth not in the library",
        (
            "task=payload",
            "plant=log",
            "tracking=none",
            "task.unloaded_paths=[{tmp}/log.csv]",
            "task.loaded_paths=[{tmp}/log.csv]",
            "task.truth=roller",
        ),
        _frame,
        error=UnknownNameError,
        fragment="no tool named 'roller'",
    ),
]
"""A user's mistakes that ended in a traceback before: each is now one line."""


def _run_case(case: Case, clean: Measurement, tmp_path: Path) -> None:
    for name, text in case.files:
        (tmp_path / name).write_text(text)
    overrides = [o.replace("{tmp}", str(tmp_path)) for o in case.overrides]
    if case.log is not None:
        path = tmp_path / f"log{case.suffix}"
        frame = case.log(clean)
        if case.suffix == ".parquet":
            frame.to_parquet(path, index=False)
        else:
            frame.to_csv(path, index=False, float_format="%.17g")
        overrides.append(f"data.path={path}")
    cfg = compose_config(*overrides)
    run(cfg, tmp_path / "run")


def _printed(error: BaseException) -> str:
    """What lwrlab prints for ``error``: its message, and for Hydra's composition errors their cause."""
    cause = error.__cause__ if isinstance(error, CompactHydraException) else None
    return f"{error}\n{cause}" if cause is not None else str(error)


@pytest.mark.parametrize("case", CASES + MISTAKES, ids=[c.name for c in CASES + MISTAKES])
def test_bad_input_is_never_a_silent_result(
    case: Case, clean: Measurement, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    if case.error is None:
        _run_case(case, clean, tmp_path)
        assert case.fragment in capsys.readouterr().out
        return
    with pytest.raises(Exception) as raised:
        _run_case(case, clean, tmp_path)
    # what lwrlab prints: the user error behind Hydra's wrapping of a plugin's, or the error itself
    error = _user_error(raised.value) or raised.value
    assert isinstance(error, case.error), repr(raised.value)
    assert case.fragment in _printed(error)
    if case.error is LogError and case.log is not None:
        assert str(tmp_path / f"log{case.suffix}") in str(error)  # the file is named
    # printed without a traceback: lwrlab's one line, or Hydra's composition error naming the key
    assert isinstance(error, UserError | CompactHydraException)


def test_a_rank_deficient_fit_fails_naming_what_the_data_cannot_determine(
    lwr4, clean: Measurement, tmp_path: Path
) -> None:
    frame = _still_joint_5(clean)
    frame["q5"] = 0.0
    frame["q6"] = 0.0  # two joints still: structurally unidentifiable columns, noiseless positions
    path = tmp_path / "still.csv"
    frame.to_csv(path, index=False, float_format="%.17g")
    settings = (*LOG, f"data.path={path}", "robot.friction_terms=[coulomb,viscous]")
    # without a prior: an error naming what the data cannot determine and the way out
    with pytest.raises(IdentifiabilityError, match="rank") as error:
        run(compose_config(*settings, "estimator=ols"), tmp_path / "ols")
    assert "FC5" in str(error.value) and "estimator=sdp" in str(error.value)
    # the default for logs leans on the prior there, and says so, parameter by parameter
    summary_run = tmp_path / "sdp"
    run(compose_config(*settings), summary_run)
    summary = (summary_run / "summary.md").read_text()
    assert "rank" in summary and "FC5" in summary
    assert "come mostly from the prior" in summary


@functools.cache
def _lwrlab_failing(overrides: tuple[str, ...], run_dir: Path) -> subprocess.CompletedProcess[str]:
    """``lwrlab`` run once per set of overrides (two fragments of one message share the run)."""
    environment = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"}
    return subprocess.run(
        [sys.executable, "-m", "lwrlab.cli", f"hydra.run.dir={run_dir}", "tracking=none", *overrides],
        cwd=REPOSITORY,
        env=environment,
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.fixture(scope="module")
def failing_run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("failing_run")


@pytest.mark.parametrize(
    "overrides, fragment",
    [
        (("task=identification", "seed=-1"), "lwrlab: invalid settings:\n  seed=-1: must be an integer ≥ 0"),
        (("task=identification", "plant=log"), "data.paths"),
        # a plugin's user error (raised inside Hydra's instantiate): lwrlab's one line too
        (
            ("task=identification", "robot=urdf", "robot.path=/no/such.urdf"),
            "lwrlab: robot.path=/no/such.urdf: the URDF file does not exist",
        ),
        # compose-time failures: Hydra's short message (override, value, key), no traceback
        (("task=identification", "seed=abc"), "Value 'abc' of type 'str' could not be converted to Integer"),
        (("task=identification", "seed=abc"), "full_key: seed\n"),
        (
            ("task=identification", "measurement.processing.order=2.5"),
            "full_key: measurement.processing.order",
        ),
        (
            ("task=identification", "plant.torque_noise_stdd=0.1"),
            "Key 'torque_noise_stdd' not in 'SimulatedPlantSettings'",
        ),
        (
            ("task=identification", "plant.torque_noise_std=-1"),
            "plant.torque_noise_std=-1: must be a number ≥ 0",
        ),
    ],
)
def test_lwrlab_prints_a_clear_message_and_exits_non_zero(
    failing_run_dir: Path, overrides: tuple[str, ...], fragment: str
) -> None:
    completed = _lwrlab_failing(overrides, failing_run_dir / re.sub(r"\W", "_", "_".join(overrides)))
    assert completed.returncode == 1
    assert fragment in completed.stderr
    assert "Traceback" not in completed.stderr
    assert len(completed.stderr.strip().splitlines()) <= 8, completed.stderr  # a message, not a dump


def test_the_suite_covers_the_reported_cases() -> None:
    """The README states how many bad inputs are tried: keep the count honest."""
    assert len(CASES) == 31 and len(MISTAKES) == 17
