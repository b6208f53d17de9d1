"""Runs that stopped without ending: marked KILLED, with what their job wrote uploaded and said so.

Three callers: the signal handler of a job (its own run), the signal handler of a sweep's launching
process (the sweep's in-flight children and the parent), and a resumed sweep or a new job (runs left
RUNNING by a process of this host that no longer exists: a ``kill -9``, a crashed node, a lost
terminal). Each run records ``pid`` and ``hostname`` tags at start, which is how a stale run is told
from one still running.

Examples
--------
>>> stale_reason("4242", "node7")
'its process 4242 on node7 no longer exists; finalised when the store was next opened from node7'
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

from mlflow.entities import Run
from mlflow.tracking import MlflowClient

from lwrlab.tracking.job_config.provenance import HOSTNAME_TAG, PID_TAG
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.runs.processes import postpone_abort_alarm, process_alive
from lwrlab.tracking.store.sqlite import retry_locked

log = logging.getLogger(__name__)

KILLED_BY_TAG = "killed_by"
"""Why a run was ended KILLED (a signal's name, or a stale process)."""
OUTPUTS_TAG = "interrupted_outputs"
"""Where the outputs written before the stop are: uploaded as artifacts, or left on disk."""
OUTPUT_DIR_TAG = "hydra_output_dir"


def stale_reason(pid: str, hostname: str) -> str:
    """The ``killed_by`` text of a run whose process died without ending it."""
    return (
        f"its process {pid} on {hostname} no longer exists; "
        f"finalised when the store was next opened from {hostname}"
    )


def end_killed(
    client: MlflowClient,
    run_id: str,
    reason: str,
    output_dir: Path | None,
    redactor: Redactor | None,
    upload: bool,
) -> str:
    """End ``run_id`` KILLED, upload what its job wrote, tag why and where the outputs are.

    Parameters
    ----------
    client, run_id
        The store and the run.
    reason
        Why it was stopped (``"SIGTERM"``, :func:`stale_reason`), tagged ``killed_by`` unless the run
        already says why (a sweep's launching process tags its jobs before it stops them).
    output_dir
        The job output folder on this machine, if any.
    redactor
        Secrets to keep out of the upload; ``None`` reads them from the folder's ``.hydra/`` configs.
    upload
        Upload the folder as the run's artifacts (the run's ``log_artifacts`` setting).

    Returns
    -------
    str
        A sentence saying where the outputs are (also tagged ``interrupted_outputs``).
    """
    from lwrlab.tracking.runs.run_logging import log_output_folder  # the callback module imports this one

    postpone_abort_alarm()  # a Ray process stopped by SIGTERM would abort mid-upload
    if output_dir is None or not output_dir.is_dir():
        where = "no output folder on this machine"
    elif not upload:
        where = f"outputs written so far left on disk in {output_dir} (artifact upload is off)"
    else:
        try:
            log_output_folder(client, run_id, output_dir, redactor or Redactor.for_output_folder(output_dir))
            where = f"outputs written so far uploaded as artifacts (and kept in {output_dir})"
        except Exception as error:  # the store may be going away too: say where the files are
            where = (
                f"outputs written so far left on disk in {output_dir} (upload failed: {type(error).__name__})"
            )
    if KILLED_BY_TAG not in retry_locked(client.get_run, run_id).data.tags:
        retry_locked(client.set_tag, run_id, KILLED_BY_TAG, reason)
    retry_locked(client.set_tag, run_id, OUTPUTS_TAG, where)
    retry_locked(client.set_terminated, run_id, status="KILLED")
    return where


def _output_dir_of(run: Run) -> Path | None:
    folder = run.data.tags.get(OUTPUT_DIR_TAG)
    return Path(folder) if folder else None


def running_runs(client: MlflowClient, experiment_ids: Sequence[str], extra_filter: str = "") -> list[Run]:
    """RUNNING runs of the experiments (at most 1000), with an optional extra MLflow filter clause."""
    filter_string = "attributes.status = 'RUNNING'" + (f" and {extra_filter}" if extra_filter else "")
    return list(
        retry_locked(client.search_runs, list(experiment_ids), filter_string=filter_string, max_results=1000)
    )


def is_stale(run: Run, hostname: str) -> bool:
    """Whether a RUNNING run was started on ``hostname`` by a process that no longer exists."""
    pid = run.data.tags.get(PID_TAG, "")
    return run.data.tags.get(HOSTNAME_TAG) == hostname and pid.isdigit() and not process_alive(int(pid))


def _end_each(client: MlflowClient, runs: Sequence[Run], reasons: Sequence[str], upload: bool) -> list[str]:
    """End each run KILLED for its reason (a failure is warned about, not raised); the ids ended."""
    finalised = []
    for run, reason in zip(runs, reasons, strict=True):
        try:
            where = end_killed(client, run.info.run_id, reason, _output_dir_of(run), None, upload)
        except Exception as error:
            log.warning("could not end run %s KILLED: %s", run.info.run_id, error)
            continue
        log.warning("run %s was left RUNNING (%s): ended KILLED, %s", run.info.run_id, reason, where)
        finalised.append(run.info.run_id)
    return finalised


def finalise_stale_runs(
    client: MlflowClient, experiment_ids: Sequence[str], hostname: str, upload: bool
) -> list[str]:
    """End KILLED every RUNNING run of this host whose process died; returns their run ids.

    Runs started on other hosts are left alone (their processes cannot be checked from here).
    """
    stale = [
        run
        for run in running_runs(client, experiment_ids, f"tags.{HOSTNAME_TAG} = '{hostname}'")
        if is_stale(run, hostname)
    ]
    return _end_each(client, stale, [stale_reason(run.data.tags[PID_TAG], hostname) for run in stale], upload)


def finalise_children(
    client: MlflowClient, experiment_ids: Sequence[str], parent_run_id: str, reason: str, upload: bool
) -> list[str]:
    """End KILLED the RUNNING nested runs of a sweep (their workers are gone); returns their run ids."""
    children = running_runs(client, experiment_ids, f"tags.`mlflow.parentRunId` = '{parent_run_id}'")
    return _end_each(client, children, [reason] * len(children), upload)


__all__ = [
    "KILLED_BY_TAG",
    "OUTPUTS_TAG",
    "end_killed",
    "finalise_children",
    "finalise_stale_runs",
    "is_stale",
    "running_runs",
    "stale_reason",
]
