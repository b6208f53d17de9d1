"""The command line's own flags: ``--version`` and Hydra's ``--info`` views of the config tree; a
user's error as one ``lwrlab:`` line, its traceback with ``HYDRA_FULL_ERROR=1``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import lwrlab


def _lwrlab(*arguments: str, full_error: bool = False) -> subprocess.CompletedProcess[str]:
    environment = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"}
    if full_error:
        environment["HYDRA_FULL_ERROR"] = "1"
    return subprocess.run(
        [sys.executable, "-m", "lwrlab.cli", *arguments],
        capture_output=True,
        text=True,
        check=False,
        env=environment,
    )


def test_version_names_lwrlab_and_the_libraries_a_bug_report_needs() -> None:
    shown = _lwrlab("--version")
    assert shown.returncode == 0, shown.stderr[-2000:]
    assert shown.stdout.startswith(f"lwrlab {lwrlab.__version__} (Python ")
    assert all(f"{name} " in shown.stdout for name in ("hydra-core", "pin", "mlflow", "mujoco"))


@pytest.mark.parametrize("info", ["defaults", "defaults-tree"])
def test_hydra_lists_the_defaults_of_the_command_line(info: str) -> None:
    """``--info defaults`` finds the schemas the YAML files link (registered before Hydra starts)."""
    shown = _lwrlab("task=identification", "--info", info)
    assert shown.returncode == 0, shown.stderr[-2000:]
    assert "schema/root/config" in shown.stdout and "task/identification" in shown.stdout


def test_a_users_error_is_one_line_and_its_traceback_is_one_setting_away(tmp_path: Path) -> None:
    """No "Error executing job…" nor "Set the environment variable HYDRA_FULL_ERROR=1…" around it."""
    no_log = f"data.path={tmp_path / 'no.csv'}"
    command = (f"hydra.run.dir={tmp_path}", "tracking=none", "task=identification", "plant=log", no_log)
    shown = _lwrlab(*command)
    assert shown.returncode == 1
    assert shown.stderr.strip().splitlines() == [f"lwrlab: {tmp_path / 'no.csv'}: no such log file"]
    full = _lwrlab(*command, full_error=True)
    assert full.returncode == 1 and "Traceback (most recent call last)" in full.stderr
