"""Ending a sweep's runs when it stops: a stop signal, its launcher's exit, or a lost worker.

* :func:`end_sweep_killed` (SIGINT/SIGTERM in the sweep's launching process): tag the parent so no
  new job starts, ask each in-flight worker to end its own run (upload what it wrote, mark KILLED),
  terminate every worker left, end what is left and the parent KILLED;
* :func:`end_sweep_at_exit`: the launching process exits without ending the sweep (a launcher that
  raised, or Ray's own signal handler): nested runs left RUNNING and the parent are ended;
* :func:`end_earlier_attempts`: a launcher (Ray) retries a job whose worker died; the dead attempt's
  run, still RUNNING, is ended KILLED and later linked to the retry.

The runs of a single job are ended by :mod:`lwrlab.tracking.runs.finalise`.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import sys
from collections.abc import Callable, Mapping

from mlflow.entities import Run
from mlflow.tracking import MlflowClient
from omegaconf import DictConfig

from lwrlab.tracking.job_config.provenance import HOSTNAME_TAG, PARENT_RUN_TAG, PID_TAG
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.lifecycle.sweep_run import log_sweep_config
from lwrlab.tracking.runs.finalise import KILLED_BY_TAG, end_killed, finalise_children, running_runs
from lwrlab.tracking.runs.processes import (
    process_alive,
    send_signal,
    terminate_processes,
    wait_until,
    worker_pids,
)
from lwrlab.tracking.runs.run_queries import earlier_attempts, experiment_ids
from lwrlab.tracking.store.sqlite import retry_locked

log = logging.getLogger(__name__)

# After a stop signal, how long a sweep's launching process lets its workers end their own runs
# (upload what they wrote, mark KILLED) before it terminates them and ends what is left.
STOP_GRACE_S = 30.0
# Then how long a worker process gets between SIGTERM and SIGKILL.
KILL_GRACE_S = 3.0

Guard = Callable[..., None]
"""``guard(action, function, *args)``: run one tracking step; a failure is warned about, not raised."""


def ray_is_initialized() -> bool:
    """Whether a launcher connected this process to Ray (a local instance or a cluster)."""
    ray = sys.modules.get("ray")
    try:
        return bool(ray is not None and ray.is_initialized())
    except AttributeError:  # a partly imported or stand-in `ray` module
        return False


def terminate_workers() -> list[int]:
    """Terminate every worker process of this one, unless Ray's own shutdown stops them; the pids killed.

    Killing a local Ray instance's processes from here would stall Ray's at-exit shutdown, and
    calling it from a signal handler may deadlock inside ``ray.get``.
    """
    return [] if ray_is_initialized() else terminate_processes(worker_pids(os.getpid()), KILL_GRACE_S)


def _in_flight_workers(client: MlflowClient, ids: list[str], nested: str) -> list[int]:
    """Pids of this host's live processes (other than this one) that run a RUNNING nested run."""
    own_pid, hostname = os.getpid(), socket.gethostname()

    def local_pid(run: Run) -> int | None:
        pid = run.data.tags.get(PID_TAG, "")
        same_host = run.data.tags.get(HOSTNAME_TAG) == hostname
        if same_host and pid.isdigit() and int(pid) != own_pid and process_alive(int(pid)):
            return int(pid)
        return None

    return [pid for run in running_runs(client, ids, nested) if (pid := local_pid(run)) is not None]


def end_sweep_killed(
    client: MlflowClient,
    parent_run_id: str,
    reason: str,
    upload: bool,
    guard: Guard,
    sweep_config: DictConfig | None = None,
    redactor: Redactor | None = None,
) -> None:
    """Let in-flight workers end their runs, terminate every worker, end what is left and the parent KILLED.

    Parameters
    ----------
    client, parent_run_id
        The store and the sweep's parent run.
    reason
        The signal's name (tagged ``killed_by``).
    upload
        Upload the output folders of runs ended here (the sweep's ``log_artifacts``).
    guard
        Runs the steps whose failure must not stop the others (see :data:`Guard`).
    sweep_config, redactor
        The sweep's primary config, to log its ``multirun.yaml`` on the parent.
    """
    ids = experiment_ids(client)
    nested = f"tags.`{PARENT_RUN_TAG}` = '{parent_run_id}'"
    # Jobs that a launcher hands out from now on see this tag and do not start.
    retry_locked(client.set_tag, parent_run_id, KILLED_BY_TAG, reason)
    for run in running_runs(client, ids, nested):  # the cause, whatever signal the worker gets
        guard(
            "tagging a stopped job",
            retry_locked,
            client.set_tag,
            run.info.run_id,
            KILLED_BY_TAG,
            f"{reason} to the sweep",
        )
    workers = _in_flight_workers(client, ids, nested)
    if workers:
        log.warning("%s: asking %d worker process(es) to end their runs", reason, len(workers))
        send_signal(workers, signal.SIGTERM)  # each worker's own handler uploads and ends its run
        wait_until(lambda: not _in_flight_workers(client, ids, nested), STOP_GRACE_S)
    killed = terminate_workers()
    if killed:
        log.warning("%s: %d worker process(es) did not stop on SIGTERM and were killed", reason, len(killed))
    finalise_children(client, ids, parent_run_id, f"{reason} to the sweep; its worker was terminated", upload)
    if sweep_config is not None:
        guard(
            "logging the sweep config",
            log_sweep_config,
            client,
            parent_run_id,
            sweep_config,
            redactor or Redactor(),
        )
    retry_locked(client.set_tag, parent_run_id, KILLED_BY_TAG, reason)
    retry_locked(client.set_terminated, parent_run_id, status="KILLED")
    log.warning("%s: sweep run %s ended KILLED; no worker process left", reason, parent_run_id)


def end_sweep_at_exit(client: MlflowClient, parent_run_id: str, upload: bool) -> None:
    """The launching process ends without on_multirun_end: end the nested runs left RUNNING, and the parent.

    The parent ends KILLED when jobs were still in flight (the process was stopped: e.g. Ray's
    driver replaces the callback's SIGTERM handler by one that exits), FAILED otherwise (a launch
    that failed before any job ran, such as a Ray cluster refusing the connection).
    """
    reason = "the sweep's launching process exited before this job ended"
    in_flight = finalise_children(client, experiment_ids(client), parent_run_id, reason, upload)
    if retry_locked(client.get_run, parent_run_id).info.status != "RUNNING":
        return
    status = "KILLED" if in_flight else "FAILED"
    if in_flight:
        retry_locked(
            client.set_tag, parent_run_id, KILLED_BY_TAG, f"{reason}, with {len(in_flight)} job(s) in flight"
        )
    retry_locked(client.set_terminated, parent_run_id, status=status)
    log.warning("the sweep's launcher stopped: sweep run %s ended %s", parent_run_id, status)


def end_earlier_attempts(
    client: MlflowClient, experiment_id: str, parent_run_id: str, tags: Mapping[str, str], upload: bool
) -> list[str]:
    """End KILLED the RUNNING runs of this very job (attempts whose worker died); returns their ids.

    The launcher (Ray) retries such a job in this process; the new run links them as ``retried_by``.
    """
    earlier = earlier_attempts(client, experiment_id, parent_run_id, tags)
    reason = (
        "its worker was lost; the launcher retried the job "
        f"in process {os.getpid()} on {socket.gethostname()}"
    )
    for run in earlier:
        end_killed(client, run.info.run_id, reason, None, None, upload)
        log.warning("run %s of this job was left RUNNING by a lost worker: ended KILLED", run.info.run_id)
    return [run.info.run_id for run in earlier]


__all__ = [
    "KILL_GRACE_S",
    "STOP_GRACE_S",
    "end_earlier_attempts",
    "end_sweep_at_exit",
    "end_sweep_killed",
    "ray_is_initialized",
    "terminate_workers",
]
