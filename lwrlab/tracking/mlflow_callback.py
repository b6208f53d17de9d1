"""MLflow tracking of Hydra jobs, as a Hydra callback: params, tags, metrics, artifacts and status.

The numeric core never imports mlflow. A job only returns its metrics and writes its artifacts into the
Hydra job output directory; this callback, enabled by the ``tracking`` config group, turns each Hydra
job into one MLflow run:

* ``on_job_start``: experiment (created if missing, as a model-development experiment with a
  description of the headline metrics), run named by what differs (``wls · seed=1``), the flattened
  resolved config and the short name of every plugin choice (``estimator=wls``) as params,
  provenance tags (overrides, git commit, config hash, seed, library versions, pid and hostname).
* ``on_job_end``: numeric metrics from the return value, the whole job output directory as artifacts,
  and the run status (FINISHED, or FAILED with the error and ``error.txt``).
* a Hydra multirun becomes a parent run with one nested run per job.
* SIGINT and SIGTERM end the runs KILLED, with what the job wrote uploaded (see ``_on_stop_signal``);
  a resumed sweep or a new job ends KILLED the runs a dead process of this host left RUNNING.

Tracking problems never hide the job's own result: they are logged once as a warning and the job
goes on untracked.

Examples
--------
Select it from the command line (``tracking: sqlite`` is the default of ``conf/config.yaml``)::

    lwrlab tracking=sqlite experiment_name=identification
    lwrlab tracking=server hydra.callbacks.mlflow.tracking_uri=http://host:5000
    lwrlab tracking=none

and compare runs afterwards:

>>> from lwrlab.tracking import runs_table  # doctest: +SKIP
>>> runs_table("sqlite:///outputs/mlflow.db", "identification", "metrics.rms_mean < 0.5")  # doctest: +SKIP
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import getpass
import hashlib
import json
import logging
import multiprocessing
import numbers
import os
import platform
import re
import signal
import socket
import subprocess
import sys
import time
import traceback
import urllib.parse
import urllib.request
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any, TypeVar

import mlflow
import pandas as pd
from hydra.core.utils import JobReturn, JobStatus
from hydra.experimental.callback import Callback
from hydra.utils import get_class
from mlflow.entities import Metric, Param, Run
from mlflow.exceptions import MlflowException
from mlflow.tracking import MlflowClient
from mlflow.utils import validation as mlflow_limits
from omegaconf import DictConfig, OmegaConf

import lwrlab
from lwrlab.tracking import job_state, offline
from lwrlab.tracking.finalise import (
    KILLED_BY_TAG,
    end_killed,
    finalise_children,
    finalise_stale_runs,
    running_runs,
)
from lwrlab.tracking.naming import (
    DESCRIPTION_TAG,
    EXPERIMENT_KIND,
    EXPERIMENT_KIND_TAG,
    NAME_SEPARATOR,
    experiment_description,
    log_file_stem,
    plugin_choices,
    run_name,
    runtime_choices,
    swept_keys,
)
from lwrlab.tracking.processes import (
    HOSTNAME_TAG,
    PID_TAG,
    JobInterrupted,
    install_stop_handler,
    process_alive,
    process_tags,
    restore_handlers,
    send_signal,
    signal_name,
    terminate_processes,
    wait_until,
    worker_pids,
)
from lwrlab.tracking.redaction import Redactor, redacted_folder
from lwrlab.tracking.store import prepare_sqlite_store, retry_locked, store_lock

log = logging.getLogger(__name__)

# MLflow's own limits, read from the installed version (with mlflow 3's values as fallbacks).
PARAM_VALUE_MAX_LENGTH: int = getattr(mlflow_limits, "MAX_PARAM_VAL_LENGTH", 6000)
TAG_VALUE_MAX_LENGTH: int = getattr(mlflow_limits, "MAX_TAG_VAL_LENGTH", 8000)
KEY_MAX_LENGTH: int = getattr(mlflow_limits, "MAX_ENTITY_KEY_LENGTH", 250)
PARAMS_PER_BATCH: int = getattr(mlflow_limits, "MAX_PARAMS_TAGS_PER_BATCH", 100)
METRICS_PER_BATCH: int = getattr(mlflow_limits, "MAX_METRICS_PER_BATCH", 1000)
RUN_NAME_MAX_LENGTH = 250  # the runs.name column of MLflow's SQL stores
ERROR_TAG_MAX_LENGTH = 1000  # a readable summary; the full traceback goes to error.txt

RUN_ID_FILE = "mlflow_run_id.txt"
ERROR_FILE = "error.txt"
JOB_TAGS_FILE = "tags.json"
"""Tags a stage asks for (written into its output folder): set on the run before it ends."""
RESUMED_FILE = "resumed_from_run.txt"  # written instead of a new run when a sweep job already finished
# Config keys that say where a run is logged, not what it computes: left out of the config hash.
NOT_HASHED_KEYS = frozenset({"tracking"})
RUN_KIND_TAG = "run_kind"  # "job" or "sweep": filter with runs_table(..., "tags.run_kind = 'job'")
# After a stop signal, how long a sweep's launching process lets its workers end their own runs
# (upload what they wrote, mark KILLED) before it terminates them and ends what is left.
STOP_GRACE_S = 30.0
# Then how long a worker process gets between SIGTERM and SIGKILL.
KILL_GRACE_S = 3.0

# Characters MLflow accepts in param and metric keys (mlflow.utils.validation, POSIX flavour).
_INVALID_KEY_CHARACTERS = re.compile(r"[^/\w.\- :]")
# Tracking URIs without "://" that are not file paths.
_BARE_URI_SCHEMES = frozenset({"databricks", "databricks-uc", "uc"})
_STATUS_OF_JOB = {JobStatus.COMPLETED: "FINISHED", JobStatus.FAILED: "FAILED", JobStatus.UNKNOWN: "KILLED"}

Item = TypeVar("Item")


# ---------------------------------------------------------------------------------------------
# Pure helpers (no MLflow calls): config → params, return value → metrics, URIs.
# ---------------------------------------------------------------------------------------------


def truncate(text: str, max_length: int) -> str:
    """Cut ``text`` to ``max_length`` characters, ending with ``...`` when it was cut."""
    return text if len(text) <= max_length else text[: max_length - 3] + "..."


def mlflow_key(name: str) -> str:
    """Turn ``name`` into a valid MLflow param/metric key (bad characters become ``_``)."""
    return _INVALID_KEY_CHARACTERS.sub("_", name)[:KEY_MAX_LENGTH]


def flatten_config(node: Any, prefix: str = "") -> dict[str, str]:
    """Flatten a nested config into MLflow params.

    Parameters
    ----------
    node
        A plain container (as from ``OmegaConf.to_container(cfg, resolve=True)``).
    prefix
        Key of ``node`` itself; nested keys are joined to it with dots.

    Returns
    -------
    dict[str, str]
        ``{"robot.dof": "7", "trajectory.harmonics": "[1, 2, 3]", ...}``: lists as JSON strings,
        every value cut to MLflow's param length limit (``PARAM_VALUE_MAX_LENGTH``).

    Examples
    --------
    >>> flatten_config({"robot": {"dof": 7, "q_max": [1.0, 2.0]}, "seed": 0})
    {'robot.dof': '7', 'robot.q_max': '[1.0, 2.0]', 'seed': '0'}
    """
    if isinstance(node, Mapping):
        flat: dict[str, str] = {}
        if not node and prefix:
            flat[prefix] = "{}"  # keep the key visible even when its node is empty
        for key, value in node.items():
            flat.update(flatten_config(value, f"{prefix}.{key}" if prefix else str(key)))
        return flat
    if isinstance(node, (list, tuple)):
        text = json.dumps(node, default=str)
    else:
        text = str(node)
    return {prefix: truncate(text, PARAM_VALUE_MAX_LENGTH)} if prefix else {}


def resolved_job_config(config: DictConfig) -> dict[str, Any]:
    """The job's config without the ``hydra`` node, resolved into plain containers.

    A key whose interpolation cannot be resolved is kept unresolved rather than failing the run.
    """
    resolved: dict[str, Any] = {}
    for key in config.keys():
        if key == "hydra":
            continue
        try:
            value = config[key]
            resolved[str(key)] = (
                OmegaConf.to_container(value, resolve=True) if OmegaConf.is_config(value) else value
            )
        except Exception:  # an unresolvable interpolation: log it as written
            raw = OmegaConf.to_container(config, resolve=False)
            assert isinstance(raw, dict)
            resolved[str(key)] = raw[key]
    return resolved


def config_hash(resolved_config: Mapping[str, Any]) -> str:
    """SHA-256 of the resolved config as YAML, keys sorted (so reordering defaults keeps the hash).

    The ``tracking`` node (where the run is logged) is left out: the hash names the computation, so a
    re-launched sweep recognises its finished jobs whatever store they went to.
    """
    kept = {key: value for key, value in resolved_config.items() if key not in NOT_HASHED_KEYS}
    text = OmegaConf.to_yaml(OmegaConf.create(kept), sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _numeric_leaves(value: Any, key: str) -> Iterator[tuple[str, float]]:
    if isinstance(value, (str, bytes, bool)) or value is None:
        return
    if hasattr(value, "tolist") and not isinstance(value, numbers.Real):
        value = value.tolist()  # numpy arrays (and 0-d arrays) → lists (or a scalar)
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        yield key, float(value)
    elif isinstance(value, Mapping):
        for sub_key, sub_value in value.items():
            yield from _numeric_leaves(sub_value, f"{key}.{sub_key}" if key else str(sub_key))
    elif isinstance(value, Sequence):
        for index, item in enumerate(value):
            yield from _numeric_leaves(item, f"{key}.{index}" if key else str(index))


def numeric_metrics(return_value: Any) -> dict[str, float]:
    """The metrics to log from a task function's return value.

    Parameters
    ----------
    return_value
        ``{"metrics": {...}, ...}`` (only the ``metrics`` entry is used), or a dict of metrics, or a
        single number (logged as ``return_value``, what a Hydra sweeper optimises).

    Returns
    -------
    dict[str, float]
        Every numeric leaf; nested keys joined by dots, sequence items by index
        (``rms.0``, ``rms.1``…); strings, booleans and ``None`` are skipped.

    Examples
    --------
    >>> numeric_metrics({"metrics": {"rms_mean": 0.2, "rms": [0.1, 0.3]}, "report": "text"})
    {'rms_mean': 0.2, 'rms.0': 0.1, 'rms.1': 0.3}
    """
    if isinstance(return_value, Mapping) and isinstance(return_value.get("metrics"), Mapping):
        return_value = return_value["metrics"]
    if isinstance(return_value, numbers.Real) and not isinstance(return_value, bool):
        return {"return_value": float(return_value)}
    if not isinstance(return_value, Mapping):
        return {}
    return {mlflow_key(key): value for key, value in _numeric_leaves(return_value, "")}


def absolute_tracking_uri(tracking_uri: str, base_dir: Path) -> str:
    """Make a relative SQLite path (``sqlite:///outputs/mlflow.db``) or plain folder absolute.

    Relative paths are taken from ``base_dir`` (the directory Hydra was started from), so the store
    does not move when ``hydra.job.chdir=true`` changes the working directory.

    Examples
    --------
    >>> absolute_tracking_uri("sqlite:///outputs/mlflow.db", Path("/home/me/lab"))
    'sqlite:////home/me/lab/outputs/mlflow.db'
    >>> absolute_tracking_uri("http://127.0.0.1:5000", Path("/home/me/lab"))
    'http://127.0.0.1:5000'
    """
    if tracking_uri.startswith("sqlite:///"):
        path = tracking_uri[len("sqlite:///") :]
        if path and path != ":memory:" and not os.path.isabs(path):
            return "sqlite:///" + str((base_dir / path).resolve())
        return tracking_uri
    if "://" not in tracking_uri and ":" not in tracking_uri and tracking_uri not in _BARE_URI_SCHEMES:
        return str((base_dir / tracking_uri).resolve())
    return tracking_uri


def absolute_artifact_location(artifact_location: str | None, base_dir: Path) -> str | None:
    """Make a relative artifact folder absolute (URIs such as ``s3://`` are kept as they are)."""
    if artifact_location is None or "://" in artifact_location:
        return artifact_location
    return str((base_dir / artifact_location).resolve())


def _local_path_of(uri: str) -> Path | None:
    if uri.startswith("file:"):
        return Path(urllib.parse.unquote(urllib.parse.urlparse(uri).path))
    if "://" not in uri:
        return Path(uri)
    return None


def _chunks(items: Sequence[Item], size: int) -> Iterator[Sequence[Item]]:
    for start in range(0, len(items), size):
        yield items[start : start + size]


def _package_version(*distributions: str) -> str:
    for distribution in distributions:
        try:
            return metadata.version(distribution)
        except metadata.PackageNotFoundError:
            continue
    return "not installed"


def _git(args: Iterable[str], cwd: Path) -> str | None:
    """Output of a git command in ``cwd``, or ``None`` (not a repository, no git, too slow)."""
    try:
        completed = subprocess.run(
            ["git", *args], cwd=cwd, capture_output=True, text=True, timeout=5, check=False
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return completed.stdout.strip() if completed.returncode == 0 else None


@functools.lru_cache(maxsize=8)  # git runs once per process and launch folder, not once per job
def provenance_tags(cwd: Path) -> dict[str, str]:
    """Tags that say which code ran: git commit (if ``cwd`` is in a repository) and versions."""
    tags = {
        "lwrlab_version": lwrlab.__version__,
        "numpy_version": _package_version("numpy"),
        "pinocchio_version": _package_version("pin", "pinocchio"),
        "mlflow_version": mlflow.__version__,
        "hydra_version": _package_version("hydra-core"),
        "python_version": platform.python_version(),
    }
    commit = _git(["rev-parse", "HEAD"], cwd)
    if commit:
        tags["git_commit"] = commit
        tags["mlflow.source.git.commit"] = commit  # shown by the MLflow UI
        changes = _git(["status", "--porcelain", "--untracked-files=no"], cwd)
        if changes is not None:
            tags["git_dirty"] = str(bool(changes)).lower()
    try:
        tags["mlflow.user"] = getpass.getuser()
    except Exception:  # no user name in some containers
        pass
    return tags


# ---------------------------------------------------------------------------------------------
# The callback.
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TrackingSettings:
    """Where and how one run is logged, with paths already made absolute."""

    tracking_uri: str
    experiment: str
    artifact_location: str | None
    log_artifacts: bool


class TrackingUnavailable(RuntimeError):
    """The tracking store cannot be reached."""


def sweep_identity(
    primary_config: Mapping[str, Any], sweep_overrides: Sequence[str], sweeper_params: Any
) -> str:
    """SHA-256 naming a sweep: the primary config, its overrides (order-free) and the sweeper's search space.

    A re-launched sweep has the same identity, so its jobs are nested under the same parent run.
    """
    text = json.dumps(
        {
            "config": config_hash(primary_config),
            "overrides": sorted(sweep_overrides),
            "params": sweeper_params,
        },
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def experiment_tags(name: str) -> dict[str, str]:
    """Tags of a new experiment: the model-development kind (MLflow 3's UI opens on its runs) and a description."""
    return {EXPERIMENT_KIND_TAG: EXPERIMENT_KIND, DESCRIPTION_TAG: experiment_description(name)}


def ensure_experiment(client: MlflowClient, settings: TrackingSettings) -> str:
    """The id of ``settings.experiment``, created (once among parallel processes) or restored if needed.

    A new experiment gets :func:`experiment_tags`; an existing one without a kind gets them too.
    """
    name = settings.experiment
    experiment = retry_locked(client.get_experiment_by_name, name)
    if experiment is None:
        artifact_location = None
        if settings.artifact_location is not None:
            folder = re.sub(r"[^\w.\-]", "_", name)
            artifact_location = settings.artifact_location.rstrip("/") + "/" + folder
        with store_lock(settings.tracking_uri):  # one creator among parallel processes on SQLite
            experiment = retry_locked(client.get_experiment_by_name, name)
            if experiment is None:
                try:
                    return retry_locked(
                        client.create_experiment,
                        name,
                        artifact_location=artifact_location,
                        tags=experiment_tags(name),
                    )
                except MlflowException:
                    # Another process (another machine, for a server) created it first.
                    experiment = client.get_experiment_by_name(name)
                    if experiment is None:
                        raise
    if experiment.lifecycle_stage == "deleted":
        log.warning("MLflow experiment %r was deleted; restoring it to log this run", name)
        retry_locked(client.restore_experiment, experiment.experiment_id)
    if EXPERIMENT_KIND_TAG not in experiment.tags:  # made by an older lwrlab, or by hand
        for key, value in experiment_tags(name).items():
            if key not in experiment.tags:
                retry_locked(client.set_experiment_tag, experiment.experiment_id, key, value)
    return experiment.experiment_id


def _without_userinfo(uri: str) -> str:
    parts = urllib.parse.urlsplit(uri)
    host = parts.hostname or ""
    netloc = f"[{host}]" if ":" in host else host
    if parts.port is not None:
        netloc += f":{parts.port}"
    return urllib.parse.urlunsplit((parts.scheme, netloc, parts.path, parts.query, parts.fragment))


def _ray_is_initialized() -> bool:
    """Whether a launcher connected this process to Ray (a local instance or a cluster)."""
    ray = sys.modules.get("ray")
    try:
        return bool(ray is not None and ray.is_initialized())
    except Exception:
        return False


class MlflowTracking(Callback):
    """Hydra callback that logs every Hydra job as an MLflow run.

    Parameters
    ----------
    tracking_uri
        MLflow tracking URI: ``sqlite:///path/mlflow.db`` (a relative path is taken from the directory
        Hydra was started in; the folder is created), ``http://host:5000``, ``postgresql://…``.
    experiment
        MLflow experiment name; the experiment is created when missing.
    artifact_location
        Root folder (or URI) for the artifacts of experiments this callback creates: each new
        experiment stores its runs under ``<artifact_location>/<experiment>``. ``None`` leaves the
        choice to the store (for a server: its ``--artifacts-destination``).
    log_artifacts
        Upload the job output directory (``.hydra/`` configs, CSV, PNG, npz, log) as run artifacts.
    resume
        In a multirun, skip a job whose resolved config (``config_hash`` tag) already has a FINISHED
        run in the experiment: the job returns that run's metrics and logs nothing. Failed runs of
        the same config are run again (the old run gets tag ``retried_by``), and a re-launched sweep
        reuses its parent run.

    Notes
    -----
    Hydra instantiates callbacks once, from the primary config, before any job runs. The values of
    this callback's own config node are therefore re-read from each job's config in
    ``on_job_start``, so that a sweep over ``experiment_name`` or over experiment presets logs each
    job in its own experiment.

    Secrets (values of keys such as ``db.auth_token`` or ``client_secret``, URI passwords, secret
    environment values) are redacted from every param, tag, run name, warning and text artifact; the
    job's own output folder keeps the config as typed. When the store is unreachable the job still
    runs; its run is kept in ``mlflow_offline_run.json`` for ``lwrlab sync``.

    Examples
    --------
    In a config (``conf/tracking/sqlite.yaml``)::

        # @package _global_
        hydra:
          callbacks:
            mlflow:
              _target_: lwrlab.tracking.MlflowTracking
              tracking_uri: ${tracking.uri}
              experiment: ${experiment_name}
    """

    def __init__(
        self,
        tracking_uri: str,
        experiment: str,
        artifact_location: str | None = None,
        log_artifacts: bool = True,
        resume: bool = True,
    ) -> None:
        self.tracking_uri = tracking_uri
        self.experiment = experiment
        self.artifact_location = artifact_location
        self.log_artifacts = log_artifacts
        self.resume = resume
        self._client: MlflowClient | None = None
        self._settings: TrackingSettings | None = None
        self._run_id: str | None = None
        self._parent_run_id: str | None = None
        self._parent_settings: TrackingSettings | None = None
        self._has_warned = False
        self._unreachable_uris: set[str] = set()
        self._prepared_uris: set[str] = set()
        self._redactor = Redactor()
        self._offline_record: dict[str, Any] | None = None
        self._skipped = False
        self._failed_attempts: list[str] = []
        self._output_dir: Path | None = None
        self._swept: list[str] = []  # keys the sweep varies, set by on_multirun_start (run names)
        self._sweep_config: DictConfig | None = None
        self._sweep_pid: int | None = None  # the process that launched the sweep (ends its parent run)
        self._previous_handlers: dict[int, Any] | None = None
        self._hook_depth = 0  # > 0 while a hook talks to the store: a stop signal waits for its end
        self._pending_signal: int | None = None
        self._stopping = False

    def __getstate__(self) -> dict[str, Any]:
        # Launchers that run jobs in other processes (joblib, submitit, ray) pickle the callbacks;
        # a client holds a database engine, so each process makes its own. Signal handlers belong
        # to the launching process (and may not pickle).
        state = dict(self.__dict__)
        state.update(
            _client=None,
            _sweep_config=None,
            _previous_handlers=None,
            _hook_depth=0,
            _pending_signal=None,
            _stopping=False,
        )
        return state

    # -- Hydra hooks ------------------------------------------------------------------------
    # Each hook holds stop signals until it is done (see _on_stop_signal), then does its work in
    # the private method of the same name.

    def on_multirun_start(self, config: DictConfig, **kwargs: Any) -> None:
        """Prepare the store, finalise stale runs, open (or reopen) the sweep's parent run; catch stop signals."""
        self._sweep_pid, self._sweep_config = os.getpid(), config
        self._install_stop_handler()
        with self._signals_held():
            self._on_multirun_start(config, **kwargs)
        # A launcher that raises (a failed launch, a lost worker) skips on_multirun_end.
        atexit.register(self._end_sweep_at_exit)

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        """Close the parent run: FINISHED unless a job already marked it FAILED."""
        with self._signals_held():
            self._on_multirun_end(config, **kwargs)
        atexit.unregister(self._end_sweep_at_exit)
        self._restore_stop_handler()

    def on_job_start(self, config: DictConfig, **kwargs: Any) -> None:
        """Start the job's run (params, tags, run id file) or skip an already finished job; catch stop signals."""
        self._install_stop_handler()
        with self._signals_held():
            self._on_job_start(config, **kwargs)

    def on_job_end(self, config: DictConfig, job_return: JobReturn, **kwargs: Any) -> None:
        """Log metrics and artifacts, then end the run with the job's status."""
        with self._signals_held():
            self._on_job_end(config, job_return, **kwargs)
        if self._sweep_pid != os.getpid():  # a sweep's launching process keeps its handler to the end
            self._restore_stop_handler()

    # -- stop signals -----------------------------------------------------------------------

    def _install_stop_handler(self) -> None:
        previous = install_stop_handler(self._on_stop_signal)
        if self._previous_handlers is None and previous is not None:
            self._previous_handlers = previous

    def _restore_stop_handler(self) -> None:
        restore_handlers(self._previous_handlers)
        self._previous_handlers = None

    @contextlib.contextmanager
    def _signals_held(self) -> Iterator[None]:
        """Defer a stop signal that arrives while a hook talks to the store until the hook is done."""
        self._hook_depth += 1
        try:
            yield
        finally:
            self._hook_depth -= 1
            if self._hook_depth == 0 and self._pending_signal is not None:
                signum, self._pending_signal = self._pending_signal, None
                self._on_stop_signal(signum, None)

    def _on_stop_signal(self, signum: int, frame: Any) -> None:
        """SIGINT/SIGTERM: end this process's runs KILLED (outputs uploaded), then raise :class:`JobInterrupted`.

        In the job's process: its run. In a sweep's launching process: also the in-flight nested
        runs (their workers are asked to end them, then terminated with every other descendant
        process, so that none outlives the sweep) and the parent run.
        """
        if self._stopping:
            return  # a second signal while the first one is handled: that one ends the process
        if self._hook_depth > 0:
            self._pending_signal = signum
            return
        self._stopping = True
        name = signal_name(signum)
        # A process-pool worker (loky, multiprocessing) of this sweep; Ray workers are not (raylet starts them).
        is_pool_worker = (
            self._sweep_pid not in (None, os.getpid()) and multiprocessing.parent_process() is not None
        )
        try:
            self._end_job_killed(name)
            if self._parent_run_id is not None and self._sweep_pid == os.getpid():
                self._end_sweep_killed(name)
            elif self._sweep_pid == os.getpid() and not _ray_is_initialized():  # no parent run (untracked)
                terminate_processes(worker_pids(os.getpid()), KILL_GRACE_S)
        except Exception as error:
            self._warn(f"ending the runs after {name}", error)
        if is_pool_worker:
            # A pool worker would catch the exception and take the sweep's next job; ending the
            # process makes the launcher stop handing out jobs (its pool is broken). A Ray worker
            # raises instead: Ray would retry a task whose worker died.
            logging.shutdown()
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(JobInterrupted(signum).exit_status)
        raise JobInterrupted(signum)

    def _end_earlier_attempts(
        self, client: MlflowClient, experiment_id: str, tags: Mapping[str, str], upload: bool
    ) -> None:
        """End KILLED the RUNNING runs of this very job (same sweep, job number and config): attempts
        whose node or worker died, which the launcher (Ray) now retries here; the retry links them."""
        same_job = (
            f"tags.`mlflow.parentRunId` = '{self._parent_run_id}' and tags.hydra_job_num = '{tags.get('hydra_job_num', '')}' "
            f"and tags.config_hash = '{tags['config_hash']}'"
        )
        earlier = running_runs(client, [experiment_id], same_job)
        reason = f"its worker was lost; the launcher retried the job in process {os.getpid()} on {socket.gethostname()}"
        for run in earlier:
            end_killed(client, run.info.run_id, reason, None, None, upload)
            log.warning("run %s of this job was left RUNNING by a lost worker: ended KILLED", run.info.run_id)
        self._failed_attempts += [run.info.run_id for run in earlier]

    def _sweep_is_stopping(self, client: MlflowClient) -> bool:
        """Whether the sweep's launching process has begun to stop (it tags the parent run first)."""
        assert self._parent_run_id is not None
        return KILLED_BY_TAG in retry_locked(client.get_run, self._parent_run_id).data.tags

    def _end_job_killed(self, reason: str) -> None:
        """End the job run of this process KILLED (or its offline record), saying where its outputs are."""
        if self._offline_record is not None and self._output_dir is not None:
            self._finish_offline(self._output_dir, {}, "KILLED", f"stopped by {reason}")
            return
        run_id, client, settings = self._run_id, self._client, self._settings
        if run_id is None or client is None or settings is None:
            return
        self._run_id = None
        atexit.unregister(self._end_run_interrupted)
        where = end_killed(client, run_id, reason, self._output_dir, self._redactor, settings.log_artifacts)
        log.warning("%s: MLflow run %s ended KILLED; %s", reason, run_id, where)

    def _end_sweep_killed(self, reason: str) -> None:
        """Let in-flight workers end their runs, terminate every worker, end what is left and the parent."""
        assert self._parent_run_id is not None and self._parent_settings is not None
        parent_run_id, own_pid, hostname = self._parent_run_id, os.getpid(), socket.gethostname()
        client = self._connect(self._parent_settings)
        experiment_ids = [experiment.experiment_id for experiment in retry_locked(client.search_experiments)]
        nested = f"tags.`mlflow.parentRunId` = '{parent_run_id}'"

        def local_pid(run: Run) -> int | None:
            pid = run.data.tags.get(PID_TAG, "")
            same_host = run.data.tags.get(HOSTNAME_TAG) == hostname
            return (
                int(pid)
                if same_host and pid.isdigit() and int(pid) != own_pid and process_alive(int(pid))
                else None
            )

        def in_flight() -> list[int]:
            return [
                pid
                for run in running_runs(client, experiment_ids, nested)
                if (pid := local_pid(run)) is not None
            ]

        # Jobs that a launcher hands out from now on see this tag and do not start.
        retry_locked(client.set_tag, parent_run_id, KILLED_BY_TAG, reason)
        for run in running_runs(client, experiment_ids, nested):  # the cause, whatever signal the worker gets
            self._guarded(
                "tagging a stopped job",
                retry_locked,
                client.set_tag,
                run.info.run_id,
                KILLED_BY_TAG,
                f"{reason} to the sweep",
            )
        workers = in_flight()
        if workers:
            log.warning("%s: asking %d worker process(es) to end their runs", reason, len(workers))
            send_signal(workers, signal.SIGTERM)  # each worker's own handler uploads and ends its run
            wait_until(lambda: not in_flight(), STOP_GRACE_S)
        # Ray's own at-exit shutdown stops a local instance's processes (killing them from here
        # would stall it, and calling it from a signal handler may deadlock inside ray.get).
        killed = [] if _ray_is_initialized() else terminate_processes(worker_pids(own_pid), KILL_GRACE_S)
        if killed:
            log.warning(
                "%s: %d worker process(es) did not stop on SIGTERM and were killed", reason, len(killed)
            )
        upload = self._parent_settings.log_artifacts
        finalise_children(
            client, experiment_ids, parent_run_id, f"{reason} to the sweep; its worker was terminated", upload
        )
        if self._sweep_config is not None:
            self._guarded("logging the sweep config", self._log_sweep_config, client, self._sweep_config)
        retry_locked(client.set_tag, parent_run_id, KILLED_BY_TAG, reason)
        retry_locked(client.set_terminated, parent_run_id, status="KILLED")
        self._parent_run_id = None
        log.warning("%s: sweep run %s ended KILLED; no worker process left", reason, parent_run_id)

    def _end_sweep_at_exit(self) -> None:
        """The launching process ends without on_multirun_end: end the nested runs left RUNNING, and the parent.

        The parent ends KILLED when jobs were still in flight (the process was stopped: e.g. Ray's
        driver replaces this callback's SIGTERM handler by one that exits), FAILED otherwise (a
        launch that failed before any job ran, such as a Ray cluster refusing the connection).
        """
        if self._parent_run_id is None or self._parent_settings is None or self._sweep_pid != os.getpid():
            return
        parent_run_id, self._parent_run_id = self._parent_run_id, None
        try:
            client = self._connect(self._parent_settings)
            experiment_ids = [
                experiment.experiment_id for experiment in retry_locked(client.search_experiments)
            ]
            reason = "the sweep's launching process exited before this job ended"
            in_flight = finalise_children(
                client, experiment_ids, parent_run_id, reason, self._parent_settings.log_artifacts
            )
            if retry_locked(client.get_run, parent_run_id).info.status == "RUNNING":
                status = "KILLED" if in_flight else "FAILED"
                if in_flight:
                    retry_locked(
                        client.set_tag,
                        parent_run_id,
                        KILLED_BY_TAG,
                        f"{reason}, with {len(in_flight)} job(s) in flight",
                    )
                retry_locked(client.set_terminated, parent_run_id, status=status)
                log.warning("the sweep's launcher stopped: sweep run %s ended %s", parent_run_id, status)
        except Exception as error:
            self._warn("ending the sweep's runs at exit", error)

    # -- hook bodies ------------------------------------------------------------------------

    def _on_multirun_start(self, config: DictConfig, **kwargs: Any) -> None:
        """Prepare the store and open (or reopen) the parent run of a sweep, before any worker starts."""
        try:
            settings = self.settings_for(config)
            self._redactor = self._redactor_for(config, resolved_job_config(config), settings)
            client = self._connect(settings)  # creates the SQLite schema here, once, not in every worker
            experiment_id = ensure_experiment(client, settings)
            if self.resume:  # runs an earlier launch left RUNNING when its process died
                finalise_stale_runs(client, [experiment_id], socket.gethostname(), settings.log_artifacts)
            task_overrides = [
                str(item) for item in OmegaConf.select(config, "hydra.overrides.task", default=[]) or []
            ]
            sweep_overrides = self._redactor.redact(" ".join(task_overrides))
            sweeper_params = OmegaConf.select(config, "hydra.sweeper.params", default=None)
            search_space = (
                OmegaConf.to_container(sweeper_params)
                if OmegaConf.is_config(sweeper_params)
                else sweeper_params
            )
            identity = sweep_identity(resolved_job_config(config), task_overrides, search_space)
            self._swept = swept_keys(
                task_overrides, search_space if isinstance(search_space, Mapping) else None
            )
            parent = self._previous_parent(client, experiment_id, identity) if self.resume else None
            if parent is not None:
                retry_locked(client.update_run, parent.info.run_id, status="RUNNING")
                if KILLED_BY_TAG in parent.data.tags:  # stopped before: its jobs may start again
                    retry_locked(client.delete_tag, parent.info.run_id, KILLED_BY_TAG)
                self._parent_run_id = parent.info.run_id
                log.info(
                    "re-launched sweep: jobs are nested under the existing parent run %s", parent.info.run_id
                )
            else:
                tags = {
                    RUN_KIND_TAG: "sweep",
                    **process_tags(),
                    "overrides": truncate(sweep_overrides, TAG_VALUE_MAX_LENGTH),
                    "sweep_hash": identity,
                    "hydra_sweep_dir": str(OmegaConf.select(config, "hydra.sweep.dir", default="")),
                    **provenance_tags(self._original_cwd(config)),
                }
                sweep_name = truncate(
                    f"sweep{NAME_SEPARATOR}{self._redactor.redact(self._run_name(config))}",
                    RUN_NAME_MAX_LENGTH,
                )
                run = retry_locked(
                    client.create_run,
                    experiment_id,
                    run_name=sweep_name,
                    tags=self._redactor.redact_mapping(tags),
                )
                self._parent_run_id = run.info.run_id
            self._parent_settings = settings
            self._client = client
        except Exception as error:
            self._warn("opening the parent run of the sweep", error)

    def _on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        """Close the parent run: FINISHED unless a job already marked it FAILED."""
        if self._parent_run_id is None or self._parent_settings is None:
            return
        try:
            client = self._connect(self._parent_settings)
            self._log_sweep_config(client, config)
            if retry_locked(client.get_run, self._parent_run_id).info.status == "RUNNING":
                retry_locked(client.set_terminated, self._parent_run_id, status="FINISHED")
        except Exception as error:
            self._warn("closing the parent run of the sweep", error)
        finally:
            self._parent_run_id = None

    def _on_job_start(self, config: DictConfig, **kwargs: Any) -> None:
        """Start the job's run (params, provenance tags, run id file), or skip an already finished job.

        If the store cannot be reached, everything is kept in the output folder for ``lwrlab sync``.
        """
        job_state.reset()
        self._run_id, self._offline_record, self._skipped, self._failed_attempts = None, None, False, []
        output_dir = Path(str(config.hydra.runtime.output_dir))
        self._output_dir = output_dir
        start_ms = int(time.time() * 1000)
        try:
            settings = self.settings_for(config)
            job_config = resolved_job_config(config)
            self._redactor = self._redactor_for(config, job_config, settings)
            tags = self._redactor.redact_mapping(self._job_tags(config, job_config))
            flat = {
                **flatten_config(job_config),
                **plugin_choices(runtime_choices(config)),
                "experiment_name": settings.experiment,
            }
            params = self._redactor.redact_mapping(self._unique_keys(flat))
            run_name = self._redactor.redact(self._run_name(config))
        except Exception as error:
            self._warn("reading the tracking settings", error)
            return
        self._settings = settings
        try:
            client = self._connect(settings)
            experiment_id = ensure_experiment(client, settings)
            if not self._is_sweep_job(config):  # a sweep's launching process did this for its jobs
                finalise_stale_runs(client, [experiment_id], socket.gethostname(), settings.log_artifacts)
            if self._parent_run_id is not None and self._sweep_is_stopping(client):
                raise JobInterrupted(signal.SIGTERM)  # dispatched while the sweep stops: do not start
            if (
                self.resume
                and self._is_sweep_job(config)
                and self._skip_if_finished(client, experiment_id, tags, output_dir)
            ):
                return
            if self._parent_run_id is not None:
                self._end_earlier_attempts(client, experiment_id, tags, settings.log_artifacts)
            run = retry_locked(
                client.create_run, experiment_id, run_name=run_name, tags=tags, start_time=start_ms
            )
        except Exception as error:
            self._warn("starting the MLflow run", error)
            self._keep_offline(config, settings, output_dir, run_name, tags, params, start_ms)
            return
        try:
            self._client, self._run_id = client, run.info.run_id
            # Marks the run KILLED if the process exits without on_job_end (Ctrl-C: Hydra only
            # catches Exception, so a KeyboardInterrupt skips the callback).
            atexit.register(self._end_run_interrupted)
            (output_dir / RUN_ID_FILE).write_text(run.info.run_id + "\n", encoding="utf-8")
            log_params(client, run.info.run_id, params)
            log.info(
                "MLflow run %s in experiment %r at %s",
                run.info.run_id,
                settings.experiment,
                self._redactor.redact(settings.tracking_uri),
            )
        except Exception as error:
            self._warn("logging the params", error)

    def _on_job_end(self, config: DictConfig, job_return: JobReturn, **kwargs: Any) -> None:
        """Log metrics and artifacts, then end the run with the job's status."""
        output_dir = Path(str(config.hydra.runtime.output_dir))
        failed = job_return.status == JobStatus.FAILED
        # job_return.return_value re-raises a failed job's exception; the private field holds it.
        error = job_return._return_value if failed else None
        if failed:
            self._write_error_file(output_dir, error)
        recorded = job_state.take_recorded_metrics()
        metrics: dict[str, float] = {}
        if job_return.status == JobStatus.COMPLETED:
            metrics = numeric_metrics(recorded if recorded is not None else job_return.return_value)
        status = _STATUS_OF_JOB.get(job_return.status, "KILLED")
        error_summary = self._redactor.redact(
            truncate(f"{type(error).__name__}: {error}", ERROR_TAG_MAX_LENGTH)
        )
        if self._skipped:
            job_state.reset()
            return
        if self._offline_record is not None:
            self._finish_offline(output_dir, metrics, status, error_summary if failed else None)
            return
        run_id, client, settings = self._run_id, self._client, self._settings
        if run_id is None or client is None or settings is None:
            return  # tracking was unavailable at job start (already warned)
        try:
            self._guarded("logging metrics", log_metrics, client, run_id, metrics)
            self._guarded("tagging what the job reported", self._log_job_tags, client, run_id, output_dir)
            if failed:
                self._guarded(
                    "tagging the error", retry_locked, client.set_tag, run_id, "error", error_summary
                )
            if settings.log_artifacts:
                self._guarded("logging artifacts", self._log_output_dir, client, run_id, output_dir)
            self._guarded("ending the run", retry_locked, client.set_terminated, run_id, status=status)
            if status == "FINISHED":
                for attempt in self._failed_attempts:
                    self._guarded(
                        "linking the failed attempt",
                        retry_locked,
                        client.set_tag,
                        attempt,
                        "retried_by",
                        run_id,
                    )
            if failed and self._parent_run_id is not None:
                # The basic sweeper raises after a failed batch and skips on_multirun_end: mark now.
                self._guarded("marking the sweep FAILED", self._fail_parent_run, client, config)
        finally:
            self._run_id = None
            atexit.unregister(self._end_run_interrupted)

    # -- internals --------------------------------------------------------------------------

    def _log_job_tags(self, client: MlflowClient, run_id: str, output_dir: Path) -> None:
        """Tags a stage wrote into ``tags.json`` (e.g. ``identifiability=poor``): what a reader must know first."""
        path = output_dir / JOB_TAGS_FILE
        if not path.is_file():
            return
        try:
            tags = json.loads(path.read_text())
        except (OSError, ValueError) as error:
            log.warning("%s is not readable JSON (%s): its tags are not logged", path, error)
            return
        for key, value in dict(tags).items():
            retry_locked(client.set_tag, run_id, str(key), self._redactor.redact(str(value)))

    def settings_for(self, config: DictConfig) -> TrackingSettings:
        """This callback's settings as ``config`` resolves them, with paths made absolute.

        Parameters
        ----------
        config
            A job's full config (with its ``hydra`` node). If exactly one node under
            ``hydra.callbacks`` targets this class, its values are resolved in this config;
            otherwise (or where a value cannot be resolved) the constructor's values are used.
            Relative paths are taken from ``hydra.runtime.cwd``.

        Returns
        -------
        TrackingSettings
        """
        values: dict[str, Any] = {
            "tracking_uri": self.tracking_uri,
            "experiment": self.experiment,
            "artifact_location": self.artifact_location,
            "log_artifacts": self.log_artifacts,
        }
        own_node = self._own_config_node(config)
        if own_node is not None:
            for field in values:
                try:
                    if field in own_node:
                        values[field] = own_node[field]
                except Exception:  # e.g. ${hydra:...} outside a job: keep the constructor value
                    log.debug("kept the constructor value of %s", field, exc_info=True)
        base_dir = self._original_cwd(config)
        experiment = values["experiment"]
        if experiment in (None, "", "None", "null"):  # one experiment per task: named after it
            experiment = (
                runtime_choices(config).get("task")
                or OmegaConf.select(config, "hydra.job.name", default=None)
                or "lwrlab"
            )
        return TrackingSettings(
            tracking_uri=absolute_tracking_uri(str(values["tracking_uri"]), base_dir),
            experiment=str(experiment),
            artifact_location=absolute_artifact_location(
                None if values["artifact_location"] is None else str(values["artifact_location"]), base_dir
            ),
            log_artifacts=bool(values["log_artifacts"]),
        )

    def _own_config_node(self, config: DictConfig) -> DictConfig | None:
        """The node under ``hydra.callbacks`` that instantiates this class, if exactly one does."""
        callbacks = OmegaConf.select(config, "hydra.callbacks")
        if not isinstance(callbacks, DictConfig):
            return None
        matches = []
        for node in callbacks.values():
            try:
                if isinstance(node, DictConfig) and get_class(str(node["_target_"])) is type(self):
                    matches.append(node)
            except Exception:
                continue
        return matches[0] if len(matches) == 1 else None

    @staticmethod
    def _original_cwd(config: DictConfig) -> Path:
        return Path(str(OmegaConf.select(config, "hydra.runtime.cwd", default=None) or os.getcwd()))

    @staticmethod
    def _is_sweep_job(config: DictConfig) -> bool:
        return str(OmegaConf.select(config, "hydra.mode", default="")).endswith("MULTIRUN")

    @staticmethod
    def _redactor_for(
        config: DictConfig, job_config: Mapping[str, Any], settings: TrackingSettings
    ) -> Redactor:
        """Secrets of this job: URI passwords anywhere in its config, overrides or store, and the environment."""
        overrides = OmegaConf.select(config, "hydra.overrides", default=None)
        texts = [settings.tracking_uri, str(settings.artifact_location)]
        if OmegaConf.is_config(overrides):
            texts.append(json.dumps(OmegaConf.to_container(overrides, resolve=False)))
        return Redactor.from_config(flatten_config(job_config), texts)

    def _connect(self, settings: TrackingSettings) -> MlflowClient:
        uri = settings.tracking_uri
        if uri in self._unreachable_uris:
            raise TrackingUnavailable(f"{self._redactor.redact(uri)} was unreachable earlier in this process")
        try:
            if uri.startswith(("http://", "https://")):
                # MLflow retries HTTP calls for minutes; a short probe lets an unreachable server cost
                # one warning instead of delaying every job.
                try:
                    with urllib.request.urlopen(_without_userinfo(uri).rstrip("/") + "/health", timeout=5):
                        pass
                except Exception as error:
                    raise TrackingUnavailable(
                        f"no MLflow server answers at {_without_userinfo(uri)}: {error}"
                    ) from error
            client = self._client if self._client is not None and self._client.tracking_uri == uri else None
            if uri not in self._prepared_uris:
                prepare_sqlite_store(uri)  # schema and WAL once per store, under a file lock
                client = client or MlflowClient(tracking_uri=uri)
                retry_locked(client.search_experiments, max_results=1)  # fails here if the store is unusable
                self._prepared_uris.add(uri)
        except Exception:
            self._unreachable_uris.add(uri)
            raise
        mlflow.set_tracking_uri(uri)  # so that code inside the job sees the same store
        return client or MlflowClient(tracking_uri=uri)

    @staticmethod
    def _runs_tagged(
        client: MlflowClient, experiment_id: str, tag: str, value: str, kind: str, limit: int
    ) -> list[Run]:
        """Runs of one kind (``job``/``sweep``) with ``tags.<tag> = value``, newest first."""
        return list(
            retry_locked(
                client.search_runs,
                [experiment_id],
                filter_string=f"tags.{tag} = '{value}' and tags.{RUN_KIND_TAG} = '{kind}'",
                order_by=["attributes.start_time DESC"],
                max_results=limit,
            )
        )

    def _previous_parent(self, client: MlflowClient, experiment_id: str, identity: str) -> Run | None:
        runs = self._runs_tagged(client, experiment_id, "sweep_hash", identity, "sweep", 1)
        return runs[0] if runs else None

    def _skip_if_finished(
        self, client: MlflowClient, experiment_id: str, tags: Mapping[str, str], output_dir: Path
    ) -> bool:
        """Resume: skip the job if its config already FINISHED; remember failed attempts to link them."""
        runs = self._runs_tagged(client, experiment_id, "config_hash", tags["config_hash"], "job", 200)
        finished = [run for run in runs if run.info.status == "FINISHED"]
        if finished:
            previous = finished[0]
            job_state.set_completed_metrics(previous.data.metrics)
            (output_dir / RESUMED_FILE).write_text(previous.info.run_id + "\n", encoding="utf-8")
            log.info("skipping the job: its config already finished as run %s", previous.info.run_id)
            self._skipped = True
            return True
        self._failed_attempts = [
            run.info.run_id
            for run in runs
            if run.info.status in ("FAILED", "KILLED") and "retried_by" not in run.data.tags
        ]
        return False

    def _keep_offline(
        self,
        config: DictConfig,
        settings: TrackingSettings,
        output_dir: Path,
        run_name: str,
        tags: Mapping[str, str],
        params: Mapping[str, str],
        start_ms: int,
    ) -> None:
        """Keep the run in the output folder for ``lwrlab sync`` (the store could not be reached)."""
        sweep_dir = (
            OmegaConf.select(config, "hydra.sweep.dir", default=None) if self._is_sweep_job(config) else None
        )
        sweep_overrides = ""
        if sweep_dir is not None:
            sweep_overrides = self._redactor.redact(
                " ".join(
                    str(item) for item in OmegaConf.select(config, "hydra.overrides.task", default=[]) or []
                )
            )
        tags = {key: value for key, value in tags.items() if key != "mlflow.parentRunId"}
        self._offline_record = offline.new_record(
            settings.experiment,
            run_name,
            tags,
            params,
            start_ms,
            sweep_dir=None if sweep_dir is None else str(Path(str(sweep_dir)).resolve()),
            sweep_overrides=sweep_overrides,
        )
        try:
            offline.write_record(output_dir, self._offline_record)
        except Exception as error:
            self._warn("keeping the run in the output folder", error)

    def _finish_offline(
        self, output_dir: Path, metrics: Mapping[str, float], status: str, error: str | None
    ) -> None:
        record = self._offline_record
        assert record is not None
        record.update(metrics=dict(metrics), status=status, end_time_ms=int(time.time() * 1000))
        if error is not None:
            record["tags"]["error"] = error
        try:
            offline.write_record(output_dir, record)
            log.info("run kept in %s for `lwrlab sync`", output_dir / offline.OFFLINE_RECORD)
        except Exception as error_writing:
            self._warn("keeping the run in the output folder", error_writing)
        self._offline_record = None

    def _run_name(self, config: DictConfig) -> str:
        """What differs: swept overrides first (plugin choices by name), the log file, then the rest."""
        choices = runtime_choices(config)
        task_overrides = [
            str(item) for item in OmegaConf.select(config, "hydra.overrides.task", default=[]) or []
        ]
        fallback = str(choices.get("task") or OmegaConf.select(config, "hydra.job.name", default="job"))
        log_stem = log_file_stem(config) if choices.get("plant") == "log" else None
        name = run_name(task_overrides, self._swept, set(choices), fallback, log_stem)
        return truncate(name, RUN_NAME_MAX_LENGTH)

    def _job_tags(self, config: DictConfig, job_config: Mapping[str, Any]) -> dict[str, str]:
        task_overrides = OmegaConf.select(config, "hydra.overrides.task", default=[]) or []
        tags = {
            RUN_KIND_TAG: "job",
            "overrides": truncate(" ".join(str(item) for item in task_overrides), TAG_VALUE_MAX_LENGTH),
            "config_hash": config_hash(job_config),
            "hydra_job_name": str(OmegaConf.select(config, "hydra.job.name", default="")),
            "hydra_output_dir": str(config.hydra.runtime.output_dir),
            **provenance_tags(self._original_cwd(config)),
            **process_tags(),
        }
        if "seed" in job_config:
            tags["seed"] = str(job_config["seed"])
        if self._is_sweep_job(config):
            tags["hydra_job_num"] = str(OmegaConf.select(config, "hydra.job.num", default=""))
        if self._parent_run_id is not None:
            tags["mlflow.parentRunId"] = self._parent_run_id  # nests the run under the sweep in the UI
        return tags

    @staticmethod
    def _unique_keys(flat: Mapping[str, str]) -> dict[str, str]:
        # Sanitising can map two config keys onto one MLflow key; a batch with duplicates fails.
        unique: dict[str, str] = {}
        for key, value in flat.items():
            unique.setdefault(mlflow_key(key), value)
        return unique

    def _log_output_dir(self, client: MlflowClient, run_id: str, output_dir: Path) -> None:
        log_output_folder(client, run_id, output_dir, self._redactor)

    def _log_sweep_config(self, client: MlflowClient, config: DictConfig) -> None:
        if self._parent_run_id is None:
            return
        sweep_dir = OmegaConf.select(config, "hydra.sweep.dir", default=None)
        sweep_config = Path(str(sweep_dir)) / "multirun.yaml" if sweep_dir else None
        if sweep_config is not None and sweep_config.is_file():
            with redacted_folder(sweep_config.parent, self._redactor) as folder:
                retry_locked(client.log_artifact, self._parent_run_id, str(folder / "multirun.yaml"))

    def _fail_parent_run(self, client: MlflowClient, config: DictConfig) -> None:
        if self._parent_run_id is None:
            return
        self._log_sweep_config(client, config)
        retry_locked(client.set_terminated, self._parent_run_id, status="FAILED")

    @staticmethod
    def _write_error_file(output_dir: Path, error: Any) -> None:
        try:
            if isinstance(error, BaseException):
                text = "".join(traceback.format_exception(error))
            else:
                text = f"{error!r}\n"
            output_dir.mkdir(parents=True, exist_ok=True)
            (output_dir / ERROR_FILE).write_text(text, encoding="utf-8")
        except Exception:
            log.warning("could not write %s into %s", ERROR_FILE, output_dir, exc_info=True)

    def _end_run_interrupted(self) -> None:
        if self._run_id is None or self._client is None:
            return
        try:
            self._client.set_terminated(self._run_id, status="KILLED")
        except Exception:
            pass  # the interpreter is exiting; nothing more useful to do
        self._run_id = None

    def _guarded(self, action: str, function: Any, *args: Any, **kwargs: Any) -> None:
        """Run one tracking step; a failure is warned about and does not stop the next steps."""
        try:
            function(*args, **kwargs)
        except Exception as error:
            self._warn(action, error)

    def _warn(self, action: str, error: BaseException) -> None:
        message = self._redactor.redact(f"{type(error).__name__}: {error}")
        if not self._has_warned:
            self._has_warned = True
            log.warning(
                "MLflow tracking failed while %s (%s); the job goes on and keeps its outputs in its folder. "
                "Further tracking problems of this process are logged at DEBUG level.",
                action,
                message,
            )
        else:
            log.debug("MLflow tracking failed while %s (%s)", action, message)


# ---------------------------------------------------------------------------------------------
# Logging helpers shared with `lwrlab sync`.
# ---------------------------------------------------------------------------------------------


def log_params(client: MlflowClient, run_id: str, params: Mapping[str, str]) -> None:
    """Log params in batches of MLflow's maximum size."""
    entries = [Param(key, value) for key, value in params.items()]
    for chunk in _chunks(entries, PARAMS_PER_BATCH):
        retry_locked(client.log_batch, run_id, params=list(chunk))


def log_metrics(
    client: MlflowClient, run_id: str, metrics: Mapping[str, float], timestamp_ms: int | None = None
) -> None:
    """Log metrics in batches (one store transaction per batch rather than one per metric)."""
    timestamp_ms = int(time.time() * 1000) if timestamp_ms is None else timestamp_ms
    entries = [Metric(key, float(value), timestamp_ms, 0) for key, value in metrics.items()]
    for chunk in _chunks(entries, METRICS_PER_BATCH):
        retry_locked(client.log_batch, run_id, metrics=list(chunk))


def log_output_folder(
    client: MlflowClient, run_id: str, output_dir: Path, redactor: Redactor, exclude: Sequence[str] = ()
) -> None:
    """Upload a job output folder as the run's artifacts, secrets redacted."""
    if not output_dir.is_dir():
        return
    artifact_dir = _local_path_of(retry_locked(client.get_run, run_id).info.artifact_uri or "")
    if artifact_dir is not None and artifact_dir.resolve().is_relative_to(output_dir.resolve()):
        # Copying a folder into a folder inside it would never end.
        raise ValueError(f"artifact folder {artifact_dir} lies inside the job output folder {output_dir}")
    with redacted_folder(output_dir, redactor, exclude=exclude) as folder:
        client.log_artifacts(run_id, str(folder))


# ---------------------------------------------------------------------------------------------
# Comparing runs.
# ---------------------------------------------------------------------------------------------


def runs_table(tracking_uri: str, experiment: str, filter_string: str = "") -> pd.DataFrame:
    """All runs of an experiment as a table, oldest first, for comparing runs.

    Parameters
    ----------
    tracking_uri
        The store (a relative ``sqlite:///`` path is taken from the current directory).
    experiment
        Experiment name.
    filter_string
        MLflow search filter, e.g. ``"metrics.rms_mean < 0.5 and params.estimator._target_ LIKE '%OLS%'"``
        or ``"tags.run_kind = 'job'"`` to leave out the parent runs of sweeps.

    Returns
    -------
    pandas.DataFrame
        One row per run: ``run_id``, ``status``, ``start_time``, … and ``metrics.*``, ``params.*``,
        ``tags.*`` columns (the layout of ``mlflow.search_runs``); empty if the experiment does not
        exist.

    Examples
    --------
    >>> table = runs_table("sqlite:///outputs/mlflow.db", "identification")  # doctest: +SKIP
    >>> table[["tags.overrides", "metrics.rms_mean"]].sort_values("metrics.rms_mean")  # doctest: +SKIP
    """
    uri = absolute_tracking_uri(tracking_uri, Path.cwd())
    found = MlflowClient(tracking_uri=uri).get_experiment_by_name(experiment)
    if found is None:
        return pd.DataFrame()
    return search_runs_table(uri, [found.experiment_id], filter_string)


def search_runs_table(
    tracking_uri: str, experiment_ids: Sequence[str], filter_string: str = ""
) -> pd.DataFrame:
    """``mlflow.search_runs`` on a given store (not the global one), oldest run first, as pandas."""
    previous_uri = mlflow.get_tracking_uri()
    mlflow.set_tracking_uri(tracking_uri)  # mlflow.search_runs reads the global URI
    try:
        table = mlflow.search_runs(
            experiment_ids=list(experiment_ids),
            filter_string=filter_string,
            order_by=["attributes.start_time ASC"],
            output_format="pandas",
        )
    finally:
        mlflow.set_tracking_uri(previous_uri)
    assert isinstance(table, pd.DataFrame)
    return table


__all__ = [
    "MlflowTracking",
    "TrackingSettings",
    "TrackingUnavailable",
    "absolute_tracking_uri",
    "config_hash",
    "ensure_experiment",
    "flatten_config",
    "log_metrics",
    "log_output_folder",
    "log_params",
    "numeric_metrics",
    "resolved_job_config",
    "runs_table",
    "search_runs_table",
    "sweep_identity",
]
