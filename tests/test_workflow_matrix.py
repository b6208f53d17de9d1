"""Every workflow across tasks, on arms as they are logged, with the default settings (slow).

Four kinds of arm, each logged as such an arm is:

- ``lwr4``: the KUKA LWR4 (modified DH), joint torque sensors, 500 Hz; its validation log stamped
  on arrival (stamps jittering around the controller's grid);
- ``panda``: Franka's Panda from its URDF (example-robot-data), joint torque sensors;
- ``ur_like``: a UR5-like arm (``benchmarks/geared_arms.py``), harmonic drives, LuGre friction,
  encoders and **motor currents** through the torque constants of its drive block;
- ``coupled_wrist``: an industrial arm whose motor 6 also turns with joint 5, logged at the motors
  as the encoders count: raw angles wrapping every turn, zero at its home
  ``q₀ = (0, −0.4, 0.5, 0, 0.6, 0)`` (``robot.drive.position_offsets``) where every log starts,
  motor torques.

Each arm's chain, with the defaults for logs (``friction=auto``, ``estimator=sdp``), into one SQLite
store: identify (registered, alias ``champion``) → payload by the identified model (a path, with the
store out of reach so the run is kept offline; and ``runs:/`` or ``models:/…@champion``) → drive
gains (the arm measured in currents) → monitor by run id with only ``MLFLOW_TRACKING_URI`` naming
the store → ``lwrlab sync`` of the offline run → ``robot=identified`` in a sweep. Every link checks
what it read from the one before: the friction law and drive terms the data chose, the drive train
(offsets included), the logged stamps, the lineage.
"""

from __future__ import annotations

import json
import socket
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
import yaml
from composing import compose_config
from geared_logs import geared_arms, warped_multisine
from hydra.utils import instantiate
from mlflow.tracking import MlflowClient
from tracking_apps import run_app

from lwrlab.io.logs import write_log
from lwrlab.model.inertia import standard_parameters
from lwrlab.model.payload import attach_payload
from lwrlab.pipeline.build import build
from lwrlab.tracking.models.identified_model import read_identified_model
from plugins.plants.simulated import SimulatedPlant

pytestmark = pytest.mark.slow

PAYLOAD = standard_parameters(2.0, np.array([0.05, 0.0, 0.1]), np.diag([0.004, 0.004, 0.002]))
"""A 2 kg payload whose centre of mass lies off every joint axis (flange frame)."""
WRIST_OFFSETS = [0.0, -0.4, 0.5, 0.0, 0.6, 0.0]
"""rad: the coupled wrist's joint positions where its encoders read zero, its home: every log
starts there (its motors' encoders read one turn: the turns count from the log's first sample)."""
ARMS = ("lwr4", "panda", "ur_like", "coupled_wrist")
URI_FORM = {"lwr4": "runs", "panda": "alias", "ur_like": "alias", "coupled_wrist": "runs"}
"""The MLflow form of the identified model each arm's payload reads (beside its path)."""


@dataclass(frozen=True)
class Arm:
    """One arm's description overrides and logs."""

    name: str
    robot: tuple[str, ...]
    """The ``robot=…`` overrides that describe it."""
    fit: Path
    validation: Path
    loaded: Path
    stamps: np.ndarray | None = None
    """The validation log's stamps, when they jitter around its grid."""
    torque_constants: np.ndarray | None = None
    """The true torque constants (N·m/A) of an arm measured in currents."""


@dataclass(frozen=True)
class Chain:
    """An arm identified with the defaults, in the shared store."""

    arm: Arm
    store: Path
    run: Path
    run_id: str
    stored: dict[str, Any]
    """The identified model's file."""

    @property
    def uri(self) -> str:
        return f"sqlite:///{self.store / 'mlflow.db'}"

    @property
    def client(self) -> MlflowClient:
        return MlflowClient(tracking_uri=self.uri)

    def tracked(self) -> list[str]:
        return [f"tracking.uri={self.uri}", f"tracking.artifact_location={self.store / 'artifacts'}"]


def _multisine(robot: Any, seconds: float, seed: int) -> Any:
    source = build("trajectory", "multisine", duration=seconds, harmonics=8, seed=seed, limit_fraction=0.8)
    return source.sample(robot, 500.0)


def _torque_sensor_arm(folder: Path, name: str, robot_overrides: tuple[str, ...]) -> Arm:
    """Joint torque sensors (the simulated plant, its truth perturbed and its noise on); the
    validation log stamped on arrival: up to 0.4 periods late, the samples regular."""
    robot = instantiate(compose_config("plant=log", *robot_overrides).robot)
    plant = SimulatedPlant(robot, seed=3, show_progress=False)
    fit = write_log(plant.measure(_multisine(robot, 8.0, 1)), folder / "fit.csv")
    check = plant.measure(_multisine(robot, 4.0, 7))
    stamps = check.t + 50.0 + np.random.default_rng(4).uniform(0.0, 0.4, check.t.shape) / 500.0
    validation = write_log(replace(check, t=stamps), folder / "validation.csv")
    loaded = write_log(
        plant.with_tool(PAYLOAD).measure(_multisine(robot, 6.0, 100)), folder / "loaded.parquet"
    )
    return Arm(name, robot_overrides, fit, validation, loaded, pd.read_csv(validation)["t"].to_numpy())


def _geared_arm(folder: Path, name: str) -> Arm:
    """A geared arm of ``benchmarks/geared_arms.py`` logged at its motors; the coupled wrist's
    encoder angles made raw: counted from their own zero, wrapping every turn."""
    spec = geared_arms.ARMS["ur_like" if name == "ur_like" else "industrial"]
    if name == "coupled_wrist":  # its logs start at home, where its encoders read zero
        spec = replace(spec, center=np.array(WRIST_OFFSETS))
    _, arm = geared_arms.geared_arm(spec)
    description = dict(spec.description)
    description["rotor_inertia"] = (0.8 * arm.reflected_inertia).round(4).tolist()
    offsets = np.zeros(6) if name == "ur_like" else np.array(WRIST_OFFSETS)
    if name == "coupled_wrist":
        description["drive"] = {**description["drive"], "position_offsets": WRIST_OFFSETS}
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(geared_arms._yaml_ready(description), sort_keys=False))
    rng = np.random.default_rng(1)
    loaded_arm = replace(arm, robot=attach_payload(arm.robot, PAYLOAD))
    logs = {}
    for log, (player, seconds, frequencies, seed) in {
        "fit": (arm, 9.0, [0.2, 0.3, 0.5, 0.7, 0.9, 1.2], 1),
        "validation": (arm, 5.0, [0.25, 0.4, 0.6, 0.85], 2),
        "loaded": (loaded_arm, 7.0, [0.2, 0.35, 0.55, 0.8, 1.1], 3),
    }.items():
        frame = player.play(warped_multisine(spec, seconds, frequencies, seed), rng).log_frame()
        if name == "coupled_wrist":  # what the encoders count: R·(q − q₀), one turn at a time
            raw = frame[[f"q{j}" for j in range(1, 7)]].to_numpy() - arm.drive.transmission @ offsets
            frame[[f"q{j}" for j in range(1, 7)]] = np.angle(np.exp(1j * raw))
        logs[log] = folder / f"{log}.parquet"
        frame.to_parquet(logs[log], index=False)
    constants = arm.drive.torque_constants
    return Arm(name, ("robot=mdh_file", f"robot.path={path}"), **logs, torque_constants=constants)


def _arm(folder: Path, name: str) -> Arm:
    if name == "lwr4":
        return _torque_sensor_arm(folder, name, ())
    if name == "panda":
        return _torque_sensor_arm(folder, name, ("robot=example_robot", "robot.robot_name=panda"))
    return _geared_arm(folder, name)


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("matrix_store")


@pytest.fixture(scope="module", params=ARMS)
def chain(request: pytest.FixtureRequest, store: Path, tmp_path_factory: pytest.TempPathFactory) -> Chain:
    """The arm's logs, identified with the defaults (tracked, registered under its name, alias
    ``champion``)."""
    name = request.param
    folder = tmp_path_factory.mktemp(name)
    arm = _arm(folder, name)
    run = folder / "identified"
    done = run_app(
        None,
        "task=identification",
        "plant=log",
        *arm.robot,
        f"data.paths=[{arm.fit}]",
        f"data.validation_paths=[{arm.validation}]",
        f"tracking.register_model={name}",
        f"hydra.run.dir={run}",
        store=store,
        cwd=folder,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    client = MlflowClient(tracking_uri=f"sqlite:///{store / 'mlflow.db'}")
    client.set_registered_model_alias(name, "champion", "1")
    stored = yaml.safe_load((run / "identified_model.yaml").read_text())
    return Chain(arm, store, run, (run / "mlflow_run_id.txt").read_text().strip(), stored)


def _law(stored: dict[str, Any]) -> str:
    """The class name of the stored friction law (``HoldingFriction``, ``SignCoulomb``, …)."""
    return str(stored["robot"]["friction_law"]["_target_"]).rsplit(".", 1)[-1]


def _read_law(described: str) -> str:
    """The law's name as a task's record describes it (``holding (presliding …)``)."""
    return described.split(" ")[0]


LAW_NAMES = {
    "SignCoulomb": "sign",
    "HoldingFriction": "holding",
    "SmoothCoulomb": "smooth",
    "Stribeck": "stribeck",
    "AsymmetricCoulomb": "asymmetric",
}


def test_identification_writes_what_the_data_chose_whole(chain: Chain) -> None:
    """The model keeps the law and drive terms the data chose and the drive train it was measured
    with; its predictions sit at the logged stamps."""
    robot = chain.stored["robot"]
    choice = pd.read_csv(chain.run / "friction_choice.csv")
    assert LAW_NAMES[_law(chain.stored)] in " ".join(choice.astype(str).to_numpy().ravel())
    base = set(chain.stored["base_parameters"])
    for term, prefix in (("rotor", "IA"), ("breakaway", "FB"), ("offset", "FO")):
        if term in robot["friction_terms"]:
            assert any(name.startswith(prefix) for name in base), (term, sorted(base))
    drive = read_identified_model(chain.run).robot.drive_train  # as every task rebuilds it
    if chain.arm.name == "coupled_wrist":
        np.testing.assert_allclose(drive.position_offsets, WRIST_OFFSETS)
        assert drive.coupling[5, 4] == 0.3 and drive.position_side == drive.torque_side == "motor"
    if chain.arm.name == "ur_like":
        np.testing.assert_allclose(drive.torque_constants, chain.arm.torque_constants)
    assert drive.rotor_inertia_columns == ("rotor" in robot["friction_terms"])
    predicted = pd.read_parquet(chain.run / "predicted_torque.parquet")
    validation = predicted[predicted["role"] == "validation"]
    assert len(validation) > 1000
    if chain.arm.stamps is not None:  # the rows join the log's own by time
        assert set(validation["t"]) <= set(chain.arm.stamps)
        assert "t_grid" in validation and np.abs(validation["t"] - validation["t_grid"]).max() > 0
    assert json.loads((chain.run / "metrics.json").read_text())["validation_rel_error"] < 0.25


def _payload_mass(run: Path) -> float:
    return float(yaml.safe_load((run / "payload.yaml").read_text())["mass"])


def test_the_payload_reads_the_identified_model_whole(chain: Chain, tmp_path: Path) -> None:
    """By path (the store out of reach: the run kept offline, then synced) and by MLflow URI: the
    payload is identified on the model's robot, law and drive terms (the job's own robot config is
    the default LWR4 and plant=log's terms), within 10 % of its mass."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        closed = probe.getsockname()[1]
    offline = tmp_path / "payload_offline"
    common = ["task=payload", "plant=log", f"task.loaded_paths=[{chain.arm.loaded}]"]
    done = run_app(
        None,
        *common,
        f"task.unloaded_model={chain.run}",
        f"tracking.uri=postgresql://user:secret@127.0.0.1:{closed}/db",
        f"hydra.run.dir={offline}",
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert (offline / "mlflow_offline_run.json").is_file()
    form = URI_FORM[chain.arm.name]
    source = f"runs:/{chain.run_id}/model" if form == "runs" else f"models:/{chain.arm.name}@champion"
    cfg = compose_config(*common, f"task.unloaded_model={source}", *chain.tracked())
    instantiate(cfg.task)(cfg, tmp_path / "payload_uri")
    for run in (offline, tmp_path / "payload_uri"):
        read = yaml.safe_load((run / "payload.yaml").read_text())["unloaded_model"]
        assert _read_law(read["friction_law"]) == LAW_NAMES[_law(chain.stored)], run
        assert read["friction_terms"] == chain.stored["robot"]["friction_terms"], run
        assert abs(_payload_mass(run) / 2.0 - 1) < 0.10, (run, _payload_mass(run))
        if chain.arm.name == "coupled_wrist":
            assert "motor 6 turns joint 5" in read["drive_train"]
    assert read["run_id"] == chain.run_id

    # the run kept offline, synced: the payload's model logged, the model it read named
    synced = run_app(None, "sync", str(offline), "--tracking-uri", chain.uri, cwd=tmp_path)
    assert synced.returncode == 0 and "failed (" not in synced.stderr, synced.stderr[-3000:]
    run_id = (offline / "mlflow_run_id.txt").read_text().strip()
    logged = chain.client.get_run(run_id)
    assert logged.info.status == "FINISHED" and logged.outputs.model_outputs
    assert logged.data.tags["lwrlab.model_uri"] == str(chain.run.resolve())
    assert float(logged.data.metrics["mass"]) == pytest.approx(_payload_mass(offline))


def test_drive_gains_read_the_identified_model(chain: Chain, tmp_path: Path) -> None:
    """An arm measured in motor currents: its torque constants from the unloaded and the loaded log
    with the payload's mass and centre of mass known, on the identified model's robot (its law,
    drive terms, drive train), written as the drive block's setting."""
    if chain.arm.torque_constants is None:
        pytest.skip(f"{chain.arm.name} logs torques, not currents: no drive gains to identify")
    cfg = compose_config(
        "task=drive_gains",
        "plant=log",
        "robot=identified",
        f"robot.source=models:/{chain.arm.name}@champion",
        f"task.unloaded_paths=[{chain.arm.fit}]",
        f"task.loaded_paths=[{chain.arm.loaded}]",
        "task.payload.mass=2.0",
        "task.payload.com=[0.05,0,0.1]",
        *chain.tracked(),
    )
    instantiate(cfg.task)(cfg, tmp_path)
    document = yaml.safe_load((tmp_path / "drive_gains.yaml").read_text())
    assert document["override"].startswith("robot.drive.torque_constants=[")
    assert _read_law(document["robot"]["friction_law"]) == LAW_NAMES[_law(chain.stored)]
    assert set(chain.stored["robot"]["friction_terms"]) <= set(document["robot"]["friction_terms"])
    # within 7 % where the payload determines them (its load grows the LuGre friction the model holds
    # constant), else flagged as poorly determined
    error = np.abs(np.array(document["drive_gains"]) / chain.arm.torque_constants - 1)
    weak = np.array(document["relative_std_pct"]) > 1.0
    assert np.all((error < 0.07) | weak), (error, document["relative_std_pct"])
    assert np.sum(~weak) >= 3


def test_the_monitor_reads_the_model_by_run_id_where_mlflow_tracking_uri_says(
    chain: Chain, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``tracking=none``, only the variable naming the store: the model by its run id, the
    thresholds calibrated on the logs its run identified from, the observer with the model's law
    and drive train (raw encoder angles read through the offsets), rows at the logged stamps."""
    monkeypatch.setenv("MLFLOW_TRACKING_URI", chain.uri)
    monkeypatch.chdir(tmp_path)
    cfg = compose_config(
        "task=monitor",
        "plant=log",
        "tracking=none",
        f"data.paths=[{chain.arm.validation}]",
        f"task.model={chain.run_id}",
    )
    metrics = instantiate(cfg.task)(cfg, tmp_path / "monitor")
    summary = (tmp_path / "monitor" / "summary.md").read_text()
    assert f"the logs of the model's run {chain.run_id}" in summary or f"MLflow run {chain.run_id}" in summary
    law = LAW_NAMES[_law(chain.stored)]
    assert f"friction law {law}" in summary and ", ".join(chain.stored["robot"]["friction_terms"]) in summary
    assert metrics["monitored_hours"] > 0
    torques = pd.read_parquet(tmp_path / "monitor" / "external_torque.parquet")
    if chain.arm.stamps is not None:
        np.testing.assert_array_equal(torques["t"].to_numpy(), chain.arm.stamps)
    # a contact-free log seen through the right model: the external torque stays near the noise
    quiet = torques[torques["monitored"]]
    assert np.median(np.abs(quiet[[c for c in quiet if c.startswith("observer")]].to_numpy())) < 2.0


def test_a_sweep_of_robot_identified_keeps_the_models_law_and_drive_train(
    chain: Chain, tmp_path: Path
) -> None:
    """``lwrlab -m robot=identified robot.source=models:/<arm>@champion estimator=ols,wls``: every
    job identifies with the model's law and drive terms (not plant=log's friction=auto) and its
    drive train, and its run names the model it read."""
    sweep = tmp_path / "sweep"
    done = run_app(
        None,
        "task=identification",
        "plant=log",
        "robot=identified",
        f"robot.source=models:/{chain.arm.name}@champion",
        f"data.paths=[{chain.arm.validation}]",
        "estimator=ols,wls",
        f"hydra.sweep.dir={sweep}",
        store=chain.store,
        multirun=True,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    for job in ("0", "1"):
        stored = yaml.safe_load((sweep / job / "identified_model.yaml").read_text())
        assert _law(stored) == _law(chain.stored)
        assert set(chain.stored["robot"]["friction_terms"]) <= set(stored["robot"]["friction_terms"])
        assert not (sweep / job / "friction_choice.csv").exists()  # the law was read, not chosen
        tags = chain.client.get_run((sweep / job / "mlflow_run_id.txt").read_text().strip()).data.tags
        assert tags["lwrlab.model_run_id"] == chain.run_id
        assert tags["lwrlab.model_uri"] == f"models:/{chain.arm.name}@champion"
