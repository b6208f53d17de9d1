"""MLflow tracking of Hydra jobs from the process that runs the hooks: params, tags, metrics, status.

The numeric core never imports mlflow. A job only returns its metrics and writes its artifacts into the
Hydra job output directory; :class:`InProcessTracking` turns each Hydra job into one MLflow run. The
callback the ``tracking`` config group names, :class:`~lwrlab.tracking.companion.callback.MlflowTracking`,
runs it in the job's process for sweeps and in a companion process for a single run:

* ``on_job_start``: experiment (created if missing, as a model-development experiment with a
  description of the headline metrics), run named by what differs (``wls · seed=1``), the few params
  that identify it (overridden keys, the short name of every plugin choice: ``estimator=wls``, the
  knobs of ``run_params``), the whole resolved config as ``resolved_config.yaml``, provenance tags
  (overrides, git commit, config hash, seed, library versions, pid and hostname).
* ``on_job_end``: numeric metrics from the return value, each under its section
  (``accuracy/rms_mean``: ``metric_sections``), the logs or simulated motions it used as dataset
  inputs, the whole job output directory as artifacts, and the run status (FINISHED, or FAILED with
  the error and ``error.txt``).
* a Hydra multirun becomes a parent run with one nested run per job.
* SIGINT and SIGTERM end the runs KILLED, with what the job wrote uploaded (see ``_on_stop_signal``);
  a resumed sweep or a new job ends KILLED the runs a dead process of this host left RUNNING.

This module only sequences the hooks; the work is done by one module each: ``settings`` (where a job
is logged), ``config_params`` (params, hashes, metrics), ``provenance`` (tags), ``connection`` (the
store and the experiment), ``job_run`` (one job's run, or its offline record), ``sweep_run`` (the
parent run), ``sweep_stop`` (stopping a sweep), ``run_queries``, ``run_logging`` and ``finalise``.
Tracking problems never hide the job's own result: they are logged once as a warning (with the
error's type) and the job goes on untracked.

Examples
--------
Select it from the command line (``tracking: sqlite`` is the default of ``conf/config.yaml``)::

    lwrlab tracking=sqlite experiment_name=identification
    lwrlab tracking=server hydra.callbacks.mlflow.tracking_uri=http://host:5000
    lwrlab tracking=none
"""

from __future__ import annotations

import atexit
import contextlib
import logging
import multiprocessing
import os
import socket
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from hydra.core.utils import JobReturn
from hydra.experimental.callback import Callback
from mlflow.tracking import MlflowClient
from omegaconf import DictConfig, OmegaConf

from lwrlab.tracking.job_config.config_params import hashed_config_text, resolved_job_config
from lwrlab.tracking.job_config.naming import job_run_name
from lwrlab.tracking.job_config.provenance import job_tags
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.job_config.run_params import job_params, resolved_config_text
from lwrlab.tracking.lifecycle import job_state
from lwrlab.tracking.lifecycle.job_run import JobRun
from lwrlab.tracking.lifecycle.sweep_run import close_sweep_run, describe_sweep, open_sweep_run
from lwrlab.tracking.lifecycle.sweep_stop import end_sweep_at_exit, end_sweep_killed, terminate_workers
from lwrlab.tracking.runs.finalise import finalise_stale_runs
from lwrlab.tracking.runs.processes import (
    JobInterrupted,
    exit_at_once,
    install_stop_handler,
    postpone_abort_alarm,
    register_at_exit,
    restore_handlers,
    signal_name,
)
from lwrlab.tracking.store.connection import StoreConnections, ensure_experiment
from lwrlab.tracking.store.settings import SETTING_FIELDS, TrackingSettings, job_redactor, job_settings

log = logging.getLogger(__name__)


class InProcessTracking(Callback):
    """Logs every Hydra job as an MLflow run from the process that runs the hooks.

    :class:`~lwrlab.tracking.companion.callback.MlflowTracking` (the callback named in the configs) uses it
    directly in sweeps, and from its companion process (:mod:`lwrlab.tracking.companion.process`) for a
    single run.

    The parameters are :class:`~lwrlab.tracking.companion.callback.MlflowTracking`'s but ``companion``,
    and ``configured_as``: the callback class the configs name, whose node under ``hydra.callbacks``
    holds the settings each job resolves (:meth:`settings_for`); ``None`` looks for this class's node.
    It is handed in rather than imported, so that this module does not import the callback that
    imports it.
    """

    def __init__(
        self,
        tracking_uri: str,
        experiment: str,
        artifact_location: str | None,
        log_artifacts: bool,
        resume: bool,
        configured_as: type | None = None,
    ) -> None:
        self.tracking_uri = tracking_uri
        self.experiment = experiment
        self.artifact_location = artifact_location
        self.log_artifacts = log_artifacts
        self.resume = resume
        self.configured_as = configured_as
        self._client: MlflowClient | None = None  # the last store this process connected to
        self._job: JobRun | None = None  # the run of the job this process runs now
        self._parent_run_id: str | None = None
        self._parent_settings: TrackingSettings | None = None
        self._has_warned = False
        self._connections = StoreConnections()  # pickled along: a worker skips preparing the store again
        self._redactor = Redactor()
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
            _job=None,
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
        """Prepare the store, end stale runs, open (or reopen) the sweep's parent run; catch stop signals."""
        self._sweep_pid, self._sweep_config = os.getpid(), config
        self._install_stop_handler()
        with self._signals_held():
            self._on_multirun_start(config)
        # A launcher that raises (a failed launch, a lost worker) skips on_multirun_end.
        launcher = OmegaConf.select(config, "hydra.launcher._target_", default="")
        register_at_exit(self._end_sweep_at_exit, str(launcher))

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        """Close the parent run: FINISHED unless a job already marked it FAILED."""
        with self._signals_held():
            self._on_multirun_end(config)
        atexit.unregister(self._end_sweep_at_exit)
        self._restore_stop_handler()

    def on_job_start(self, config: DictConfig, **kwargs: Any) -> None:
        """Start the job's run (params, tags, run id file) or skip a finished job; catch stop signals."""
        self._install_stop_handler()
        with self._signals_held():
            self.start_job(config)

    def on_job_end(self, config: DictConfig, job_return: JobReturn, **kwargs: Any) -> None:
        """Log metrics and artifacts, then end the run with the job's status."""
        with self._signals_held():
            self.end_job(config, job_return)
        if self._sweep_pid != os.getpid():  # a sweep's launching process keeps its handler to the end
            self._restore_stop_handler()

    def settings_for(self, config: DictConfig) -> TrackingSettings:
        """This callback's settings as ``config`` resolves them.

        See :func:`~lwrlab.tracking.store.settings.job_settings`.
        """
        values = {field: getattr(self, field) for field in SETTING_FIELDS}
        return job_settings(config, values, self.configured_as or type(self))

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
        """SIGINT/SIGTERM: end this process's runs KILLED (outputs uploaded), raise :class:`JobInterrupted`.

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
        launcher = self._sweep_pid == os.getpid()
        # A process-pool worker (loky, multiprocessing) of this sweep; not a Ray worker (raylet starts those).
        is_pool_worker = (
            self._sweep_pid is not None and not launcher and multiprocessing.parent_process() is not None
        )
        try:
            if self._job is not None:
                self._job.end_killed(name)
            if self._parent_run_id is not None and launcher:
                self._end_sweep_killed(name)
            elif launcher:  # no parent run (untracked): still no worker may outlive the sweep
                terminate_workers()
        except Exception as error:  # broad: whatever the store does, the process must still stop
            self._warn(f"ending the runs after {name}", error)
        if is_pool_worker:
            # A pool worker would catch the exception and take the sweep's next job; ending the
            # process makes the launcher stop handing out jobs (its pool is broken). A Ray worker
            # raises instead: Ray would retry a task whose worker died.
            exit_at_once(JobInterrupted(signum).exit_status)
        raise JobInterrupted(signum)

    def _end_sweep_killed(self, reason: str) -> None:
        assert self._parent_run_id is not None and self._parent_settings is not None
        client = self._connect(self._parent_settings)
        upload = self._parent_settings.log_artifacts
        end_sweep_killed(
            client, self._parent_run_id, reason, upload, self._guarded, self._sweep_config, self._redactor
        )
        self._parent_run_id = None

    def _end_sweep_at_exit(self) -> None:
        """The launching process ends without on_multirun_end: end the sweep's runs (see ``sweep_stop``)."""
        if self._parent_run_id is None or self._parent_settings is None or self._sweep_pid != os.getpid():
            return
        postpone_abort_alarm()  # Ray's SIGTERM handler aborts the process 3 s on, mid-way otherwise
        parent_run_id, self._parent_run_id = self._parent_run_id, None
        try:
            client = self._connect(self._parent_settings)
            end_sweep_at_exit(client, parent_run_id, self._parent_settings.log_artifacts)
        except Exception as error:  # broad: an at-exit hook that raises would only print a traceback
            self._warn("ending the sweep's runs at exit", error)

    # -- hook bodies ------------------------------------------------------------------------
    # Each body is the boundary between Hydra and tracking: it catches every Exception, because a
    # tracking failure must never fail the user's job; the error is logged with its type by _warn.

    def _on_multirun_start(self, config: DictConfig) -> None:
        """Prepare the store and open (or reopen) the parent run of a sweep, before any worker starts."""
        try:
            settings = self.settings_for(config)
            self._redactor = job_redactor(config, resolved_job_config(config), settings)
            client = self._connect(settings)  # creates the SQLite schema here, once, not in every worker
            experiment_id = ensure_experiment(client, settings)
            if self.resume:  # runs an earlier launch left RUNNING when its process died
                finalise_stale_runs(client, [experiment_id], socket.gethostname(), settings.log_artifacts)
            sweep = describe_sweep(config)
            self._swept = sweep.swept
            self._parent_run_id = open_sweep_run(
                client, experiment_id, config, sweep, self._redactor, self.resume
            )
            self._parent_settings = settings
        except Exception as error:  # broad: see above
            self._warn("opening the parent run of the sweep", error)

    def _on_multirun_end(self, config: DictConfig) -> None:
        """Close the parent run: FINISHED unless a job already marked it FAILED."""
        if self._parent_run_id is None or self._parent_settings is None:
            return
        try:
            close_sweep_run(self._connect(self._parent_settings), self._parent_run_id, config, self._redactor)
        except Exception as error:  # broad: see above
            self._warn("closing the parent run of the sweep", error)
        finally:
            self._parent_run_id = None

    # -- one job's run, for the job hooks and for the companion process ----------------------

    def start_job(self, config: DictConfig, started_ms: int | None = None) -> None:
        """Start the job's run (params, provenance tags, run id file), or skip an already finished job.

        ``started_ms``: when the job started (epoch ms), if not now. If the store cannot be reached,
        everything is kept in the output folder for ``lwrlab sync``. Never raises for the store.
        """
        job_state.reset()
        job = JobRun(Path(str(config.hydra.runtime.output_dir)), self._redactor, self._warn, self._guarded)
        if started_ms is not None:
            job.start_ms = started_ms
        self._job = job
        try:
            settings = self.settings_for(config)
            job_config = resolved_job_config(config)
            self._redactor = job.redactor = job_redactor(config, job_config, settings)
            hashed = hashed_config_text(job_config)  # once: the tag config_hash and the artifact
            tags = self._redactor.redact_mapping(job_tags(config, job_config, self._parent_run_id, hashed))
            params = self._redactor.redact_mapping(job_params(config, job_config))
            config_text = self._redactor.redact(resolved_config_text(job_config, hashed))
            run_name = self._redactor.redact(job_run_name(config, self._swept))
        except Exception as error:  # broad: see above
            self._warn("reading the tracking settings", error)
            return
        job.settings = settings
        try:
            job.start(self._connect(settings), config, tags, run_name, self._parent_run_id, self.resume)
        except Exception as error:  # broad: see above; the run is then kept for `lwrlab sync`
            self._warn("starting the MLflow run", error)
            job.keep_offline(config, run_name, tags, params)
            return
        try:
            job.log_start(params, config_text)
        except Exception as error:  # broad: see above
            self._warn("logging the params", error)

    def end_job(self, config: DictConfig, job_return: JobReturn) -> None:
        """Log metrics and artifacts, then end the run with the job's status. Never raises for the store."""
        # Without on_job_start in this process, a fresh JobRun still writes error.txt, and logs nothing.
        job = self._job or JobRun(
            Path(str(config.hydra.runtime.output_dir)), self._redactor, self._warn, self._guarded
        )
        job.end(job_return, config, self._parent_run_id)

    def end_job_killed(self, reason: str) -> None:
        """End the running job's run KILLED (``reason``: a signal's name), with its outputs uploaded."""
        if self._job is None:
            return
        try:
            self._job.end_killed(reason)
        except Exception as error:  # broad: whatever the store does, the stop must go on
            self._warn(f"ending the run after {reason}", error)

    # -- internals --------------------------------------------------------------------------

    def _connect(self, settings: TrackingSettings) -> MlflowClient:
        self._client = self._connections.connect(settings.tracking_uri, self._client, self._redactor)
        return self._client

    def _guarded(self, action: str, function: Callable[..., object], *args: Any, **kwargs: Any) -> None:
        """Run one tracking step; a failure is warned about and does not stop the next steps."""
        try:
            function(*args, **kwargs)
        except Exception as error:  # broad: one failed step must neither fail the job nor skip the others
            self._warn(action, error)

    def _warn(self, action: str, error: BaseException) -> None:
        """Log a tracking failure with its type: the first as a warning, later ones at DEBUG level."""
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


__all__ = ["InProcessTracking"]
