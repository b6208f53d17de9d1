"""Identified models as MLflow Models, the Model Registry, and tasks reading a model by its MLflow URI.

One short identification (``lwrlab`` in a subprocess, a friction law with memory, a temporary SQLite
store, registered under :data:`NAME`) serves every test: its pyfunc model, loaded in a plain Python
process, predicts ``predicted_torque.parquet``; its version carries the headline metrics and the
datasets; ``lwrlab model alias`` names it ``champion``; ``task=monitor`` reads it as
``models:/<name>@champion`` and records the lineage; a URI that names nothing is one line.

A payload run (noiseless simulated logs read through ``plant=log``) logs its payload as a model too,
registered as ``<robot>_payload``: loaded in a plain process, it predicts the torques the payload
adds, as Pinocchio's inverse dynamics of the robot with and without it.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pinocchio as pin
import pytest
import yaml
from mlflow.tracking import MlflowClient
from tracking_apps import app_environment, run_app

from lwrlab.identification.log_predictions import process_measurement
from lwrlab.io.logs import write_log
from lwrlab.io.payload_model import payload_parameters
from lwrlab.model.payload import attach_payload
from lwrlab.plants.core import Measurement
from lwrlab.tracking.models import registry
from lwrlab.tracking.models.resolve import ModelNotFoundError, resolve_model

NAME = "lab_arm"
"""The registered model the identification registers its model under (``tracking.register_model``)."""
JOINTS = 7


@dataclass(frozen=True)
class Identified:
    """The identification run every test reads."""

    folder: Path
    """The store's folder (``mlflow.db``, ``artifacts/``) and the job folders."""
    run: Path
    """The identification's output folder."""
    run_id: str

    @property
    def uri(self) -> str:
        return f"sqlite:///{self.folder / 'mlflow.db'}"

    @property
    def client(self) -> MlflowClient:
        return MlflowClient(tracking_uri=self.uri)


SHORT_IDENTIFICATION = (
    "task=identification",
    "trajectory=multisine",
    "trajectory.duration=2",
    "validation.duration=2",
    "plant.show_progress=false",
)
"""A 2 s identification of the simulated LWR4, validated on 2 s."""


@pytest.fixture(scope="module")
def identified(tmp_path_factory: pytest.TempPathFactory) -> Identified:
    folder = tmp_path_factory.mktemp("registry")
    done = run_app(
        None,
        *SHORT_IDENTIFICATION,
        "friction=holding",  # a law with memory: the pyfunc model treats the rows as one motion
        f"tracking.register_model={NAME}",
        f"hydra.run.dir={folder / 'identified'}",
        store=folder,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    run = folder / "identified"
    return Identified(folder, run, (run / "mlflow_run_id.txt").read_text().strip())


def _lwrlab(identified: Identified, *arguments: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "lwrlab.cli", *arguments],
        cwd=identified.folder,
        env=app_environment(None),
        capture_output=True,
        text=True,
        timeout=300,
    )


def _states(run: Path) -> pd.DataFrame:
    """Every log's states as its prediction evaluated them (processed as the run's config says)."""
    processing = yaml.safe_load((run / ".hydra" / "config.yaml").read_text())["measurement"]["processing"]
    frames = []
    for file in ("measurement.npz", "validation_measurement.npz"):
        with np.load(run / file, allow_pickle=False) as stored:
            name = yaml.safe_load(str(stored["metadata"]))["name"]
            measurement = Measurement(t=stored["t"], q=stored["q"], tau=stored["tau"])
        blocks = list(process_measurement(measurement, processing, every_sample=True).state_blocks())
        columns: dict[str, object] = {"log": name, "t": np.concatenate([b.t for b in blocks])}
        for prefix in ("q", "dq", "ddq"):
            values = np.concatenate([getattr(b, prefix) for b in blocks])
            columns.update({f"{prefix}{j}": values[:, j - 1] for j in range(1, JOINTS + 1)})
        frames.append(pd.DataFrame(columns))
    return pd.concat(frames, ignore_index=True)


PREDICT = """
import sys
import mlflow
import pandas as pd
from hydra.core.global_hydra import GlobalHydra

uri, run_id, states, out = sys.argv[1:]
model = mlflow.pyfunc.load_model(f"runs:/{run_id}/model")
frame = pd.read_parquet(states)
# one motion per call: the friction law's memory runs over a whole log's consecutive samples
parts = [model.predict(rows.drop(columns="log")).assign(log=name) for name, rows in frame.groupby("log")]
pd.concat(parts).to_parquet(out)
assert not GlobalHydra.instance().is_initialized(), "no Hydra app, no config"
"""


def _check_plain_process_predictions(uri: str, run_id: str, run: Path, folder: Path) -> None:
    """``runs:/<run_id>/model`` loaded in a plain Python process predicts ``run``'s
    ``predicted_torque.parquet`` to 1e-9 N·m at every state of its logs."""
    states = _states(run)
    states.to_parquet(folder / "states.parquet")
    done = subprocess.run(
        [sys.executable, "-c", PREDICT, uri, run_id, str(folder / "states.parquet")]
        + [str(folder / "predicted.parquet")],
        cwd=folder,
        env=app_environment({"MLFLOW_TRACKING_URI": uri}),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    predicted = pd.read_parquet(folder / "predicted.parquet")
    assert list(predicted.columns[:JOINTS]) == [f"tau{j}" for j in range(1, JOINTS + 1)]
    predicted = pd.concat([states[["log", "t"]], predicted.drop(columns="log")], axis=1)
    logged = pd.read_parquet(run / "predicted_torque.parquet")
    rows = logged.merge(predicted, on=["log", "t"], how="left", validate="one_to_one")
    assert set(rows["log"]) == {"exciting_motion", "validation_motion"} and len(rows) > 3000
    expected = rows[[f"tau_hat{j}" for j in range(1, JOINTS + 1)]].to_numpy()
    got = rows[[f"tau{j}_y" for j in range(1, JOINTS + 1)]].to_numpy()
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)


def test_the_pyfunc_model_predicts_the_runs_torques_in_a_plain_process(
    identified: Identified, tmp_path: Path
) -> None:
    _check_plain_process_predictions(identified.uri, identified.run_id, identified.run, tmp_path)
    # the model logged with the run: signature, example, artifacts, pinned requirements
    model = identified.client.get_run(identified.run_id).outputs.model_outputs[0].model_id
    logged_model = identified.client.get_logged_model(model)
    assert logged_model.name == "model" and logged_model.source_run_id == identified.run_id
    files = {Path(f.path).name for f in identified.client.list_logged_model_artifacts(model)}
    assert {"MLmodel", "input_example.json", "requirements.txt"} <= files


@pytest.mark.slow
def test_a_run_kept_offline_gets_its_model_and_its_version_when_synced(tmp_path: Path) -> None:
    """The store unreachable during the identification (a PostgreSQL port nothing listens on): the
    job keeps its run on disk; ``lwrlab sync`` uploads it with its MLflow Model, registered as the
    job's ``tracking.register_model`` asked, and the model predicts the run's torques."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        closed = probe.getsockname()[1]
    job = tmp_path / "offline"
    done = run_app(
        None,
        *SHORT_IDENTIFICATION,
        f"tracking.register_model={NAME}_offline",
        f"tracking.uri=postgresql://user:secret@127.0.0.1:{closed}/db",
        f"hydra.run.dir={job}",
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert (job / "mlflow_offline_run.json").is_file()
    store = tmp_path / "store"
    uri = f"sqlite:///{store / 'mlflow.db'}"
    synced = run_app(None, "sync", str(job), "--tracking-uri", uri, cwd=tmp_path)
    assert synced.returncode == 0, synced.stderr[-3000:]
    assert "failed (" not in synced.stderr, synced.stderr[-3000:]
    run_id = (job / "mlflow_run_id.txt").read_text().strip()
    (version,) = MlflowClient(tracking_uri=uri).search_model_versions(f"name='{NAME}_offline'")
    assert version.run_id == run_id and str(version.version) == "1"
    _check_plain_process_predictions(uri, run_id, job, tmp_path)


def test_the_registered_version_carries_the_headline_metrics_and_the_datasets(identified: Identified) -> None:
    client = identified.client
    run = client.get_run(identified.run_id)
    (version,) = client.search_model_versions(f"name = '{NAME}'")
    assert str(version.version) == "1" and version.run_id == identified.run_id
    assert version.source == f"models:/{run.outputs.model_outputs[0].model_id}"
    rms = run.data.metrics["accuracy/rms_mean"]
    assert float(version.tags["accuracy/rms_mean"]) == pytest.approx(rms, rel=1e-5)
    assert "accuracy/validation_rel_error" in version.tags and "joints/rms_joint1" not in version.tags
    digests = {(i.dataset.name, i.dataset.digest) for i in run.inputs.dataset_inputs}
    assert version.tags["datasets.identification"] == "multisine_motion@" + dict(digests)["multisine_motion"]
    assert version.tags["datasets.validation"].startswith("multisine_validation_motion@")
    assert version.tags["robot"] == "kuka_lwr4"
    assert identified.run_id in version.description and "rms_mean" in version.description


def test_lwrlab_model_alias_points_an_alias_at_a_version(
    identified: Identified, capsys: pytest.CaptureFixture[str]
) -> None:
    store = ["--tracking-uri", identified.uri]
    done = _lwrlab(identified, "model", "alias", NAME, "1", "champion", *store)
    assert done.returncode == 0, done.stderr
    assert f"models:/{NAME}@champion" in done.stdout
    assert str(identified.client.get_model_version_by_alias(NAME, "champion").version) == "1"
    capsys.readouterr()
    assert registry.main(["list", NAME, *store]) == 0
    listed = capsys.readouterr().out
    assert "@champion" in listed and identified.run_id in listed and "rms_mean=" in listed
    with pytest.raises(SystemExit) as missing:  # argparse's one-line error, status 2
        registry.main(["alias", NAME, "9", "staging", *store])
    assert missing.value.code == 2 and "version=9" in capsys.readouterr().err


def test_monitor_reads_the_champion_by_its_uri_and_records_the_lineage(identified: Identified) -> None:
    identified.client.set_registered_model_alias(NAME, "champion", "1")
    with np.load(identified.run / "validation_measurement.npz", allow_pickle=False) as stored:
        log = write_log(
            Measurement(t=stored["t"], q=stored["q"], tau=stored["tau"]), identified.folder / "free.parquet"
        )
    done = run_app(
        None,
        "task=monitor",
        "plant=log",
        f"data.paths=[{log}]",
        f"task.model=models:/{NAME}@champion",
        f"hydra.run.dir={identified.folder / 'monitor'}",
        store=identified.folder,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    monitor = identified.folder / "monitor"
    # thresholds calibrated on the model's run's own measurements, fetched from its artifacts
    assert f"MLflow run {identified.run_id}" in (monitor / "summary.md").read_text()
    run = identified.client.get_run((monitor / "mlflow_run_id.txt").read_text().strip())
    assert run.info.status == "FINISHED"
    tags = run.data.tags
    assert tags["lwrlab.model_uri"] == f"models:/{NAME}@champion"
    assert tags["lwrlab.model_run_id"] == identified.run_id
    assert (tags["lwrlab.model_name"], tags["lwrlab.model_version"]) == (NAME, "1")
    model_id = identified.client.get_run(identified.run_id).outputs.model_outputs[0].model_id
    assert [i.model_id for i in run.inputs.model_inputs] == [model_id] == [tags["lwrlab.model_id"]]
    assert json.loads((monitor / "model_inputs.json").read_text())[0]["version"] == "1"


def test_a_uri_that_names_nothing_is_one_line_and_a_failed_run(identified: Identified) -> None:
    done = run_app(
        None,
        "task=identification",
        "robot=identified",
        f"robot.source=models:/{NAME}@no_such_alias",
        f"hydra.run.dir={identified.folder / 'bad'}",
        store=identified.folder,
        env={"HYDRA_FULL_ERROR": "0"},
    )
    assert done.returncode == 1
    lines = [line for line in done.stderr.splitlines() if line.startswith("lwrlab: ")]
    assert lines == [lines[0]] and lines[0].startswith(f"lwrlab: robot.source=models:/{NAME}@no_such_alias: ")
    assert "no_such_alias" in lines[0] and "Traceback" not in done.stderr
    run = identified.client.get_run((identified.folder / "bad" / "mlflow_run_id.txt").read_text().strip())
    assert run.info.status == "FAILED" and f"models:/{NAME}@no_such_alias" in run.data.tags["error"]


def test_a_run_id_is_found_where_mlflow_tracking_uri_names_the_store(
    identified: Identified, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Only ``MLFLOW_TRACKING_URI`` names the store (``tracking=none``): ``task=monitor task.model=<run
    id>`` looks the model up, then its run's logs, both in that store; the variable stays set."""
    from composing import compose_config
    from hydra.utils import instantiate

    monkeypatch.setenv("MLFLOW_TRACKING_URI", identified.uri)
    monkeypatch.chdir(tmp_path)  # no store of MLflow's default here
    with np.load(identified.run / "validation_measurement.npz", allow_pickle=False) as stored:
        log = write_log(Measurement(t=stored["t"], q=stored["q"], tau=stored["tau"]), tmp_path / "free.csv")
    resolved = resolve_model(identified.run_id)
    assert resolved.run_id == identified.run_id and resolved.run_file(".hydra/config.yaml") is not None
    assert os.environ["MLFLOW_TRACKING_URI"] == identified.uri
    cfg = compose_config(
        "task=monitor", "plant=log", "tracking=none", f"data.paths=[{log}]", f"task.model={identified.run_id}"
    )
    instantiate(cfg.task)(cfg, tmp_path / "monitor")
    assert os.environ["MLFLOW_TRACKING_URI"] == identified.uri
    summary = (tmp_path / "monitor" / "summary.md").read_text()
    assert f"MLflow run {identified.run_id}" in summary and "friction law holding" in summary


@pytest.mark.parametrize(
    "source", ["runs:/0123456789abcdef0123456789abcdef/model", "0123456789abcdef0123456789abcdef"]
)
def test_an_unknown_run_is_named_with_its_setting_and_store(identified: Identified, source: str) -> None:
    with pytest.raises(ModelNotFoundError, match=r"task\.unloaded_model=.*Run with id") as raised:
        resolve_model(source, identified.uri, "task.unloaded_model")
    assert str(identified.folder / "mlflow.db") in str(raised.value)
    assert isinstance(raised.value, FileNotFoundError)


def test_every_form_of_a_model_resolves_to_the_same_file(identified: Identified) -> None:
    expected = (identified.run / "identified_model.yaml").read_text()
    identified.client.set_registered_model_alias(NAME, "champion", "1")
    for source in (
        identified.run_id,
        f"runs:/{identified.run_id}/model",
        f"models:/{NAME}/1",
        f"models:/{NAME}@champion",
        str(identified.run),
    ):
        resolved = resolve_model(source, identified.uri)
        assert resolved.path.read_text() == expected, source
        assert resolved.run_id in (identified.run_id, None), source
    assert resolve_model(f"models:/{NAME}/1", identified.uri).tags()["lwrlab.model_version"] == "1"


# --- payload ------------------------------------------------------------------------------------------

PAYLOAD_PREDICT = """
import sys
import mlflow
import pandas as pd
from hydra.core.global_hydra import GlobalHydra

uri, model_uri, states, out = sys.argv[1:]
model = mlflow.pyfunc.load_model(model_uri)
model.predict(pd.read_parquet(states)).to_parquet(out)
assert not GlobalHydra.instance().is_initialized(), "no Hydra app, no config"
"""


def _payload_logs(folder: Path) -> tuple[Path, Path]:
    """Noiseless unloaded and loaded logs (2 s each) of the ``plant=log`` robot carrying a roller."""
    from composing import compose_config
    from hydra.utils import instantiate

    from lwrlab.pipeline.build import build
    from lwrlab.pipeline.tools.library import load_tool
    from plugins.plants.simulated import SimulatedPlant

    robot = instantiate(compose_config("plant=log").robot)
    plant = SimulatedPlant(robot, seed=0, show_progress=False, torque_noise_std=0.0, encoder_noise_std=0.0)

    def motion(seed: int) -> object:
        source = build("trajectory", "multisine", duration=2.0, harmonics=10, seed=seed, limit_fraction=0.9)
        return source.sample(robot, 1000.0)

    unloaded = write_log(plant.measure(motion(1)), folder / "unloaded.csv")
    loaded = write_log(plant.with_tool(load_tool("small_roller")).measure(motion(100)), folder / "loaded.csv")
    return unloaded, loaded


@pytest.mark.parametrize("form", ["runs", "alias"])
def test_a_payload_reads_the_unloaded_model_by_its_uri_with_its_law(
    identified: Identified, tmp_path: Path, form: str
) -> None:
    """``task.unloaded_model=runs:/…`` or ``models:/…@champion``: the payload's robot is the model's,
    with the law it was identified with (the holding law and its breakaway terms), not the payload
    job's own (``plant=log``: the sign law with offsets)."""
    from composing import compose_config
    from hydra.utils import instantiate

    identified.client.set_registered_model_alias(NAME, "champion", "1")
    source = f"runs:/{identified.run_id}/model" if form == "runs" else f"models:/{NAME}@champion"
    _, loaded = _payload_logs(tmp_path)
    cfg = compose_config(
        "task=payload",
        "plant=log",
        f"task.loaded_paths=[{loaded}]",
        f"task.unloaded_model={source}",
        f"tracking.uri={identified.uri}",
    )
    instantiate(cfg.task)(cfg, tmp_path / "run")
    read = yaml.safe_load((tmp_path / "run" / "payload.yaml").read_text())["unloaded_model"]
    assert read["source"] == source and read["run_id"] == identified.run_id
    assert read["friction_law"].startswith("holding") and "breakaway" in read["friction_terms"]
    assert "offset" not in read["friction_terms"]  # plant=log's own terms are not the model's
    if form == "alias":
        assert (read["registered_name"], read["registered_version"]) == (NAME, "1")


def test_a_payload_run_logs_and_registers_a_model_of_its_payloads_torques(
    identified: Identified, tmp_path: Path
) -> None:
    unloaded, loaded = _payload_logs(tmp_path)
    run = identified.folder / "payload"
    done = run_app(
        None,
        "task=payload",
        "plant=log",
        f"task.unloaded_paths=[{unloaded}]",
        f"task.loaded_paths=[{loaded}]",
        "measurement.processing.cutoff_hz=null",
        "measurement.processing.difference_accuracy=4",
        "measurement.processing.rate_hz=100",
        "tracking.register_model=robot",
        f"hydra.run.dir={run}",
        store=identified.folder,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    run_id = (run / "mlflow_run_id.txt").read_text().strip()
    client = identified.client
    (version,) = client.search_model_versions("name = 'kuka_lwr4_payload'")
    assert version.run_id == run_id and version.tags["tool"] == "small_roller"
    assert float(version.tags["mass"]) == pytest.approx(0.1, rel=0.01)  # the small roller's 0.1 kg
    assert "payload" in version.description

    # random states, predicted in a plain process from the registered version (its files only)
    rng = np.random.default_rng(0)
    q, dq, ddq = rng.uniform(-1.5, 1.5, (3, 40, JOINTS))
    states = pd.DataFrame(
        {
            f"{name}{j}": values[:, j - 1]
            for name, values in (("q", q), ("dq", dq), ("ddq", ddq))
            for j in range(1, 8)
        }
    )
    states.to_parquet(tmp_path / "states.parquet")
    moved = tmp_path / "elsewhere"  # the run folder gone: the model needs none of its files
    run.rename(moved)
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            PAYLOAD_PREDICT,
            identified.uri,
            "models:/kuka_lwr4_payload/1",
            str(tmp_path / "states.parquet"),
            str(tmp_path / "predicted.parquet"),
        ],
        cwd=tmp_path,
        env=app_environment({"MLFLOW_TRACKING_URI": identified.uri}),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    predicted = pd.read_parquet(tmp_path / "predicted.parquet")
    assert list(predicted.columns) == [f"tau{j}" for j in range(1, JOINTS + 1)]

    # independently: Pinocchio's RNEA of the robot carrying the payload, less that of the robot
    from composing import compose_config
    from hydra.utils import instantiate

    robot = instantiate(compose_config("plant=log").robot)
    carrying = attach_payload(robot, payload_parameters(moved / "payload.yaml"))
    difference = np.stack(
        [
            pin.rnea(carrying.model, carrying.model.createData(), q[k], dq[k], ddq[k])
            - pin.rnea(robot.model, robot.model.createData(), q[k], dq[k], ddq[k])
            for k in range(len(q))
        ]
    )
    assert np.abs(difference).max() > 0.1  # the payload loads the joints
    np.testing.assert_allclose(predicted.to_numpy(), difference, rtol=0, atol=1e-9)
    model_id = client.get_run(run_id).outputs.model_outputs[0].model_id
    files = {Path(f.path).name for f in client.list_logged_model_artifacts(model_id)}
    assert {"MLmodel", "input_example.json", "requirements.txt"} <= files
    artifacts = {Path(f.path).name for f in client.list_logged_model_artifacts(model_id, "artifacts")}
    assert {"payload.yaml", "payload_robot.yaml", "payload_parameters.csv"} <= artifacts
