"""A model setting resolved to a local ``identified_model.yaml``: a path, or any MLflow model URI.

Every setting that reads an identified model (``task.model``, ``robot.source``,
``task.unloaded_model``) takes

* a file ``identified_model.yaml`` or the run folder holding it;
* ``runs:/<run id>/model``: the model an identification logged (or ``runs:/<run id>/<file>``: a
  file among the run's artifacts);
* ``models:/<name>/<version>``, ``models:/<name>@<alias>``: a version of a registered model;
  ``models:/<model id>``: a logged model by its id;
* a bare run id (32 hex digits): that run's model, or the ``identified_model.yaml`` among its
  artifacts (runs logged before models were).

:func:`resolve_model` downloads what a URI names into a temporary folder (removed at exit) and
returns the local file with its lineage (:class:`ResolvedModel`: run id, logged model id,
registered name and version). The store is the job's (``tracking.uri``), or ``MLFLOW_TRACKING_URI``
where the job has none. A source that does not resolve raises :class:`ModelNotFoundError`, one line
naming the setting and the source. MLflow is imported only when a URI is looked up: a job given a
file starts as fast as before.

Each model resolved in this process is remembered (:func:`models_used`); the entry point writes
them into the job's output folder (:data:`MODEL_INPUTS_FILE`), from which the tracking callback
tags the job's run and records the models as its inputs (MLflow's lineage).

Examples
--------
>>> is_model_uri("models:/kuka_lwr4@champion"), is_model_uri("runs:/0123/model")
(True, True)
>>> is_model_uri("0123456789abcdef0123456789abcdef"), is_model_uri("outputs/runs/x/identified_model.yaml")
(True, False)
>>> model_reference("models:/kuka_lwr4@champion")
('models:/kuka_lwr4@champion', 'kuka_lwr4', None, 'champion')
"""

from __future__ import annotations

import atexit
import json
import os
import re
import shutil
import tempfile
import urllib.parse
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from lwrlab.errors import MissingFileError
from lwrlab.tracking.store.sqlite import absolute_tracking_uri, sqlite_database_path

MODEL_NAME = "model"
"""The name (artifact path) of the model every identification run logs: ``runs:/<run id>/model``."""
MODEL_INPUTS_FILE = "model_inputs.json"
"""The models a job read, written into its output folder for the tracking callback."""
MODEL_TAG_PREFIX = "lwrlab.model_"
"""Run tags of the model a job read: ``lwrlab.model_uri``, ``…_run_id``, ``…_name``, ``…_version``,
``…_id``."""

_RUN_ID = re.compile(r"^[0-9a-f]{32}$")
_URI_SCHEMES = ("runs:/", "models:/")
_used: list[ResolvedModel] = []
_download_folders: list[str] = []


class ModelNotFoundError(MissingFileError):
    """A model setting whose path or MLflow URI does not resolve; the message names both (and the store)."""


@dataclass(frozen=True)
class ResolvedModel:
    """A model setting resolved: the local file and where it came from."""

    source: str
    """The setting's value as given (a path, a URI, a run id)."""
    path: Path
    """The local ``identified_model.yaml``."""
    run_id: str | None = None
    """The MLflow run that identified it (None: a local file)."""
    model_id: str | None = None
    """MLflow's logged model id (None: a local file, or a run logged before models were)."""
    name: str | None = None
    """The registered model's name, for a ``models:/<name>…`` URI."""
    version: str | None = None
    """The registered model's version, for a ``models:/<name>…`` URI."""
    tracking_uri: str | None = None
    """The store it was looked up in (None: a local file)."""

    def tags(self) -> dict[str, str]:
        """The run tags of a job that read this model (only those known)."""
        values = {
            "uri": self.source,
            "run_id": self.run_id,
            "id": self.model_id,
            "name": self.name,
            "version": self.version,
        }
        return {MODEL_TAG_PREFIX + key: value for key, value in values.items() if value}

    def run_file(self, name: str) -> Path | None:
        """The file ``name`` of the run that identified the model (``.hydra/config.yaml``,
        ``measurement.npz``): beside a local file, else downloaded from the run's artifacts; None
        where there is none."""
        if self.run_id is None:
            local = self.path.parent / name
            return local if local.is_file() else None
        try:
            return _download(f"runs:/{self.run_id}/{name}", self.tracking_uri)
        except _LookupFailed:
            return None


class _LookupFailed(Exception):
    """A look-up in the store found nothing (the caller says what was looked for)."""


def is_model_uri(source: str) -> bool:
    """Whether ``source`` names a model in MLflow (a URI or a bare run id) rather than a path."""
    text = str(source).strip()
    return text.startswith(_URI_SCHEMES) or bool(_RUN_ID.match(text))


def model_reference(uri: str) -> tuple[str, str | None, str | None, str | None]:
    """``(uri, name, version, alias)`` of a ``models:/`` URI (name None: ``models:/<model id>``)."""
    path = uri[len("models:/") :].strip("/")
    if "@" in path:
        name, alias = path.rsplit("@", 1)
        return uri, name, None, alias
    if "/" in path:
        name, version = path.rsplit("/", 1)
        return uri, name, version, None
    return uri, None, None, None


def _shown(tracking_uri: str | None) -> str:
    """The store, for a message: its URI without a password, or MLflow's default."""
    uri = tracking_uri or os.environ.get("MLFLOW_TRACKING_URI")
    if not uri:
        return "MLflow's default store (no tracking.uri, no MLFLOW_TRACKING_URI)"
    parts = urllib.parse.urlsplit(uri)
    if parts.password is not None:
        netloc = (parts.hostname or "") + (f":{parts.port}" if parts.port is not None else "")
        uri = urllib.parse.urlunsplit((parts.scheme, netloc, parts.path, parts.query, parts.fragment))
    return f"the MLflow store {uri}"


def _store_uris(tracking_uri: str | None) -> tuple[str, str]:
    """The tracking and registry URIs a look-up uses: ``tracking_uri``, else ``MLFLOW_TRACKING_URI``,
    else MLflow's default; the registry is the same store unless ``MLFLOW_REGISTRY_URI`` says
    otherwise. Read, never set: the process's environment and MLflow's globals stay as they are."""
    import mlflow  # only when a URI is looked up: a job given a file never imports MLflow

    uri = tracking_uri or os.environ.get("MLFLOW_TRACKING_URI") or mlflow.get_tracking_uri()
    return uri, os.environ.get("MLFLOW_REGISTRY_URI") or uri


@contextmanager
def _store(tracking_uri: str | None) -> Iterator[Any]:
    """An MLflow client of the store with explicit tracking and registry URIs (:func:`_store_uris`);
    a store error becomes :class:`_LookupFailed`."""
    import mlflow
    from mlflow.exceptions import MlflowException

    uri, registry = _store_uris(tracking_uri)
    database = sqlite_database_path(uri)
    if database is not None and not database.is_file():  # looking would create an empty store
        raise _LookupFailed(f"the store {database} does not exist")
    try:
        yield mlflow.MlflowClient(tracking_uri=uri, registry_uri=registry)
    except (MlflowException, OSError) as error:
        raise _LookupFailed(str(error).splitlines()[0] if str(error) else type(error).__name__) from error


def _download_folder() -> str:
    folder = tempfile.mkdtemp(prefix="lwrlab-model-")
    if not _download_folders:
        atexit.register(_remove_download_folders)
    _download_folders.append(folder)
    return folder


def _remove_download_folders() -> None:
    while _download_folders:
        shutil.rmtree(_download_folders.pop(), ignore_errors=True)


def _download(artifact_uri: str, tracking_uri: str | None) -> Path:
    """Download ``artifact_uri`` (a file or folder) into a new temporary folder; its local path."""
    import mlflow.artifacts

    uri, registry = _store_uris(tracking_uri)
    with _store(tracking_uri):
        local = mlflow.artifacts.download_artifacts(
            artifact_uri=artifact_uri, dst_path=_download_folder(), tracking_uri=uri, registry_uri=registry
        )
    return Path(local)


def _model_file(local: Path) -> Path:
    """The ``identified_model.yaml`` of a downloaded model folder (an MLflow Model keeps it among its
    ``artifacts/``), or the downloaded file itself."""
    from lwrlab.io.artifacts import IDENTIFIED_MODEL_FILE

    for candidate in (local, local / IDENTIFIED_MODEL_FILE, local / "artifacts" / IDENTIFIED_MODEL_FILE):
        if candidate.is_file():
            return candidate
    raise _LookupFailed(f"it holds no {IDENTIFIED_MODEL_FILE}")


def _logged_model_of(source: str) -> str | None:
    """The logged model id a version's source ``models:/<model id>`` names, or None."""
    if not source.startswith("models:/"):
        return None
    _, name, _, _ = model_reference(source)
    return source[len("models:/") :].strip("/") if name is None else None


def _logged_model_id(client: Any, run_id: str, name: str) -> str | None:
    """The id of the model ``name`` that run ``run_id`` logged, or None."""
    experiment_id = client.get_run(run_id).info.experiment_id
    for model in client.search_logged_models([experiment_id], filter_string=f"name = '{name}'"):
        if model.source_run_id == run_id:
            return str(model.model_id)
    return None


def _from_run(source: str, run_id: str, artifact_path: str, tracking_uri: str | None) -> ResolvedModel:
    from lwrlab.io.artifacts import IDENTIFIED_MODEL_FILE

    name, _, inside = artifact_path.partition("/")
    with _store(tracking_uri) as client:
        model_id = _logged_model_id(client, run_id, name)
        # a logged model's files, where this client says they are (MLflow's runs:/ download looks a
        # logged model up in the process's global store instead)
        location = None if model_id is None else client.get_logged_model(model_id).artifact_location
    if model_id is None and artifact_path == MODEL_NAME and _RUN_ID.match(source.strip()):
        artifact_path = IDENTIFIED_MODEL_FILE  # a bare run id logged before models were
    download = f"runs:/{run_id}/{artifact_path}" if location is None else f"{location}/{inside}".rstrip("/")
    path = _model_file(_download(download, tracking_uri))
    return ResolvedModel(source, path, run_id, model_id, tracking_uri=tracking_uri)


def _from_registry(source: str, tracking_uri: str | None) -> ResolvedModel:
    _, name, version, alias = model_reference(source)
    with _store(tracking_uri) as client:
        if name is None:  # models:/<model id>
            logged = client.get_logged_model(source[len("models:/") :].strip("/"))
            run_id, model_id, download = logged.source_run_id, logged.model_id, logged.artifact_location
        else:
            found = (
                client.get_model_version_by_alias(name, alias)
                if alias is not None
                else client.get_model_version(name, version)
            )
            run_id, version = found.run_id, str(found.version)
            # a version of a logged model points to it (``models:/<model id>``)
            model_id = found.model_id or _logged_model_of(str(found.source or ""))
            # where its files are, asked of this client: MLflow's own models:/ download would ask
            # the process's global registry instead
            download = client.get_model_version_download_uri(name, version)
    path = _model_file(_download(download, tracking_uri))
    return ResolvedModel(source, path, run_id or None, model_id or None, name, version, tracking_uri)


def resolve_model(
    source: str | Path, tracking_uri: str | None = None, setting: str = "task.model"
) -> ResolvedModel:
    """The ``identified_model.yaml`` that ``source`` names, with its lineage (see the module docstring).

    Parameters
    ----------
    source
        A path, a run folder, ``runs:/<run id>/model``, ``models:/<name>/<version>``,
        ``models:/<name>@<alias>``, ``models:/<model id>`` or a bare run id.
    tracking_uri
        The store a URI is looked up in (a relative SQLite path is taken from the working folder);
        None: ``MLFLOW_TRACKING_URI`` or MLflow's default.
    setting
        The setting that gave ``source``, named by the error.

    Raises
    ------
    ModelNotFoundError
        When ``source`` does not resolve: no such file, run, model, version or alias.
    """
    from lwrlab.io.artifacts import identified_model_path  # the core's file reader: with the first model

    text = str(source).strip()
    uri = None if tracking_uri in (None, "") else absolute_tracking_uri(str(tracking_uri), Path.cwd())
    local = Path(text).expanduser()
    try:
        if local.exists() or not is_model_uri(text):
            resolved = ResolvedModel(str(local.resolve()), identified_model_path(local).resolve())
        elif text.startswith("models:/"):
            resolved = _from_registry(text, uri)
        elif text.startswith("runs:/"):
            run_id, _, artifact_path = text[len("runs:/") :].partition("/")
            resolved = _from_run(text, run_id, artifact_path.strip("/") or MODEL_NAME, uri)
        else:
            resolved = _from_run(text, text, MODEL_NAME, uri)
    except MissingFileError as error:
        raise ModelNotFoundError(f"{setting}={text}: {error}") from error
    except _LookupFailed as error:
        raise ModelNotFoundError(
            f"{setting}={text}: no identified model there in {_shown(uri)} ({error})"
        ) from error
    if all(used.source != resolved.source for used in _used):
        _used.append(resolved)
    return resolved


def identified_model_file(source: str, tracking_uri: str | None = None) -> Path:
    """The local ``identified_model.yaml`` of ``robot.source`` (what ``robot=identified`` is handed)."""
    return resolve_model(source, tracking_uri, setting="robot.source").path


def models_used() -> list[ResolvedModel]:
    """The models this process resolved since :func:`forget_models_used`, first first."""
    return list(_used)


def forget_models_used() -> None:
    """Start a new job: no model used yet."""
    _used.clear()


def write_models_used(output_dir: Path) -> Path | None:
    """Write :func:`models_used` into ``output_dir``/:data:`MODEL_INPUTS_FILE` (None: none used)."""
    if not _used:
        return None
    output_dir.mkdir(parents=True, exist_ok=True)
    path = output_dir / MODEL_INPUTS_FILE
    records = [{**asdict(used), "path": str(used.path)} for used in _used]
    path.write_text(json.dumps(records, indent=2) + "\n", encoding="utf-8")
    return path


def read_models_used(output_dir: Path) -> list[ResolvedModel]:
    """The models a job wrote into its output folder (none: an empty list)."""
    path = output_dir / MODEL_INPUTS_FILE
    if not path.is_file():
        return []
    records: list[Mapping[str, Any]] = json.loads(path.read_text(encoding="utf-8"))
    return [ResolvedModel(**{**record, "path": Path(str(record["path"]))}) for record in records]


def lineage_tags(models: list[ResolvedModel]) -> dict[str, str]:
    """The run tags of the models a job read (several models: their values joined by ``, ``)."""
    joined: dict[str, list[str]] = {}
    for model in models:
        for key, value in model.tags().items():
            joined.setdefault(key, []).append(value)
    return {key: ", ".join(values) for key, values in joined.items()}


__all__ = [
    "MODEL_INPUTS_FILE",
    "MODEL_NAME",
    "MODEL_TAG_PREFIX",
    "ModelNotFoundError",
    "ResolvedModel",
    "forget_models_used",
    "identified_model_file",
    "is_model_uri",
    "lineage_tags",
    "model_reference",
    "models_used",
    "read_models_used",
    "resolve_model",
    "write_models_used",
]
