"""The Model Registry: a version per identification, its aliases, and ``lwrlab model``.

With ``tracking.register_model=<name>`` (``robot`` or ``true``: the robot's name) an identification
registers the model it logged as a new version of ``<name>`` (:func:`register_identified_model`).
The version's tags carry the run's headline metrics (its ``accuracy/`` section: ``accuracy/rms_mean``,
``accuracy/validation_rel_error``, …), the robot and the data it was fitted and validated on
(``datasets.identification``, ``datasets.validation``: ``name@digest``, as the run's Dataset
column shows them); its description says the same in a sentence. A payload run registers its
payload's model the same way (``robot``, ``true``: ``<robot>_payload``), its versions tagged with
the payload's ``mass`` (kg) and recognised ``tool``.

``lwrlab model alias <name> <version> <alias>`` points an alias (``champion``, ``staging``) at a
version, which every task then reads as ``models:/<name>@<alias>``; ``lwrlab model list <name>``
shows the versions with their aliases, runs and headline metrics::

    lwrlab task=identification tracking.register_model=robot          # kuka_lwr4, version 1
    lwrlab model alias kuka_lwr4 1 champion
    lwrlab task=monitor plant=log task.model=models:/kuka_lwr4@champion 'data.paths=[log.csv]'

Examples
--------
>>> registered_name("robot", "kuka_lwr4"), registered_name(True, "kuka_lwr4"), registered_name(None, "x")
('kuka_lwr4', 'kuka_lwr4', None)
>>> registered_name("lab_arm", "kuka_lwr4")
'lab_arm'
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from mlflow.entities import DatasetInput
from mlflow.exceptions import MlflowException
from mlflow.protos.databricks_pb2 import RESOURCE_ALREADY_EXISTS, ErrorCode
from mlflow.tracking import MlflowClient

from lwrlab.tracking.job_config.metric_sections import ACCURACY
from lwrlab.tracking.job_config.naming import HEADLINE_METRICS
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.store.sqlite import absolute_tracking_uri, add_tracking_uri_option, retry_locked

if TYPE_CHECKING:  # `lwrlab model` needs no pyfunc machinery
    from lwrlab.tracking.models.model_logging import LoggedIdentifiedModel

log = logging.getLogger(__name__)

ROBOT_NAME = ("robot", "true")
"""Values of ``tracking.register_model`` that mean the robot's name."""
NOT_REGISTERED = ("", "none", "null", "false")
DATASET_TAG_PREFIX = "datasets."
ROBOT_TAG = "robot"
CONTEXT_TAG = "mlflow.data.context"


def registered_name(setting: str | bool | None, robot: str) -> str | None:
    """The registered model's name ``tracking.register_model`` asks for (None: no registration)."""
    if setting is None or setting is False:
        return None
    text = str(setting).strip()
    if text.lower() in NOT_REGISTERED:
        return None
    return robot if text.lower() in ROBOT_NAME else text


def headline_tags(metrics: Mapping[str, float]) -> dict[str, str]:
    """The run's ``accuracy/`` metrics (MLflow keys), as tags of its model version."""
    return {key: f"{value:.6g}" for key, value in metrics.items() if key.startswith(f"{ACCURACY}/")}


def dataset_tags(datasets: Sequence[DatasetInput]) -> dict[str, str]:
    """``datasets.<role>``: ``name@digest`` of each dataset of that role, comma-separated."""
    roles: dict[str, list[str]] = {}
    for entry in datasets:
        role = next((tag.value for tag in entry.tags if tag.key == CONTEXT_TAG), "input")
        roles.setdefault(role, []).append(f"{entry.dataset.name}@{entry.dataset.digest}")
    return {DATASET_TAG_PREFIX + role: ", ".join(dict.fromkeys(names)) for role, names in roles.items()}


def version_description(
    robot: str, run_id: str, run_name: str, metrics: Mapping[str, float], tags: Mapping[str, str]
) -> str:
    """One paragraph: the robot, the run, the data, the headline metrics with their units."""
    fitted = tags.get(f"{DATASET_TAG_PREFIX}identification", "")
    validated = tags.get(f"{DATASET_TAG_PREFIX}validation", "")
    figures = [
        f"{name} {metrics[f'{ACCURACY}/{name}']:.4g}" + ("" if unit == "1" else f" {unit}")
        for name, (unit, _) in HEADLINE_METRICS.items()
        if f"{ACCURACY}/{name}" in metrics
    ]
    return (
        f"{robot} identified by run {run_name} ({run_id})"
        + (f", fitted on {fitted}" if fitted else "")
        + (f", validated on {validated}" if validated else "")
        + (f": {', '.join(figures)}." if figures else ".")
        + " An MLflow pyfunc model: q1…, dq1…, ddq1… (rad, rad/s, rad/s²) → tau1… (N·m)."
    )


def payload_version_description(robot: str, run_id: str, run_name: str, tags: Mapping[str, str]) -> str:
    """One paragraph: the payload's robot, its run, its data, its mass and recognised tool."""
    fitted = ", ".join(value for key, value in tags.items() if key.startswith(DATASET_TAG_PREFIX))
    tool = tags.get("tool", "")
    return (
        f"A payload at the flange of {robot} identified by run {run_name} ({run_id})"
        + (f" from {fitted}" if fitted else "")
        + (f": {tags['mass']} kg" if "mass" in tags else "")
        + (f", recognised as {tool}" if tool else "")
        + ". An MLflow pyfunc model: q1…, dq1…, ddq1… (rad, rad/s, rad/s²) → tau1… (N·m), the torques"
        " the payload adds at the joints."
    )


def _ensure_registered_model(client: MlflowClient, name: str, robot: str, kind: str) -> None:
    what = (
        f"Payloads at the flange of {robot} identified by lwrlab, one version per payload run; "
        "each version's tags hold the payload's mass and recognised tool."
        if kind == "payload"
        else f"Dynamic models of {robot} identified by lwrlab, one version per identification; "
        "each version's tags hold its run's headline metrics and datasets."
    )
    try:
        retry_locked(client.create_registered_model, name, description=what)
    except MlflowException as error:  # another job created it first: fine
        if error.error_code != ErrorCode.Name(RESOURCE_ALREADY_EXISTS):
            raise


def register_identified_model(
    client: MlflowClient,
    name: str,
    logged: LoggedIdentifiedModel,
    run_id: str,
    run_name: str,
    metrics: Mapping[str, float],
    datasets: Sequence[DatasetInput],
) -> str:
    """Register ``logged`` as a new version of ``name`` (created if missing); returns the version."""
    _ensure_registered_model(client, name, logged.robot, logged.kind)
    tags = {ROBOT_TAG: logged.robot, **logged.tags, **headline_tags(metrics), **dataset_tags(datasets)}
    description = (
        payload_version_description(logged.robot, run_id, run_name, tags)
        if logged.kind == "payload"
        else version_description(logged.robot, run_id, run_name, metrics, tags)
    )
    version = retry_locked(
        client.create_model_version,
        name,
        logged.model_uri,
        run_id=run_id,
        tags=tags,
        description=description,
        model_id=logged.model_id,
    )
    log.info(
        "model registered as %s version %s (models:/%s/%s)", name, version.version, name, version.version
    )
    return str(version.version)


def log_and_register(
    client: MlflowClient,
    run_id: str,
    output_dir: Path,
    tracking_uri: str,
    setting: str | bool | None,
    run_name: str,
    metrics: Mapping[str, float],
    datasets: Sequence[DatasetInput],
) -> LoggedIdentifiedModel | None:
    """Log the model a job identified (a robot or a payload) as its run's MLflow Model, and register
    it where ``setting`` (the job's ``tracking.register_model``) says; None: the job identified none."""
    from lwrlab.tracking.models.model_logging import log_job_model

    logged = log_job_model(client, run_id, output_dir, tracking_uri)
    name = None if logged is None else registered_name(setting, logged.default_name)
    if logged is not None and name is not None:
        register_identified_model(client, name, logged, run_id, run_name, metrics, datasets)
    return logged


# -- lwrlab model ---------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``lwrlab model``."""
    parser = argparse.ArgumentParser(
        prog="lwrlab model",
        description="Registered identified models: point an alias at a version, list the versions.",
    )
    store = argparse.ArgumentParser(add_help=False)
    add_tracking_uri_option(store)
    commands = parser.add_subparsers(dest="command", required=True, metavar="{alias,list}")
    alias = commands.add_parser(
        "alias",
        parents=[store],
        help="point an alias (champion, staging) at a version: tasks read models:/<name>@<alias>",
        description="Point ALIAS at VERSION of the registered model NAME (moved from any other version).",
    )
    alias.add_argument("name", help="registered model name")
    alias.add_argument("version", help="version number")
    alias.add_argument("alias", help="alias, e.g. champion or staging")
    listed = commands.add_parser(
        "list",
        parents=[store],
        help="the versions of a registered model: aliases, runs, headline metrics",
        description="The versions of NAME, newest first, with their aliases, runs and headline metrics.",
    )
    listed.add_argument("name", help="registered model name")
    return parser


def set_alias(client: MlflowClient, name: str, version: str, alias: str) -> None:
    """Point ``alias`` at ``version`` of ``name`` (raises ``MlflowException`` naming what is missing)."""
    retry_locked(client.get_model_version, name, version)  # a clear error for a missing version
    retry_locked(client.set_registered_model_alias, name, alias, version)


def version_lines(client: MlflowClient, name: str) -> list[str]:
    """One line per version of ``name``, newest first: version, aliases, run, headline metrics."""
    registered = retry_locked(client.get_registered_model, name)
    aliases: dict[str, list[str]] = {}
    for alias, version in (registered.aliases or {}).items():
        aliases.setdefault(str(version), []).append(alias)
    found = retry_locked(client.search_model_versions, f"name = '{name}'")
    lines = []
    for version in sorted(found, key=lambda v: int(v.version), reverse=True):
        shown = " ".join(
            f"{key.removeprefix(f'{ACCURACY}/')}={value}"
            for key, value in sorted(version.tags.items())
            if key.startswith(f"{ACCURACY}/")
        )
        named = ",".join(sorted(aliases.get(str(version.version), []))) or "-"
        lines.append(f"{version.version}\t@{named}\trun {version.run_id}\t{shown}")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """``lwrlab model alias|list ...``; returns the process exit status."""
    parser = build_parser()
    arguments = parser.parse_args(argv)
    uri = absolute_tracking_uri(arguments.tracking_uri, Path.cwd())
    client = MlflowClient(tracking_uri=uri)
    try:
        if arguments.command == "alias":
            set_alias(client, arguments.name, arguments.version, arguments.alias)
            print(
                f"{arguments.name} version {arguments.version} is @{arguments.alias}: "
                f"models:/{arguments.name}@{arguments.alias}"
            )
        else:
            lines = version_lines(client, arguments.name)
            print(f"{arguments.name}: {len(lines)} version(s)")
            print("\n".join(lines))
    except (MlflowException, OSError) as error:  # an unknown model or version, an unreachable store
        parser.error(Redactor().redact(str(error).splitlines()[0]))
    return 0


__all__ = [
    "build_parser",
    "dataset_tags",
    "headline_tags",
    "main",
    "payload_version_description",
    "register_identified_model",
    "registered_name",
    "set_alias",
    "version_description",
    "version_lines",
]
