"""Matplotlib, imported on first drawing and set to write files only.

Importing matplotlib costs a noticeable part of a second; a job that draws nothing (or draws at its
end) should not pay it at start-up, so every figure function asks for ``pyplot()`` when it draws.
"""

from __future__ import annotations

from types import ModuleType


def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` with the non-interactive Agg backend (no display on servers and CI)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
