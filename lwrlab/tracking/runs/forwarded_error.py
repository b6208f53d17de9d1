"""A failed job's error in a form that crosses processes: what the companion logs, and the error file.

The job's process sends its error to the tracking companion
(:mod:`lwrlab.tracking.companion.companion_link`), and the run's ``error.txt``
(:func:`lwrlab.tracking.runs.run_logging.write_error_file`) keeps its traceback. This module imports
nothing of MLflow or Hydra, so that the job's process can load it cheaply.
"""

from __future__ import annotations

import traceback


class ForwardedError(Exception):
    """A failed job's error as the companion sees it: its type's name, message and formatted traceback.

    Exceptions and their tracebacks do not always pickle; these three strings do.
    """

    def __init__(self, type_name: str, message: str, traceback_text: str) -> None:
        super().__init__(type_name, message, traceback_text)
        self.type_name = type_name
        self.message = message
        self.traceback_text = traceback_text

    def __str__(self) -> str:
        return self.message

    @classmethod
    def of(cls, error: BaseException) -> ForwardedError:
        return cls(type(error).__name__, str(error), "".join(traceback.format_exception(error)))
