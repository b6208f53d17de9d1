"""New matplotlib figures that only ever go to files, imported on the first drawing.

Figures are plain :class:`matplotlib.figure.Figure` objects, not pyplot's: nothing registers them
in a global state to close, no GUI backend is ever chosen (servers and CI have no display), and
``matplotlib.pyplot`` (a third of a second to import) is never imported. Importing matplotlib still
costs part of a second; a job that draws nothing (or draws at its end) should not pay it at
start-up, so every figure function asks for its figure here when it draws.

Examples
--------
>>> fig, ax = subplots(figsize=(3, 2))
>>> _ = ax.plot([0, 1], [0, 1])
>>> type(fig).__name__
'Figure'
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def subplots(*grid: int, figsize: tuple[float, float], **options: Any) -> tuple[Figure, Any]:
    """A new figure and its axes, as ``pyplot.subplots(*grid, figsize=…, **options)`` returns them."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.subplots(*grid, **options)


def set_margins(
    fig: Figure,
    left: float,
    right: float,
    top: float,
    bottom: float,
    hspace: float = 0.2,
    wspace: float = 0.2,
) -> None:
    """Margins in inches (spaces between axes as fractions of their size, as matplotlib takes them).

    Fixed margins instead of ``tight_layout``, which lays out every tick label once more before the
    figure is drawn (a third of the drawing time of a seven-panel figure). The margins fit the
    labels the figure functions write; a figure whose labels vary widely keeps ``tight_layout``.
    """
    width, height = fig.get_size_inches()
    fig.subplots_adjust(
        left=left / width,
        right=1 - right / width,
        top=1 - top / height,
        bottom=bottom / height,
        hspace=hspace,
        wspace=wspace,
    )


__all__ = ["set_margins", "subplots"]
