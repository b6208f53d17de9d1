"""`lwrlab compare` says where its runs are in MLflow's model-training view (MLflow 3.17 opens on GenAI).

The server URL must have the form the README documents; a local store gets the `mlflow ui` command and
the same path; the link `lwrlab compare` prints opens the view it saved on the experiment. The command
is checked end to end on a real SQLite store with finished job runs.
"""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pytest
from mlflow.tracking import MlflowClient
from tracking_apps import new_store

from lwrlab.tracking.reports.compare import MLFLOW_UI_ADDRESS, main, runs_view_hint
from lwrlab.tracking.runs.runs_view import mlflow_executable, share_key, view_name

README = Path(__file__).resolve().parents[1] / "README.md"


def test_a_server_gets_the_runs_url_the_readme_documents_without_its_password() -> None:
    documented = re.search(r"`(http://127\.0\.0\.1:5000/#/experiments/<id>/runs\?[^`]+)`", README.read_text())
    assert documented is not None, "README no longer documents the runs URL"
    assert runs_view_hint("http://127.0.0.1:5000", "<id>") == f"MLflow UI: {documented.group(1)}"
    hint = runs_view_hint("https://user:secret@mlflow.lab:8443/", "7")
    assert hint == "MLflow UI: https://mlflow.lab:8443/#/experiments/7/runs?workflowType=machine_learning"


def test_a_local_store_gets_the_mlflow_ui_command_and_the_path() -> None:
    hint = runs_view_hint("sqlite:////lab/my outputs/mlflow.db", "4")
    assert hint is not None
    command, url = hint.removeprefix("MLflow UI: ").split(", then open ")
    assert shlex.split(command) == [
        mlflow_executable(),  # beside the running Python: nothing need be on PATH
        "ui",
        "--backend-store-uri",
        "sqlite:////lab/my outputs/mlflow.db",
    ]
    assert url == f"{MLFLOW_UI_ADDRESS}/#/experiments/4/runs?workflowType=machine_learning"
    assert "--backend-store-uri /lab/mlruns," in str(runs_view_hint("/lab/mlruns", "0"))  # a file store
    assert runs_view_hint("postgresql://user:secret@db/mlflow", "4") is None  # not local, not a UI server


def test_compare_prints_the_hint_after_its_table_with_the_experiment_id(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    client = MlflowClient(tracking_uri=new_store(tmp_path / "store" / "mlflow.db"))
    client.create_experiment("other")  # so that the compared experiment's id is not the first one
    experiment_id = client.create_experiment("ui_link")
    for seed in (0, 1):
        run = client.create_run(experiment_id, tags={"run_kind": "job", "seed": str(seed)})
        client.log_param(run.info.run_id, "seed", str(seed))
        client.log_metric(run.info.run_id, "rms_mean", 0.1 + seed)
        client.set_terminated(run.info.run_id, "FINISHED")

    relative_store = "sqlite:///store/mlflow.db"  # made absolute before it is printed
    assert main(["--tracking-uri", relative_store, "--experiment", "ui_link", "--no-log"]) == 0
    printed = capsys.readouterr().out
    table_end = printed.index("rms_mean [N·m]")
    hint = next(line for line in printed.splitlines() if line.startswith("MLflow UI: "))
    assert printed.index(hint) > table_end
    store = f"sqlite:///{(tmp_path / 'store' / 'mlflow.db').resolve()}"
    key = share_key(view_name([]))  # the runs differ in the seed only: grouped by run kind
    assert hint == (
        f"MLflow UI: {mlflow_executable()} ui --backend-store-uri {store}, then open {MLFLOW_UI_ADDRESS}"
        f"/#/experiments/{experiment_id}/runs?viewStateShareKey={key}&workflowType=machine_learning"
    )


def test_compare_links_the_port_given_and_logs_its_table_as_metrics_and_a_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    uri = new_store(tmp_path / "mlflow.db")
    client = MlflowClient(tracking_uri=uri)
    experiment_id = client.create_experiment("ui_port", str(tmp_path / "artifacts"))
    for estimator, rms in (("ols", 0.2), ("wls", 0.1)):
        run = client.create_run(experiment_id, tags={"run_kind": "job"})
        client.log_param(run.info.run_id, "estimator", estimator)
        client.log_metric(run.info.run_id, "accuracy/rms_mean", rms)  # as a job logs it
        client.set_terminated(run.info.run_id, "FINISHED")
    assert main(["--tracking-uri", uri, "--experiment", "ui_port", "--ui-port", "5123"]) == 0
    printed = capsys.readouterr().out
    hint = next(line for line in printed.splitlines() if line.startswith("MLflow UI: "))
    assert "--port 5123, then open http://127.0.0.1:5123/#/experiments/" in hint
    (compared,) = client.search_runs([experiment_id], "tags.run_kind = 'compare'")
    assert compared.data.metrics == {
        "estimator:ols/runs": 1.0,
        "estimator:ols/rms_mean": 0.2,
        "estimator:wls/runs": 1.0,
        "estimator:wls/rms_mean": 0.1,
    }
    artifacts = {item.path for item in client.list_artifacts(compared.info.run_id)}
    assert {"compare_table.json", "compare.html", "compare.md"} <= artifacts
    table = json.loads(
        Path(client.download_artifacts(compared.info.run_id, "compare_table.json", str(tmp_path))).read_text()
    )
    groups = [row[table["columns"].index("group")] for row in table["data"]]  # MLflow's table layout
    assert sorted(groups) == ["estimator=ols", "estimator=wls"] and "rms_mean" in table["columns"]
    logged = json.loads(compared.data.tags["mlflow.loggedArtifacts"])  # what makes the UI show it as a table
    assert {"path": "compare_table.json", "type": "table"} in logged
