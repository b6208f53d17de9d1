"""A real `mlflow server` on 127.0.0.1 (SQLite backend, proxied artifacts): a sweep through it, read back.

Marked slow: the server takes seconds to start. The server URI carries a password (basic-auth style
user info, ignored by a server without auth) that must reach no param, tag or artifact.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
from tracking_apps import TOY_APP, all_logged_text, jobs_and_parents, run_app, runs_of

from lwrlab.tracking.reports.report import build_report
from lwrlab.tracking.reports.run_selection import selection_filter

pytestmark = pytest.mark.slow
STARTUP_TIMEOUT_S = 120


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """``mlflow server`` bound to 127.0.0.1 on a free port; yields its URL, stops it afterwards."""
    folder = tmp_path_factory.mktemp("server")
    port = _free_port()
    command = [
        sys.executable,
        "-m",
        "mlflow",
        "server",
        "--host",
        "127.0.0.1",
        "--port",
        str(port),
        "--workers",
        "1",
        "--backend-store-uri",
        f"sqlite:///{folder / 'server.db'}",
        "--artifacts-destination",
        str(folder / "artifacts"),
    ]
    log = (folder / "server.log").open("w")
    process = subprocess.Popen(
        command, cwd=folder, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
    )
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    try:
        while True:
            try:
                with urllib.request.urlopen(url + "/health", timeout=2):
                    break
            except OSError:
                if process.poll() is not None or time.monotonic() > deadline:
                    pytest.fail(
                        f"mlflow server did not start:\n{(folder / 'server.log').read_text()[-3000:]}"
                    )
                time.sleep(0.5)
        yield url
    finally:
        os.killpg(process.pid, 15)  # the server and its workers, started in their own session
        process.wait(timeout=30)
        log.close()


def test_sweep_through_a_tracking_server_is_read_back_and_reported(server: str, tmp_path: Path) -> None:
    uri_with_password = server.replace("http://", "http://team:secret@")
    finished = run_app(
        TOY_APP,
        "tracking=server",
        f"tracking.uri={uri_with_password}",
        "experiment_name=through_server",
        f"hydra.sweep.dir={tmp_path / 'sweep'}",
        "x=1,2,3",
        multirun=True,
    )
    assert finished.returncode == 0, finished.stderr
    assert "MLflow tracking failed" not in finished.stdout + finished.stderr
    runs = runs_of(server, "through_server")
    jobs, parents = jobs_and_parents(runs)
    assert len(parents) == 1 and len(jobs) == 3
    assert sorted(run.data.metrics["doubled"] for run in jobs) == [2.0, 4.0, 6.0]
    for index, run in enumerate(jobs):
        logged = all_logged_text(server, run, tmp_path / f"download{index}")
        assert "table.csv" in logged or (tmp_path / f"download{index}" / "table.csv").exists()
        assert "secret" not in logged

    report = build_report(server, tmp_path / "report", ["through_server"], selection_filter())
    assert len(report.runs) == 3 and "fig6" in report.skipped  # toy runs carry no paper tables
