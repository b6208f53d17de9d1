"""The command line's own flags: ``--version`` and Hydra's ``--info`` views of the config tree."""

from __future__ import annotations

import subprocess
import sys

import pytest

import lwrlab


def _lwrlab(*arguments: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "lwrlab.cli", *arguments], capture_output=True, text=True, check=False
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
