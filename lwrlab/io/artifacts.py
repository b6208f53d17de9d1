"""Artifact files: Parquet for long series, CSV for what a robot or a spreadsheet reads, YAML for models,
npz for exactness.

Nothing here unpickles: npz files are read with ``allow_pickle=False`` and YAML with a safe loader
(libyaml's ``CSafeLoader`` where there is one).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from lwrlab.errors import MissingFileError
from lwrlab.identification.identified import IdentifiedModel
from lwrlab.plants.core import Measurement
from lwrlab.trajectory.core import Trajectory
from lwrlab.yaml_files import safe_yaml


def _joint_columns(prefix: str, n: int) -> list[str]:
    return [f"{prefix}{j}" for j in range(1, n + 1)]


def trajectory_frame(trajectory: Trajectory) -> pd.DataFrame:
    """Columns ``t`` (s), ``q1…`` (rad), ``dq1…`` (rad/s), ``ddq1…`` (rad/s²)."""
    n = trajectory.q.shape[1]
    data = {"t": trajectory.t}
    for prefix, array in (("q", trajectory.q), ("dq", trajectory.dq), ("ddq", trajectory.ddq)):
        data.update(dict(zip(_joint_columns(prefix, n), array.T, strict=True)))
    return pd.DataFrame(data)


CSV_FLOAT_FORMAT = "%.10g"
"""How a motion's CSV writes its values (ten significant digits: a 1 kHz motion's time and angles)."""


def save_trajectory_csv(trajectory: Trajectory, path: Path) -> Path:
    """Write the motion as CSV (one row per sample), playable by a robot controller.

    The text ``DataFrame.to_csv(index=False, float_format=CSV_FLOAT_FORMAT)`` writes, formatted a row
    at a time (a fifth of the time pandas takes cell by cell: 0.05 s for a 10 s, 1 kHz motion).
    """
    frame = trajectory_frame(trajectory)
    values = frame.to_numpy(dtype=float)
    if np.isnan(values).any():  # pandas writes a missing value as an empty field
        frame.to_csv(path, index=False, float_format=CSV_FLOAT_FORMAT)
        return path
    row = ",".join([CSV_FLOAT_FORMAT] * values.shape[1]) + os.linesep
    with open(path, "w", encoding="utf-8", newline="") as file:
        file.write(",".join(frame.columns) + os.linesep)
        file.writelines(row % tuple(sample) for sample in values.tolist())
    return path


def save_trajectory(trajectory: Trajectory, path: Path) -> Path:
    """Write the motion by suffix: Parquet (exact, ~10× smaller and faster than CSV at 1 kHz) or CSV."""
    if path.suffix.lower() == ".csv":
        return save_trajectory_csv(trajectory, path)
    trajectory_frame(trajectory).to_parquet(path, index=False)
    return path


def save_measurement(measurement: Measurement, path: Path) -> Path:
    """Write a measurement as npz (t, q, tau, and the metadata as a YAML string)."""
    np.savez_compressed(
        path,
        t=measurement.t,
        q=measurement.q,
        tau=measurement.tau,
        metadata=yaml.safe_dump(measurement.metadata),
    )
    return path


IDENTIFIED_MODEL_FILE = "identified_model.yaml"
"""File name of an identified model in a run folder (and as an MLflow artifact)."""
MODEL_INPUT_EXAMPLE_FILE = "model_input_example.csv"
"""A few consecutive states of the fit's motion (``t, q1…, dq1…, ddq1…``) beside the identified model:
the input example of the model an identification logs to MLflow."""


def identified_model_path(source: str | Path) -> Path:
    """The ``identified_model.yaml`` at ``source``: the file itself, or the run folder holding it.

    Raises ``FileNotFoundError`` naming the path when there is no such file.
    """
    path = Path(source).expanduser()
    if path.is_dir():
        path = path / IDENTIFIED_MODEL_FILE
    if not path.is_file():
        raise MissingFileError(f"identified model {path} does not exist")
    return path


class _FlowRow(list[float]):
    """A row of numbers written on one line (``[a, b, …]``): a matrix stays one line per row."""


class _ModelDumper(yaml.SafeDumper):
    """``yaml.safe_dump`` with :class:`_FlowRow` rows in flow style."""


_ModelDumper.add_representer(
    _FlowRow, lambda dumper, row: dumper.represent_sequence("tag:yaml.org,2002:seq", row, flow_style=True)
)


def _source(model: IdentifiedModel, index: int) -> dict[str, Any]:
    """Where base parameter ``index`` comes from, for a model fitted with a prior: ``from`` (``data`` or
    ``prior``, :data:`~lwrlab.identification.prior_weight.PRIOR_DOMINATED_SHARE`) and ``prior_share``."""
    if model.prior_share is None:
        return {}
    from lwrlab.identification.prior_weight import PRIOR_DOMINATED_SHARE

    share = float(model.prior_share[index])
    return {"from": "prior" if share > PRIOR_DOMINATED_SHARE else "data", "prior_share": share}


def save_identified_model(model: IdentifiedModel, robot_config: dict[str, Any], path: Path) -> Path:
    """Write an identified model as YAML, with the robot description it refines (to rebuild it), and,
    when the model has them, its base parameters' covariance and the noise it was fitted with (key
    ``information``: what a next exciting motion is designed with) and its friction drift (key
    ``friction_drift``: value and source, what a monitor's thresholds may cover)."""
    document = {
        "robot": robot_config,
        "base_parameters": {
            name: {"value": float(v), "std": float(s), **_source(model, i)}
            for i, (name, v, s) in enumerate(
                zip(model.base_names, model.base_values, model.base_std, strict=True)
            )
        },
        "standard_parameters": {
            name: float(v) for name, v in zip(model.standard_names, model.standard_values, strict=True)
        },
    }
    if model.base_covariance is not None and model.noise_density is not None:
        # what the next exciting motion is designed with (task=excitation task.known_model=…)
        document["information"] = {
            "covariance": [_FlowRow(float(v) for v in row) for row in model.base_covariance],
            "noise_density": _FlowRow(float(v) for v in model.noise_density),
        }
    if model.friction_drift is not None:
        # how far friction differs between runs: what a monitor's thresholds may cover (task.friction_drift)
        document["friction_drift"] = {
            "value": float(model.friction_drift),
            "source": model.friction_drift_source,
        }
    path.write_text(yaml.dump(document, Dumper=_ModelDumper, sort_keys=False))
    return path


def load_identified_model(path: Path) -> tuple[IdentifiedModel, dict[str, Any]]:
    """Read an identified model and its robot description written by :func:`save_identified_model`."""
    document = safe_yaml(Path(path).read_text())
    missing = {"robot", "base_parameters", "standard_parameters"} - set(document or {})
    if missing:
        raise ValueError(f"{path}: not an identified model, missing keys {sorted(missing)}")
    base, standard = document["base_parameters"], document["standard_parameters"]
    information = document.get("information") or {}
    drift = document.get("friction_drift") or {}
    model = IdentifiedModel(
        base_names=tuple(base),
        base_values=np.array([entry["value"] for entry in base.values()]),
        base_std=np.array([entry["std"] for entry in base.values()]),
        standard_names=tuple(standard),
        standard_values=np.array(list(standard.values()), dtype=float),
        base_covariance=np.array(information["covariance"], dtype=float) if information else None,
        noise_density=np.array(information["noise_density"], dtype=float) if information else None,
        friction_drift=float(drift["value"]) if drift else None,
        friction_drift_source=str(drift.get("source")) if drift else None,
        prior_share=(
            np.array([entry["prior_share"] for entry in base.values()], dtype=float)
            if all("prior_share" in entry for entry in base.values()) and base
            else None
        ),
    )
    return model, document["robot"]
