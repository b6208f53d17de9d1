"""The job's side of the tracking companion: start it, send it the job, wait for its run to be logged.

:class:`CompanionLink` starts :mod:`lwrlab.tracking.companion.process` as a child process and talks to it
over a socket pair with pickled messages (``multiprocessing.connection`` framing):

* to the companion: ``("settings", settings, levels)`` once (it imports MLflow before it reads
  them: :meth:`CompanionLink.launch` may start it before the job knows its settings),
  ``("job_start", config, started_ms)``, ``("job_end", config, job_return, recorded_metrics)``,
  ``("stop", reason)``, ``("close",)`` (before the settings: exit, having logged nothing);
* from it: ``("log", record)`` for each log record (re-emitted here, so that its warnings reach the
  job's console and log file) and ``("done",)`` after a ``job_end`` or a ``stop``.

A reader thread re-emits the log records as they come; the job's thread only waits for ``done``.
This module imports nothing of MLflow: that is the point of the companion.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import queue
import socket
import subprocess
import sys
import threading
from collections.abc import Mapping
from multiprocessing.connection import Connection
from typing import Any

from hydra.core.utils import JobReturn, JobStatus
from omegaconf import DictConfig

from lwrlab.tracking.runs.forwarded_error import ForwardedError

log = logging.getLogger(__name__)

CLOSE_TIMEOUT_S = 10.0
"""How long the job's process waits for the companion to exit after its run is logged."""


class CompanionGone(RuntimeError):
    """The companion process ended (or never answered): nothing more can be logged through it."""


def logger_levels() -> dict[str, int]:
    """The levels set in this process (root and named loggers), for the companion to filter alike."""
    levels = {"": logging.getLogger().level}
    for name, logger in logging.root.manager.loggerDict.items():
        if isinstance(logger, logging.Logger) and logger.level != logging.NOTSET:
            levels[name] = logger.level
    return levels


def forwarded_job_return(job_return: JobReturn) -> JobReturn:
    """The parts of ``job_return`` the companion uses (status, value or error), in a picklable form."""
    value: Any = job_return._return_value
    if job_return.status == JobStatus.FAILED and isinstance(value, BaseException):
        value = ForwardedError.of(value)
    return JobReturn(status=job_return.status, _return_value=value)


def _absolute(path: list[str]) -> list[str]:
    """``sys.path`` with its relative entries ('' is the current folder) made absolute, for a child."""
    return [os.path.abspath(entry or os.curdir) for entry in path]


def _emit(record: logging.LogRecord) -> None:
    logger = logging.getLogger(record.name)
    if logger.isEnabledFor(record.levelno):
        logger.handle(record)


class CompanionLink:
    """A running companion process; :meth:`start` makes one."""

    def __init__(self, process: subprocess.Popen[bytes], connection: Connection) -> None:
        self.process = process
        self._connection = connection
        self._replies: queue.Queue[tuple[Any, ...] | None] = queue.Queue()
        self._send_lock = threading.Lock()
        threading.Thread(target=self._read, name="tracking-companion-reader", daemon=True).start()

    @classmethod
    def launch(cls) -> CompanionLink:
        """Start a companion, which imports MLflow at once and then waits for :meth:`configure`.

        It imports modules from this process's ``sys.path``, in its own session (a Ctrl-C reaches the
        job, which tells the companion), and inherits stdout and stderr. Raises ``OSError`` if it
        cannot be started. A companion that is closed before it was configured exits quietly.
        """
        ours, theirs = socket.socketpair()
        with ours, theirs:
            bootstrap = (
                "import json, sys; sys.path[:] = json.loads(sys.argv[1]); "
                "from lwrlab.tracking.companion.process import main; main(int(sys.argv[2]))"
            )
            process = subprocess.Popen(
                [sys.executable, "-c", bootstrap, json.dumps(_absolute(sys.path)), str(theirs.fileno())],
                pass_fds=(theirs.fileno(),),
                stdin=subprocess.DEVNULL,
                start_new_session=True,
            )
            return cls(process, Connection(ours.detach()))

    @classmethod
    def start(cls, settings: Mapping[str, Any]) -> CompanionLink:
        """Start a companion that logs with ``settings`` (the tracking callback's constructor values)."""
        link = cls.launch()
        link.configure(settings)
        return link

    def configure(self, settings: Mapping[str, Any]) -> None:
        """Tell the companion how to log (the tracking callback's constructor values) and at which levels."""
        self.send(("settings", dict(settings), logger_levels()))

    def send(self, message: tuple[Any, ...]) -> None:
        """Send ``message``; raises :class:`CompanionGone` if the companion has ended."""
        try:
            with self._send_lock:
                self._connection.send(message)
        except OSError as error:  # BrokenPipeError, ConnectionResetError: the companion ended
            raise CompanionGone(f"the tracking companion ended ({error})") from error

    def request(self, message: tuple[Any, ...]) -> None:
        """Send ``message`` and wait until the companion has done it; :class:`CompanionGone` if it ends."""
        self.send(message)
        if self._replies.get() is None:
            raise CompanionGone(f"the tracking companion ended with status {self.process.wait()}")

    def job_start(self, config: DictConfig, started_ms: int) -> None:
        """Let the companion start the job's run (it does not wait: the job goes on meanwhile)."""
        self.send(("job_start", config, started_ms))

    def job_end(self, config: DictConfig, job_return: JobReturn, recorded: Mapping[str, Any] | None) -> None:
        """Wait until the companion has logged the job's metrics and outputs and ended its run."""
        self.request(("job_end", config, forwarded_job_return(job_return), recorded))

    def stop(self, reason: str) -> None:
        """Wait until the companion has ended the run KILLED (``reason``: the signal's name)."""
        self.request(("stop", reason))

    def discard(self) -> None:
        """End a companion that has no run (never configured, or its job started none) at once."""
        self.process.kill()
        self.process.wait()
        self._connection.close()

    def close(self) -> None:
        """Let the companion exit and wait for it (a bounded time: its run is already logged)."""
        with contextlib.suppress(CompanionGone):
            self.send(("close",))
        try:
            self.process.wait(timeout=CLOSE_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            log.debug("the tracking companion did not exit within %s s; terminating it", CLOSE_TIMEOUT_S)
            self.process.kill()
            self.process.wait()
        self._connection.close()

    def _read(self) -> None:
        while True:
            try:
                message = self._connection.recv()
            except (EOFError, OSError):
                self._replies.put(None)
                return
            if message[0] == "log":
                _emit(message[1])
            else:
                self._replies.put(message)


__all__ = [
    "CLOSE_TIMEOUT_S",
    "CompanionGone",
    "CompanionLink",
    "ForwardedError",
    "forwarded_job_return",
    "logger_levels",
]
