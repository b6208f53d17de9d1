"""The tracking callback the configs name: every Hydra job becomes an MLflow run.

Importing MLflow and opening a store takes about two seconds, longer than an identification from a
log. For a single run (``lwrlab task=…``), :class:`MlflowTracking` therefore logs from a companion
process (:mod:`lwrlab.tracking.companion.process`), launched by ``lwrlab`` before Hydra composes the config
(:mod:`lwrlab.tracking.companion.early_companion`) or else when the run starts: it imports MLflow and starts
the run on another core while the job computes, and the job's process never imports MLflow. The job
waits for the companion at its end, so that its run is complete in the store when ``lwrlab``
returns. Sweeps, whose jobs run in launcher workers (joblib, Ray, Slurm), are logged from the
processes that run their hooks (:class:`~lwrlab.tracking.lifecycle.mlflow_callback.InProcessTracking`), as
are single runs with ``companion: false``.

What is logged, and how failures and stop signals end runs, is described in
:mod:`lwrlab.tracking.lifecycle.mlflow_callback`.
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING, Any

from hydra.core.utils import JobReturn
from hydra.experimental.callback import Callback
from omegaconf import DictConfig

from lwrlab.tracking.companion import early_companion
from lwrlab.tracking.companion.companion_link import CompanionGone, CompanionLink
from lwrlab.tracking.lifecycle import job_state
from lwrlab.tracking.runs.processes import JobInterrupted, install_stop_handler, restore_handlers, signal_name

if TYPE_CHECKING:
    from lwrlab.tracking.lifecycle.mlflow_callback import InProcessTracking

log = logging.getLogger(__name__)


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
    companion
        Log a single run from a companion process, in parallel with the job (see the module's
        docstring); ``False``: from the job's own process, after MLflow is imported there.

    Notes
    -----
    Hydra instantiates callbacks once, from the primary config, before any job runs. The values of
    this callback's own config node are therefore re-read from each job's config in
    ``on_job_start`` (:func:`~lwrlab.tracking.store.settings.job_settings`), so that a sweep over
    ``experiment_name`` or over experiment presets logs each job in its own experiment.

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
        artifact_location: str | None,
        log_artifacts: bool,
        resume: bool,
        companion: bool,
    ) -> None:
        self.tracking_uri = tracking_uri
        self.experiment = experiment
        self.artifact_location = artifact_location
        self.log_artifacts = log_artifacts
        self.resume = resume
        self.companion = companion
        self._in_process: InProcessTracking | None = None  # made on first use (it imports MLflow)
        self._link: CompanionLink | None = None  # the companion of this process's single run
        self._previous_handlers: dict[int, Any] | None = None
        self._waiting = False  # the job waits for the companion: a stop signal waits too
        self._pending_signal: int | None = None
        self._stopping = False

    def __getstate__(self) -> dict[str, Any]:
        # Launcher workers get this callback pickled; the companion and handlers stay here.
        state = dict(self.__dict__)
        state.update(
            _link=None, _previous_handlers=None, _waiting=False, _pending_signal=None, _stopping=False
        )
        return state

    def in_process(self) -> InProcessTracking:
        """The tracking that logs from this process (sweeps, ``companion: false``), made on first use."""
        if self._in_process is None:
            from lwrlab.tracking.lifecycle.mlflow_callback import InProcessTracking

            self._in_process = InProcessTracking(**self.logging_settings(), configured_as=type(self))
        return self._in_process

    def logging_settings(self) -> dict[str, Any]:
        """The settings the logging itself takes (all but ``companion``), in this process or the companion."""
        return {
            "tracking_uri": self.tracking_uri,
            "experiment": self.experiment,
            "artifact_location": self.artifact_location,
            "log_artifacts": self.log_artifacts,
            "resume": self.resume,
        }

    # -- Hydra hooks ------------------------------------------------------------------------

    def on_run_start(self, config: DictConfig, **kwargs: Any) -> None:
        """A single run: configure the companion ``lwrlab`` launched, or start one now."""
        early = early_companion.take()
        if not self.companion:
            if early is not None:
                early.discard()
            return
        try:
            if early is None:
                self._link = CompanionLink.start(self.logging_settings())
            else:
                early.configure(self.logging_settings())
                self._link = early
        except (OSError, ValueError, CompanionGone) as error:  # ValueError: no fd passing (Windows)
            log.warning(
                "the tracking companion did not start (%s: %s); logging from the job's process",
                type(error).__name__,
                error,
            )

    def on_run_end(self, config: DictConfig, **kwargs: Any) -> None:
        if self._link is not None:
            self._link.close()
            self._link = None

    def on_multirun_start(self, config: DictConfig, **kwargs: Any) -> None:
        early_companion.discard()  # a preset that sweeps: its jobs log from the launcher's processes
        self.in_process().on_multirun_start(config, **kwargs)

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        self.in_process().on_multirun_end(config, **kwargs)

    def on_job_start(self, config: DictConfig, **kwargs: Any) -> None:
        """Let the companion start the job's run (or start it here); catch stop signals."""
        if self._link is None:
            self.in_process().on_job_start(config, **kwargs)
            return
        job_state.reset()
        try:
            self._link.job_start(config, int(time.time() * 1000))
        except CompanionGone as error:
            self._companion_lost(error)
            self.in_process().on_job_start(config, **kwargs)
            return
        self._previous_handlers = install_stop_handler(self._on_stop_signal)

    def on_job_end(self, config: DictConfig, job_return: JobReturn, **kwargs: Any) -> None:
        """Wait until the job's metrics, outputs and status are logged."""
        if self._link is None:
            self.in_process().on_job_end(config, job_return, **kwargs)
            return
        self._waiting = True
        try:
            self._link.job_end(config, job_return, job_state.take_recorded_metrics())
        except CompanionGone as error:
            self._companion_lost(error)
        finally:
            self._waiting = False
            restore_handlers(self._previous_handlers)
            self._previous_handlers = None
        if self._pending_signal is not None:  # arrived while waiting: the run is logged, now stop
            raise JobInterrupted(self._pending_signal)

    # -- internals --------------------------------------------------------------------------

    def _on_stop_signal(self, signum: int, frame: Any) -> None:
        """SIGINT/SIGTERM during the job: the companion ends the run KILLED, then the job stops."""
        if self._waiting:
            self._pending_signal = signum
            return
        if self._stopping or self._link is None:
            return
        self._stopping = True
        try:
            self._link.stop(signal_name(signum))
        except CompanionGone as error:
            self._companion_lost(error)
        restore_handlers(self._previous_handlers)
        self._previous_handlers = None
        raise JobInterrupted(signum)

    def _companion_lost(self, error: CompanionGone) -> None:
        log.warning("MLflow tracking failed: %s; the job keeps its outputs in its folder", error)
        self._link = None


__all__ = ["MlflowTracking"]
