"""The tracking companion: a process that logs one single run's job to MLflow while the job computes.

Started by :class:`~lwrlab.tracking.companion.companion_link.CompanionLink` (see there for the messages),
usually before Hydra composes the job's config. It imports MLflow at once, then opens the store
named by the settings on the machine's other core while the job's process composes, imports its
numerics and computes, then does what :class:`~lwrlab.tracking.lifecycle.mlflow_callback.InProcessTracking`
does in a job's own process: the run started with params and tags, then metrics, outputs and status.

It ignores SIGINT and SIGTERM: it runs in its own session, and the job's process, which gets the
signals, tells it to end the run KILLED. If the job's process ends without a word (SIGKILL, a crash),
the companion ends the run KILLED itself and exits.
"""

from __future__ import annotations

import logging
import signal
from multiprocessing.connection import Connection
from typing import Any, NoReturn

from lwrlab.garbage_collection import relax_garbage_collection
from lwrlab.tracking.runs.processes import exit_at_once

log = logging.getLogger(__name__)

GONE_REASON = "the end of the job's process"
"""``killed_by`` of a run whose job's process ended without ending it (SIGKILL, a crash)."""


class ForwardingHandler(logging.Handler):
    """Sends every log record to the job's process, which prints and files it with its own."""

    def __init__(self, connection: Connection) -> None:
        super().__init__()
        self.connection = connection

    def emit(self, record: logging.LogRecord) -> None:
        try:
            record.msg, record.args = record.getMessage(), None
            if record.exc_info:
                record.exc_text = logging.Formatter().formatException(record.exc_info)
                record.exc_info = None
            self.connection.send(("log", record))
        except Exception:  # broad: logging must never stop the companion (the job may be gone)
            self.handleError(record)


def _forward_logs(connection: Connection) -> None:
    root = logging.getLogger()
    for handler in list(root.handlers):
        root.removeHandler(handler)
    root.addHandler(ForwardingHandler(connection))


def serve(connection: Connection) -> int:
    """Handle the job's messages until ``close`` or until the job's process ends; the exit status."""
    _forward_logs(connection)  # from the start: warnings of the imports reach the job too

    # The slow part, on the other core while the job composes its config and computes.
    from hydra.core.hydra_config import HydraConfig
    from hydra.core.utils import setup_globals

    from lwrlab.tracking.companion.callback import MlflowTracking  # the class the configs name
    from lwrlab.tracking.lifecycle import job_state
    from lwrlab.tracking.lifecycle.mlflow_callback import InProcessTracking

    try:
        first: tuple[Any, ...] = connection.recv()
    except (EOFError, OSError):  # launched early for a job that logs no single run
        return 0
    if first[0] == "close":
        return 0
    kind, settings, levels = first
    assert kind == "settings", kind
    for name, level in levels.items():
        logging.getLogger(name or None).setLevel(level)
    setup_globals()  # Hydra's resolvers (${hydra:...}) for the job's config
    tracking = InProcessTracking(**settings, configured_as=MlflowTracking)
    while True:
        try:
            message: tuple[Any, ...] = connection.recv()
        except (EOFError, OSError):
            tracking.end_job_killed(GONE_REASON)
            return 0
        kind = message[0]
        try:
            if kind == "job_start":
                config, started_ms = message[1:]
                HydraConfig.instance().set_config(config)
                tracking.start_job(config, started_ms)
            elif kind == "job_end":
                config, job_return, recorded = message[1:]
                if recorded is not None:
                    job_state.record_metrics(recorded)
                tracking.end_job(config, job_return)
            elif kind == "stop":
                tracking.end_job_killed(message[1])
            elif kind == "close":
                return 0
        except Exception as error:  # broad: the job must get its answer, whatever went wrong here
            log.warning("the tracking companion failed on %r (%s: %s)", kind, type(error).__name__, error)
        if kind in ("job_end", "stop"):
            connection.send(("done",))


def main(fd: int) -> NoReturn:
    """Entry point: serve the job's process on the socket ``fd``, then exit at once.

    The run is ended by then; exiting without the interpreter's shutdown (MLflow's and SQLAlchemy's
    exit hooks, the collection of MLflow's modules) saves the job most of a second of waiting.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    relax_garbage_collection()  # MLflow's imports
    with Connection(fd) as connection:
        status = serve(connection)
    exit_at_once(status)


__all__ = ["GONE_REASON", "ForwardingHandler", "main", "serve"]
