"""What a job's run gets of models: the model it identified (an MLflow Model) and the models it read.

* :func:`log_identified_model`: a job whose output folder holds ``identified_model.yaml`` (an
  identification, the paper's chain) logs it as the run's MLflow Model ``model`` (pyfunc flavour,
  :mod:`~lwrlab.tracking.models.identified_pyfunc`): its signature, an input example (a few states
  of the fit's motion, ``model_input_example.csv``), the YAML, the URDF and the base-parameter table
  as artifacts, and pip requirements pinned to the versions installed (none inferred: MLflow would
  load the model and watch its imports, seconds per job);
* :func:`log_model_inputs`: the models the job read (``model_inputs.json``) become its run's tags
  (``lwrlab.model_uri``, ``lwrlab.model_run_id``, ``lwrlab.model_name``, ``lwrlab.model_version``,
  ``lwrlab.model_id``) and, for logged models, its model inputs (the lineage MLflow's UI shows).
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import pandas as pd
from mlflow.entities import LoggedModelInput
from mlflow.tracking import MlflowClient

from lwrlab.tracking.models.identified_pyfunc import (
    MODEL_ARTIFACT,
    PARAMETERS_ARTIFACT,
    TIME_COLUMN,
    URDF_ARTIFACT,
    model_signature,
    rows_rate,
    state_columns,
)
from lwrlab.tracking.models.resolve import MODEL_NAME, lineage_tags, read_models_used
from lwrlab.tracking.store.sqlite import retry_locked

log = logging.getLogger(__name__)

MODEL_CODE = Path(__file__).with_name("identified_model_code.py")
"""The file MLflow runs to load the model (*models from code*: nothing pickled)."""
URDF_FILE = "identified_model.urdf"
PARAMETERS_FILE = "base_parameters.csv"
PREDICTIONS_FILE = "predicted_torque.parquet"
REQUIRED_DISTRIBUTIONS = ("lwrlab", "pin", "numpy", "scipy", "pandas", "hydra-core", "omegaconf", "pyyaml")
"""What the model needs to load and predict, pinned at the installed versions (MLflow adds itself)."""
DEFAULT_RATE_HZ = 1000.0
"""The rate of consecutive rows when a run left no sample times to read it from (Hz)."""
MODEL_TYPE = "identified_dynamics"
PAYLOAD_MODEL_CODE = Path(__file__).with_name("payload_model_code.py")
PAYLOAD_MODEL_TYPE = "identified_payload"
PAYLOAD_NAME_SUFFIX = "_payload"
"""``tracking.register_model=robot`` registers a payload as ``<robot>_payload``."""


@dataclass(frozen=True)
class LoggedIdentifiedModel:
    """A model an identification run logged."""

    model_id: str
    """MLflow's logged model id."""
    model_uri: str
    """``models:/<model id>``: what a registered version points to."""
    robot: str
    """The robot's name (the identified model's ``robot.name``)."""
    n_joints: int
    kind: str = "robot"
    """``robot`` (an identified robot) or ``payload`` (a payload at its flange)."""
    tags: dict[str, str] = field(default_factory=dict)
    """What the model's registered versions are tagged with besides the run's metrics (a payload's
    mass and recognised tool)."""

    @property
    def default_name(self) -> str:
        """The registered name ``tracking.register_model=robot`` means: the robot's name, for a
        payload followed by :data:`PAYLOAD_NAME_SUFFIX`."""
        return self.robot + (PAYLOAD_NAME_SUFFIX if self.kind == "payload" else "")


def pip_requirements() -> list[str]:
    """``name==version`` of each of :data:`REQUIRED_DISTRIBUTIONS` installed (lwrlab itself first)."""
    found = []
    for name in REQUIRED_DISTRIBUTIONS:
        try:
            found.append(f"{name}=={version(name)}")
        except PackageNotFoundError:
            continue
    return found


@contextmanager
def _quiet_mlflow() -> Iterator[None]:
    """No progress bars and no INFO lines of MLflow's while it saves and checks the model."""
    from mlflow.environment_variables import MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR

    mlflow_log = logging.getLogger("mlflow")
    level, bars = mlflow_log.level, os.environ.get(MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR.name)
    mlflow_log.setLevel(max(level, logging.WARNING))
    os.environ[MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR.name] = "false"
    try:
        yield
    finally:
        mlflow_log.setLevel(level)
        if bars is None:
            os.environ.pop(MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR.name, None)
        else:
            os.environ[MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR.name] = bars


@contextmanager
def _requirements_checked_by_name() -> Iterator[None]:
    """MLflow checks pinned requirements against the environment through a map of every installed
    distribution's modules, built on first use (seconds: every distribution's file list is read).
    Pinned names need no map: an empty one makes MLflow look each version up by name, for the call."""
    from mlflow.utils import requirements_utils

    if getattr(requirements_utils, "_MODULES_TO_PACKAGES", False) is not None:
        yield  # already built (or the private map is gone): nothing to spare
        return
    setattr(requirements_utils, "_MODULES_TO_PACKAGES", {})  # noqa: B010  (a private global of MLflow's)
    try:
        yield
    finally:
        setattr(requirements_utils, "_MODULES_TO_PACKAGES", None)  # noqa: B010


def _joint_count(columns: list[str], prefix: str) -> int:
    return sum(bool(re.fullmatch(rf"{prefix}\d+", str(column))) for column in columns)


def _predictions_schema(output_dir: Path) -> tuple[int, float | None]:
    """(joints, rate of the first log's rows or None) from ``predicted_torque.parquet``."""
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    path = output_dir / PREDICTIONS_FILE
    if not path.is_file():
        return 0, None
    joints = _joint_count(list(pq.read_schema(path).names), "tau_hat")
    first_rows = next(pq.ParquetFile(path).iter_batches(batch_size=64, columns=["log", "t"]), None)
    if first_rows is None:
        return joints, None
    frame = first_rows.to_pandas()
    t = frame.loc[frame["log"] == frame["log"].iloc[0], "t"].to_numpy(dtype=float)
    steps = t[1:] - t[:-1]
    return joints, (float(1.0 / pd.Series(steps).median()) if steps.size and steps.min() > 0 else None)


def _input_example(path: Path, n_joints: int) -> pd.DataFrame | None:
    if not path.is_file():
        return None
    frame = pd.read_csv(path)
    return frame[[TIME_COLUMN, *state_columns(n_joints)]] if TIME_COLUMN in frame else frame


def _robot_name(model_file: Path) -> str:
    from lwrlab.yaml_files import safe_yaml

    document = safe_yaml(model_file.read_text(encoding="utf-8")) or {}
    return str((document.get("robot") or {}).get("name") or "robot")


def log_identified_model(
    client: MlflowClient, run_id: str, output_dir: Path, tracking_uri: str
) -> LoggedIdentifiedModel | None:
    """Log the job's identified model as the run's MLflow Model ``model``; None: the job identified none.

    The rate of consecutive rows (a friction law with memory) is the identification logs' own:
    read from the input example's times, else from the predictions' (see
    :mod:`~lwrlab.tracking.models.identified_pyfunc`).
    """
    # the file names only: the core's readers are not needed here
    from lwrlab.io.artifacts import IDENTIFIED_MODEL_FILE, MODEL_INPUT_EXAMPLE_FILE

    model_file = output_dir / IDENTIFIED_MODEL_FILE
    if not model_file.is_file():
        return None
    joints, rate_hz = _predictions_schema(output_dir)
    example_path = output_dir / MODEL_INPUT_EXAMPLE_FILE
    if example_path.is_file():
        header = list(pd.read_csv(example_path, nrows=0).columns)
        joints = _joint_count(header, "q") or joints
    if joints == 0:
        log.warning("%s: no joint count found beside it; its MLflow Model is not logged", model_file)
        return None
    example = _input_example(example_path, joints)
    rate_hz = (rows_rate(example) if example is not None else None) or rate_hz
    artifacts = {MODEL_ARTIFACT: str(model_file)}
    for key, name in ((URDF_ARTIFACT, URDF_FILE), (PARAMETERS_ARTIFACT, PARAMETERS_FILE)):
        if (output_dir / name).is_file():
            artifacts[key] = str(output_dir / name)
    robot = _robot_name(model_file)
    # 9 digits: the rate of uniform samples, not the rounding of their times
    config = {"rate_hz": float(f"{rate_hz or DEFAULT_RATE_HZ:.9g}")}
    model_id = _log_pyfunc(
        client,
        run_id,
        tracking_uri,
        MODEL_CODE,
        MODEL_TYPE,
        {"robot": robot},
        artifacts,
        joints,
        example,
        config,
    )
    return LoggedIdentifiedModel(model_id, f"models:/{model_id}", robot, joints)


METRICS_PER_BATCH = 1000
"""MLflow's limit of metrics in one ``log_batch``."""


def _log_pyfunc(
    client: MlflowClient,
    run_id: str,
    tracking_uri: str,
    code: Path,
    model_type: str,
    tags: dict[str, str],
    artifacts: dict[str, str],
    joints: int,
    example: pd.DataFrame | None,
    config: dict[str, float] | None = None,
) -> str:
    """Log the pyfunc model of ``code`` as the run's MLflow Model :data:`MODEL_NAME`; its model id.

    What ``mlflow.pyfunc.log_model`` does, through this store's client: the logged model created in
    the run's experiment and linked to the run as its output, given the run's metrics (its page
    lists them), its folder saved (``save_model``: flavour, signature, input example, pinned
    requirements) and uploaded. Not MLflow's check that serves the input example through the model
    (loading it again, 0.8 s a job): the tests load and predict with every logged model.
    """
    import tempfile
    import time

    import mlflow.pyfunc
    from mlflow.entities import LoggedModelOutput, Metric
    from mlflow.models import Model

    run = retry_locked(client.get_run, run_id)
    # created here, in the run's experiment (MLflow's own would go to its default experiment)
    created = retry_locked(
        client.create_logged_model,
        run.info.experiment_id,
        name=MODEL_NAME,
        source_run_id=run_id,
        tags=tags,
        params=dict(run.data.params),
        model_type=model_type,
    )
    model_id = str(created.model_id)
    retry_locked(client.log_outputs, run_id, [LoggedModelOutput(model_id, step=0)])
    stamp = int(time.time() * 1000)
    metrics = [
        Metric(key, value, stamp, 0, run_id=run_id, model_id=model_id)
        for key, value in run.data.metrics.items()
    ]
    for first in range(0, len(metrics), METRICS_PER_BATCH):
        retry_locked(client.log_batch, run_id, metrics=metrics[first : first + METRICS_PER_BATCH])
    with tempfile.TemporaryDirectory(prefix="lwrlab-model-") as scratch, _requirements_checked_by_name():
        folder = Path(scratch) / MODEL_NAME
        described = Model(
            artifact_path=created.artifact_location, model_uuid=model_id, run_id=run_id, model_id=model_id
        )
        with _quiet_mlflow():
            mlflow.pyfunc.save_model(
                str(folder),
                python_model=str(code),
                artifacts=artifacts,
                signature=model_signature(joints),
                input_example=example,
                pip_requirements=pip_requirements(),
                model_config=config,
                mlflow_model=described,
            )
            retry_locked(client.log_model_artifacts, model_id, str(folder))
    return model_id


def log_payload_model(
    client: MlflowClient, run_id: str, output_dir: Path, tracking_uri: str
) -> LoggedIdentifiedModel | None:
    """Log the job's payload as the run's MLflow Model ``model``; None: the job identified none.

    Its version's tags (:attr:`LoggedIdentifiedModel.tags`): ``mass`` (kg) and ``tool``, the
    recognised library tool (``unknown`` far from every one).
    """
    import yaml

    from lwrlab.io.artifacts import MODEL_INPUT_EXAMPLE_FILE
    from lwrlab.io.payload_model import PAYLOAD_FILE, PAYLOAD_PARAMETERS_FILE, PAYLOAD_ROBOT_FILE
    from lwrlab.tracking.models.payload_pyfunc import (
        PAYLOAD_ARTIFACT,
        ROBOT_ARTIFACT,
        ROBOT_FILE_ARTIFACT,
        TABLE_ARTIFACT,
    )

    payload_file, robot_file = output_dir / PAYLOAD_FILE, output_dir / PAYLOAD_ROBOT_FILE
    example_path = output_dir / MODEL_INPUT_EXAMPLE_FILE
    if not (payload_file.is_file() and robot_file.is_file() and example_path.is_file()):
        return None
    joints = _joint_count(list(pd.read_csv(example_path, nrows=0).columns), "q")
    document = yaml.safe_load(payload_file.read_text(encoding="utf-8")) or {}
    description = yaml.safe_load(robot_file.read_text(encoding="utf-8")) or {}
    artifacts = {PAYLOAD_ARTIFACT: str(payload_file), ROBOT_ARTIFACT: str(robot_file)}
    if description.get("path") is not None:
        artifacts[ROBOT_FILE_ARTIFACT] = str(output_dir / str(description["path"]))
    if (output_dir / PAYLOAD_PARAMETERS_FILE).is_file():
        artifacts[TABLE_ARTIFACT] = str(output_dir / PAYLOAD_PARAMETERS_FILE)
    robot = str(document.get("robot") or "robot")
    tool = str((document.get("recognised") or {}).get("tool") or "")
    tags = {"robot": robot, "mass": f"{float(document['mass']):.6g}", **({"tool": tool} if tool else {})}
    example = _input_example(example_path, joints)
    model_id = _log_pyfunc(
        client, run_id, tracking_uri, PAYLOAD_MODEL_CODE, PAYLOAD_MODEL_TYPE, tags, artifacts, joints, example
    )
    return LoggedIdentifiedModel(model_id, f"models:/{model_id}", robot, joints, "payload", tags)


def log_job_model(
    client: MlflowClient, run_id: str, output_dir: Path, tracking_uri: str
) -> LoggedIdentifiedModel | None:
    """Log the model the job identified: a robot (:func:`log_identified_model`) or a payload
    (:func:`log_payload_model`); None: neither."""
    logged = log_identified_model(client, run_id, output_dir, tracking_uri)
    return logged if logged is not None else log_payload_model(client, run_id, output_dir, tracking_uri)


def log_model_inputs(client: MlflowClient, run_id: str, output_dir: Path) -> None:
    """Tag the run with the models its job read and record the logged ones as its model inputs."""
    used = read_models_used(output_dir)
    if not used:
        return
    for key, value in lineage_tags(used).items():
        retry_locked(client.set_tag, run_id, key, value)
    logged = list(dict.fromkeys(model.model_id for model in used if model.model_id))
    if logged:
        retry_locked(client.log_inputs, run_id, models=[LoggedModelInput(model_id) for model_id in logged])


__all__ = [
    "MODEL_CODE",
    "PAYLOAD_MODEL_CODE",
    "PAYLOAD_NAME_SUFFIX",
    "REQUIRED_DISTRIBUTIONS",
    "LoggedIdentifiedModel",
    "log_identified_model",
    "log_job_model",
    "log_model_inputs",
    "log_payload_model",
    "pip_requirements",
]
