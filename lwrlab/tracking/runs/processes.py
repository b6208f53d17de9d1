"""Processes of a job or a sweep: whether one still lives, its workers, the signals that stop it.

Used by the tracking callback so that every stop ends runs in a final state: a stop signal (SIGINT,
SIGTERM) becomes a :class:`JobInterrupted` exception after the callback has finalised its runs; a
sweep's launching process terminates its worker processes (joblib's loky workers, a local Ray
instance) so that none outlives it; a resumed sweep finalises runs whose process no longer exists
(the ``pid`` and ``hostname`` tags of :mod:`lwrlab.tracking.job_config.provenance`); a Ray process stopped by
SIGTERM gets time to end its runs before Ray's crash handler aborts it.

Examples
--------
>>> import os
>>> process_alive(os.getpid())
True
"""

from __future__ import annotations

import atexit
import contextlib
import logging
import os
import signal
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from types import FrameType
from typing import Any, NoReturn

STOP_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM)
EXIT_STATUS_OFFSET = 128  # a process ended by signal N exits with 128 + N (shell convention)
FINALISE_DEADLINE_S = 60
"""Seconds a Ray process stopped by SIGTERM gets to end its runs (see :func:`postpone_abort_alarm`)."""


class JobInterrupted(KeyboardInterrupt):
    """A stop signal (SIGINT or SIGTERM) reached a process that runs a job or a sweep.

    A ``KeyboardInterrupt`` so that code which stops on Ctrl-C stops on SIGTERM alike; Hydra catches
    only ``Exception``, so it reaches the top of the process (or the launcher).
    """

    def __init__(self, signum: int) -> None:
        super().__init__(f"stopped by {signal_name(signum)}")
        self.signum = signum

    @property
    def exit_status(self) -> int:
        """The shell's status for a process ended by this signal (130 for SIGINT, 143 for SIGTERM)."""
        return EXIT_STATUS_OFFSET + self.signum


def signal_name(signum: int) -> str:
    """``SIGTERM`` for 15, ``signal 99`` for an unknown number."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


def process_alive(pid: int) -> bool:
    """Whether process ``pid`` exists on this machine and is not a zombie waiting to be reaped."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: it exists
        return True
    stat = Path(f"/proc/{pid}/stat")
    try:
        state = stat.read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True  # no /proc (macOS): os.kill said it exists
    return state not in ("Z", "X")


def _parents_from_proc() -> dict[int, int] | None:
    proc = Path("/proc")
    if not proc.is_dir():
        return None
    parents = {}
    for entry in proc.iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
                parents[int(entry.name)] = int(fields[1])
            except (OSError, IndexError, ValueError):
                continue  # the process ended while we looked
    return parents


def _parents_from_ps() -> dict[int, int]:
    import subprocess

    try:
        listing = subprocess.run(
            ["ps", "-A", "-o", "pid=,ppid="], capture_output=True, text=True, timeout=10, check=False
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return {}
    parents = {}
    for line in listing.splitlines():
        fields = line.split()
        if len(fields) == 2 and fields[0].isdigit() and fields[1].isdigit():
            parents[int(fields[0])] = int(fields[1])
    return parents


def descendant_pids(pid: int) -> list[int]:
    """Every living descendant of process ``pid`` (children first, then theirs)."""
    parents = _parents_from_proc()
    if parents is None:
        parents = _parents_from_ps()
    children: dict[int, list[int]] = {}
    for child, parent in parents.items():
        children.setdefault(parent, []).append(child)
    found: list[int] = []
    frontier = [pid]
    while frontier:
        next_frontier = []
        for parent in frontier:
            for child in children.get(parent, []):
                if child not in found and child != pid:
                    found.append(child)
                    next_frontier.append(child)
        frontier = next_frontier
    return found


def _command_line(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def worker_pids(pid: int) -> list[int]:
    """The descendants of ``pid`` to terminate when it stops: all but loky's resource tracker.

    The resource tracker removes the pool's shared memory and exits by itself once ``pid`` has ended
    (its pipe closes); killing it first would only make loky start another one.
    """
    return [child for child in descendant_pids(pid) if "resource_tracker" not in _command_line(child)]


def send_signal(pids: Iterable[int], signum: int) -> list[int]:
    """Send ``signum`` to each process that still exists; returns those it reached."""
    reached = []
    for pid in pids:
        try:
            os.kill(pid, signum)
            reached.append(pid)
        except (ProcessLookupError, PermissionError):
            continue
    return reached


def wait_until(condition: Callable[[], bool], timeout_s: float, poll_s: float = 0.2) -> bool:
    """Poll ``condition`` until it holds or ``timeout_s`` passes; returns whether it held."""
    deadline = time.monotonic() + timeout_s
    while True:
        if condition():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(poll_s)


def terminate_processes(pids: Iterable[int], grace_s: float) -> list[int]:
    """SIGTERM, then SIGKILL after ``grace_s`` for those still alive; returns the pids that were killed."""
    pids = send_signal(pids, signal.SIGTERM)
    wait_until(lambda: not any(process_alive(pid) for pid in pids), grace_s)
    survivors = [pid for pid in pids if process_alive(pid)]
    send_signal(survivors, signal.SIGKILL)
    wait_until(lambda: not any(process_alive(pid) for pid in survivors), 5.0)
    return survivors


def postpone_abort_alarm(seconds: int = FINALISE_DEADLINE_S) -> bool:
    """Give a Ray process ``seconds`` to end its runs before the alarm that aborts it on SIGTERM.

    Ray's core (a driver or a worker) handles SIGTERM with absl's failure-signal handler, which
    prints a stack trace and arms ``alarm(3)``: its SIGALRM aborts the process three seconds later,
    lest the exit hang. Ending runs (store writes, uploads), after Ray's own shutdown, takes longer
    on a busy machine, and the abort left runs RUNNING. A pending alarm is re-armed to ``seconds``
    from now, so a hung exit still ends. Returns whether an alarm was postponed; no-op (``False``)
    in a process without Ray's core or without a pending alarm.
    """
    if "ray._raylet" not in sys.modules or not hasattr(signal, "alarm"):
        return False
    remaining = signal.alarm(0)
    if remaining == 0:
        return False  # none pending (cancelling none changed nothing)
    signal.alarm(max(remaining, seconds))
    return True


def register_at_exit(hook: Callable[[], object], launcher_target: str) -> None:
    """Run ``hook`` when this process exits; before Ray's own shutdown when the launcher is Ray's.

    At-exit hooks run last registered first, and Ray registers its shutdown when first imported,
    which the Ray launcher does after the sweep started: that shutdown (0.6 to 1.7 s on a busy
    machine) would run first, inside the 3 s that Ray's SIGTERM handler leaves before it aborts the
    process (see :func:`postpone_abort_alarm`). Importing Ray here, first, puts ``hook`` ahead of it.
    """
    if "hydra_ray_launcher" in launcher_target:
        with contextlib.suppress(ImportError):
            import ray  # noqa: F401  (registers Ray's at-exit shutdown now, so that ``hook`` runs before it)
    atexit.register(hook)


Handler = Callable[[int, FrameType | None], Any] | int | None


def exit_at_once(status: int) -> NoReturn:
    """End this process with ``status`` after flushing its logs and streams, skipping the interpreter's
    shutdown (exit hooks, module teardown): for a process whose work is done or must not go on."""
    logging.shutdown()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


def install_stop_handler(handler: Callable[[int, FrameType | None], Any]) -> dict[int, Handler] | None:
    """Make ``handler`` the handler of SIGINT and SIGTERM; returns the previous handlers to restore.

    ``None`` (and nothing changed) outside the main thread, where Python cannot set handlers (some
    launchers run jobs in threads): the launching process's handler then covers the job.
    """
    previous: dict[int, Handler] = {}
    try:
        for signum in STOP_SIGNALS:
            previous[signum] = signal.signal(signum, handler)
    except ValueError:
        restore_handlers(previous)
        return None
    return previous


def restore_handlers(previous: dict[int, Handler] | None) -> None:
    """Put back the handlers :func:`install_stop_handler` replaced."""
    for signum, handler in (previous or {}).items():
        with contextlib.suppress(ValueError, TypeError):
            signal.signal(signum, handler if handler is not None else signal.SIG_DFL)


__all__ = [
    "FINALISE_DEADLINE_S",
    "JobInterrupted",
    "descendant_pids",
    "exit_at_once",
    "install_stop_handler",
    "postpone_abort_alarm",
    "process_alive",
    "register_at_exit",
    "restore_handlers",
    "send_signal",
    "signal_name",
    "terminate_processes",
    "wait_until",
    "worker_pids",
]
