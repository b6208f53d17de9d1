"""Helpers for the tracking, sweep, report and server tests: run a Hydra app as a user would.

The apps (tests/apps/) include the repository's own ``conf/`` through ``hydra.searchpath``
(``pkg://lwrlab.conf``, as an installed lwrlab is found), so the shipped tracking, launcher and sweeper
configs are what is exercised.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest
from hydra.conf import HydraConf
from mlflow.entities import Run
from mlflow.tracking import MlflowClient
from omegaconf import DictConfig, OmegaConf

REPO_ROOT = Path(__file__).resolve().parents[1]
REPO_CONF = REPO_ROOT / "conf"
TOY_APP = REPO_ROOT / "tests" / "apps" / "toy_app.py"
TABLE_FIXTURES_APP = REPO_ROOT / "tests" / "apps" / "table_fixtures_app.py"
HOLD_RELEASE_FILE = "release"
"""The file that lets the toy app's held jobs go on (``RELEASE_FILE`` in tests/apps/toy_app.py)."""


def app_command(app: Path | None, overrides: Sequence[str], store: Path | None, multirun: bool) -> list[str]:
    """The command line that runs ``app`` (``None``: ``lwrlab``), tracking into ``store``/mlflow.db."""
    command = [sys.executable, *(["-m", "lwrlab.cli"] if app is None else [str(app)])]
    command += ["-m"] if multirun else []
    if app is not None:
        # The shipped tree: importing it registers its schemas.
        command.append("hydra.searchpath=[pkg://lwrlab.conf]")
    if store is not None:
        command += [
            f"tracking.uri=sqlite:///{store / 'mlflow.db'}",
            f"tracking.artifact_location={store / 'artifacts'}",
        ]
    return command + list(overrides)


def app_environment(env: dict[str, str] | None) -> dict[str, str]:
    """This environment, the repository importable, no tracking URI of the user's, plus ``env``."""
    environment = dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(REPO_ROOT), os.environ.get("PYTHONPATH", "")])
    )
    environment.pop("MLFLOW_TRACKING_URI", None)
    environment.update(env or {})
    return environment


def run_app(
    app: Path | None,
    *overrides: str,
    store: Path | None = None,
    multirun: bool = False,
    cwd: Path = REPO_ROOT,
    env: dict[str, str] | None = None,
    timeout: float = 300,
) -> subprocess.CompletedProcess[str]:
    """Run ``app`` (``None``: ``lwrlab``) in a subprocess until it ends, tracking into ``store``/mlflow.db."""
    return subprocess.run(
        app_command(app, overrides, store, multirun),
        cwd=cwd,
        env=app_environment(env),
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def start_app(
    app: Path | None, *overrides: str, store: Path, multirun: bool = False, env: dict[str, str] | None = None
) -> subprocess.Popen[str]:
    """Start ``app`` in ``store`` in its own session (a signal to the group reaches it all), output merged."""
    return subprocess.Popen(
        app_command(app, overrides, store, multirun),
        cwd=store,
        env=app_environment(env),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )


def wait_for_files(
    folder: Path, pattern: str, count: int, process: subprocess.Popen[str], timeout: float = 120
) -> list[Path]:
    """Wait until ``count`` files under ``folder`` match ``pattern``; fail if ``process`` ends first."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = sorted(folder.rglob(pattern))
        if len(found) >= count:
            return found
        if process.poll() is not None:
            pytest.fail(f"the process ended before {count} {pattern}:\n{process.communicate()[0][-4000:]}")
        time.sleep(0.2)
    process.kill()
    pytest.fail(f"fewer than {count} {pattern} under {folder} in {timeout} s")


@dataclass(frozen=True)
class HeldJob:
    """A toy job waiting in ``TOY_HOLD_DIR`` for its release (see tests/apps/toy_app.py)."""

    pid: int
    overrides: str


def wait_for_held_jobs(
    folder: Path, count: int, process: subprocess.Popen[str], timeout: float = 120
) -> list[HeldJob]:
    """Wait until ``count`` toy jobs hold in ``folder`` (each job announces itself there once)."""
    announcements = wait_for_files(folder, "started-*", count, process, timeout)
    return [HeldJob(int(path.name.split("-")[1]), path.read_text(encoding="utf-8")) for path in announcements]


def release_held_jobs(folder: Path) -> None:
    """Let every toy job holding in ``folder`` go on, and any that starts later not wait."""
    (folder / HOLD_RELEASE_FILE).touch()


def new_store(database: Path) -> str:
    """The tracking URI of a new SQLite store at ``database``, made as ``lwrlab`` makes one.

    Its schema is lwrlab's copy of MLflow's migrated empty store (lwrlab.tracking.store.schema_template)
    rather than the sixty migrations a bare ``MlflowClient`` replays on a new file (~2 s each time);
    without a template (a read-only cache folder), MLflow migrates it when it is first opened.
    """
    from lwrlab.tracking.store.schema_template import copy_schema_template

    copy_schema_template(database)
    return f"sqlite:///{database}"


def runs_of(tracking_uri: str, experiment: str) -> list[Run]:
    """All runs of an experiment, oldest first."""
    client = MlflowClient(tracking_uri=tracking_uri)
    found = client.get_experiment_by_name(experiment)
    assert found is not None, f"experiment {experiment!r} was not created"
    return list(
        client.search_runs([found.experiment_id], order_by=["attributes.start_time ASC"], max_results=5000)
    )


def jobs_and_parents(runs: list[Run]) -> tuple[list[Run], list[Run]]:
    """Split runs into job runs and sweep (parent) runs."""
    return (
        [run for run in runs if run.data.tags.get("run_kind") == "job"],
        [run for run in runs if run.data.tags.get("run_kind") == "sweep"],
    )


def all_logged_text(tracking_uri: str, run: Run, download_dir: Path) -> str:
    """Params, tags, run name and every artifact of ``run``, as one text (to look for leaks)."""
    import mlflow

    parts = [
        run.info.run_name or "",
        *run.data.params.keys(),
        *run.data.params.values(),
        *run.data.tags.values(),
    ]
    local = Path(
        mlflow.artifacts.download_artifacts(
            run_id=run.info.run_id, dst_path=str(download_dir), tracking_uri=tracking_uri
        )
    )
    for path in local.rglob("*"):
        if path.is_file():
            parts.append(path.read_bytes().decode("utf-8", errors="replace"))
    return "\n".join(parts)


def unit_job_config(tmp_path: Path, callback_node: dict[str, object]) -> DictConfig:
    """The parts of a single run's Hydra job config the tracking callback reads (its output: tmp_path/job).

    The ``hydra`` node has Hydra's own type, as in a composed config (the companion sets it as the
    job's ``HydraConfig``, which checks that).
    """
    config = OmegaConf.create({"experiment_name": "swept_name", "seed": 3})
    config.hydra = OmegaConf.merge(
        OmegaConf.structured(HydraConf),
        {
            "callbacks": {"mlflow": callback_node},
            "runtime": {"cwd": str(tmp_path), "output_dir": str(tmp_path / "job")},
            "job": {"name": "unit", "override_dirname": "", "num": 0},
            "overrides": {"task": []},
            "mode": "RUN",
        },
    )
    return config
