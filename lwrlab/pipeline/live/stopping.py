"""When a live task stops: a stop signal, a set duration, a stream gone quiet — a clean stop each.

A live run that a user ends with Ctrl-C (SIGINT) or a supervisor with SIGTERM has done what it was
for: it ends FINISHED with its artifacts, not KILLED. :class:`StopConditions` takes both signals
over while the loop runs (and gives them back after), and says why the loop should end.
"""

from __future__ import annotations

import signal
import threading
import time
from types import FrameType
from typing import Any


class StopConditions:
    """Why a live loop ends: a signal, ``duration_s`` after ``started``, ``idle_s`` without input.

    Use as a context manager around the loop: the signals are taken over inside it.
    """

    def __init__(self, duration_s: float | None, idle_s: float | None) -> None:
        self.duration_s = duration_s
        self.idle_s = idle_s
        self.started = time.monotonic()
        self.signal: str | None = None
        self._event = threading.Event()
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopConditions:
        if threading.current_thread() is threading.main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                self._previous[signum] = signal.signal(signum, self._on_signal)
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        self.signal = signal.Signals(signum).name
        self._event.set()

    def reason(self, last_input_s: float) -> str | None:
        """Why to stop now (``last_input_s``: monotonic time of the last input, NaN before one), or
        None to go on."""
        now = time.monotonic()
        if self.signal is not None:
            return f"stopped by {self.signal}"
        if self.duration_s is not None and now - self.started >= self.duration_s:
            return f"ran its {self.duration_s:g} s"
        if self.idle_s is not None and last_input_s == last_input_s and now - last_input_s >= self.idle_s:
            return f"no input for {self.idle_s:g} s"
        return None

    def wait(self, seconds: float) -> None:
        """Sleep ``seconds`` or until a signal comes."""
        self._event.wait(seconds)


__all__ = ["StopConditions"]
