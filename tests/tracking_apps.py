"""Helpers for the tracking, sweep, report and server tests: run a Hydra app as a user would.

The apps (tests/apps/) include the repository's own ``conf/`` through ``hydra.searchpath``, so the
shipped tracking, launcher and sweeper configs are what is exercised.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from mlflow.entities import Run
from mlflow.tracking import MlflowClient

REPO_ROOT = Path(__file__).resolve().parents[1]
REPO_CONF = REPO_ROOT / "conf"
TOY_APP = REPO_ROOT / "tests" / "apps" / "toy_app.py"
TABLE_FIXTURES_APP = REPO_ROOT / "tests" / "apps" / "table_fixtures_app.py"


def run_app(
    app: Path | None,
    *overrides: str,
    store: Path | None = None,
    multirun: bool = False,
    cwd: Path = REPO_ROOT,
    env: dict[str, str] | None = None,
    timeout: float = 300,
) -> subprocess.CompletedProcess[str]:
    """Run ``app`` (``None``: the ``lwrlab`` entry point) in a subprocess, tracking into ``store``/mlflow.db."""
    command = [sys.executable, *(["-m", "lwrlab.cli"] if app is None else [str(app)])]
    command += ["-m"] if multirun else []
    if app is not None:
        command.append(f"hydra.searchpath=[file://{REPO_CONF}]")
    if store is not None:
        command += [
            f"tracking.uri=sqlite:///{store / 'mlflow.db'}",
            f"tracking.artifact_location={store / 'artifacts'}",
        ]
    command += list(overrides)
    environment = dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(REPO_ROOT), os.environ.get("PYTHONPATH", "")])
    )
    environment.pop("MLFLOW_TRACKING_URI", None)
    environment.update(env or {})
    return subprocess.run(command, cwd=cwd, env=environment, capture_output=True, text=True, timeout=timeout)


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
