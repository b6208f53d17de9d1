"""One line on a user's error: Hydra's own lines around an ``lwrlab:`` message left out.

A job that fails on a :class:`~lwrlab.errors.UserError` ends in one line, ``lwrlab: <cause and fix>``
(:class:`lwrlab.cli.UserFacingError`). Hydra writes two more of its own around it: "Error executing job
with overrides: […]" before, "Set the environment variable HYDRA_FULL_ERROR=1 for a complete stack
trace." after. :class:`UserErrorStderr` stands for ``sys.stderr`` while the job runs and drops them
where they surround an ``lwrlab:`` line; every other text (a bug's traceback with Hydra's lines, the
logs) passes unchanged. With ``HYDRA_FULL_ERROR=1`` in the environment, nothing is filtered: Hydra
raises the error whole and Python prints its traceback.

Examples
--------
>>> import io
>>> out = io.StringIO()
>>> stream = UserErrorStderr(out)
>>> _ = stream.write("Error executing job with overrides: ['plant=log']\\n")
>>> _ = stream.write("lwrlab: data.path=x.csv: no such log file\\n")
>>> _ = stream.write("\\nSet the environment variable HYDRA_FULL_ERROR=1 for a complete stack trace.\\n")
>>> stream.flush()
>>> out.getvalue()
'lwrlab: data.path=x.csv: no such log file\\n'
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from typing import TextIO

JOB_FAILED_PREFIX = "Error executing job with overrides:"
"""How Hydra's line before a failed job's error starts (``hydra.core.utils.JobReturn``)."""
FULL_ERROR_HINT = "Set the environment variable HYDRA_FULL_ERROR=1"
"""How Hydra's line after a failed job's error starts (``hydra._internal.utils.run_and_report``)."""
USER_ERROR_PREFIX = "lwrlab: "
"""How a user's error is printed (:class:`lwrlab.cli.UserFacingError`)."""


class UserErrorStderr:
    """A text stream in front of ``target`` that leaves out Hydra's lines around an ``lwrlab:`` error."""

    def __init__(self, target: TextIO) -> None:
        self.target = target
        self._held = ""  # Hydra's "Error executing job" line, until what follows it is known
        self._after_user_error = False

    def write(self, text: str) -> int:
        if text.startswith(JOB_FAILED_PREFIX):
            self._release()
            self._held = text
            return len(text)
        if text.lstrip("\r\n").startswith(FULL_ERROR_HINT) and self._after_user_error:
            self._after_user_error = False
            return len(text)
        if text.startswith(USER_ERROR_PREFIX):
            self._held = ""
            self._after_user_error = True
        elif text.strip():
            self._release()
            self._after_user_error = False
        self.target.write(text)
        return len(text)

    def _release(self) -> None:
        if self._held:
            self.target.write(self._held)
            self._held = ""

    def flush(self) -> None:
        self._release()
        self.target.flush()

    def __getattr__(self, name: str) -> object:  # fileno, isatty, encoding, …: the target's
        return getattr(self.target, name)


@contextlib.contextmanager
def one_line_user_errors() -> Iterator[None]:
    """``sys.stderr`` filtered by :class:`UserErrorStderr` inside the block (unless ``HYDRA_FULL_ERROR``
    asks for Hydra's whole output)."""
    if os.environ.get("HYDRA_FULL_ERROR") == "1":  # Hydra's own test of it
        yield
        return
    original = sys.stderr
    stream = UserErrorStderr(original)
    sys.stderr = stream
    try:
        yield
    finally:
        stream.flush()
        sys.stderr = original


__all__ = ["UserErrorStderr", "one_line_user_errors"]
