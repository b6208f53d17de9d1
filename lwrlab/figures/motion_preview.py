"""The preview of an exciting motion: the robot at key poses, its closest approaches marked and named.

The picture a person checks before pressing play. One 3-D panel per snapshot (up to six, three per
row), every panel with the same limits and an equal aspect (the robot is never squashed), the robot's
bodies coloured per body (the same colour in every panel), world objects grey and translucent, the
mounting surface as a translucent square. Each closest approach is a red segment between its two
closest points, numbered, on the panel of its time; under the panels every approach is listed,
nearest first, violations (distance below the clearance) in red.

The caller poses the meshes (:class:`BodyMesh`, base frame) at the times :func:`key_times` picks; the
approaches come from the collision check (:class:`~lwrlab.excitation.approaches.ClosestApproach`).

Drawing is kept fast by thinning: a snapshot with more than ``max_faces`` triangles keeps every k-th
triangle of each large mesh (:func:`decimate_meshes`). That leaves holes, which each drawn triangle's
outline (1.5 pt, in its fill colour) mostly closes on fine meshes; coarse meshes with large triangles
may look perforated, but keep their shape and extent. Six panels of a seven-link arm with a thousand
triangles per link draw in about a second on two cores (matplotlib's import included).

What is drawn (the snapshots, their times, the thinning) lives in
:mod:`lwrlab.figures.motion_snapshots`; this module lays it out and draws it.

Examples
--------
>>> import tempfile
>>> box = BodyMesh("link1", np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float),
...                np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]))
>>> approach = ClosestApproach("world", "link1", "table", 0.02, 0.0, np.zeros(3), np.array([0, 0, -0.02]))
>>> with tempfile.TemporaryDirectory() as folder:
...     path = motion_preview_figure([Snapshot(0.0, (box,), "start pose")], [approach],
...                                  Path(folder) / "preview.png", "a tetrahedron")
...     path.name, path.stat().st_size > 10_000
('preview.png', True)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lwrlab.excitation.approaches import ClosestApproach
from lwrlab.figures.motion_snapshots import KEEP_WHOLE, BodyMesh, Snapshot, decimate_meshes, key_times

if TYPE_CHECKING:
    from matplotlib.figure import Figure

MAX_SNAPSHOTS = 6
"""Most panels of one preview (two rows of three)."""
COLUMNS = 3
"""Panels per row."""
PANEL_SIZE = (4.4, 4.0)
"""Width and height (in) of one panel."""
DPI = 110
"""Resolution of the saved PNG (dots per inch)."""
VIEW = (22.0, -55.0)
"""Elevation and azimuth (degrees) of every panel: from above the front right of the base."""
APPROACH_COLOR = (0.85, 0.0, 0.0)
"""Red: the approach segments and the violated rows of the list (no body is drawn red)."""
WORLD_COLOR = (0.55, 0.55, 0.55, 0.3)
"""Translucent grey of the world objects."""

_ROW_HEIGHT = 0.18  # in, one line of the list of approaches (8 pt monospace)
_TOP = 0.55  # in, the suptitle
_LEGEND = 0.45  # in, the row of body colours under the panels
_LIST_ROWS_PER_COLUMN = 10  # the list of approaches goes to two columns beyond this


def preview_size(n_snapshots: int, n_approaches: int) -> tuple[float, float]:
    """Width and height (in) of the preview of ``n_snapshots`` panels listing ``n_approaches``."""
    columns = min(max(n_snapshots, 1), COLUMNS)
    rows = math.ceil(max(n_snapshots, 1) / COLUMNS)
    list_rows = max(n_approaches, 1)
    if n_approaches > _LIST_ROWS_PER_COLUMN:
        list_rows = math.ceil(n_approaches / 2)
    width = max(columns, 2) * PANEL_SIZE[0]
    height = _TOP + rows * PANEL_SIZE[1] + _LEGEND + (list_rows + 1.5) * _ROW_HEIGHT + 0.15
    return width, height


def motion_preview_figure(
    snapshots: Sequence[Snapshot],
    approaches: Sequence[ClosestApproach],
    path: Path,
    title: str,
    mounting_height: float | None = 0.0,
    max_faces: int = 4000,
    *,
    time_tolerance: float = 5e-4,
    view: tuple[float, float] = VIEW,
) -> Path:
    """The robot at each snapshot, its closest approaches marked and listed; saved as a PNG at ``path``.

    Parameters
    ----------
    snapshots : one to :data:`MAX_SNAPSHOTS` poses, drawn in the given order, three per row.
    approaches : closest approaches (self and world), numbered nearest first. Each is labelled in the
        upper left corner of the snapshot nearest its time, and drawn there as a red segment from
        ``point_a`` to ``point_b`` (ends marked, tagged with its number) when the snapshot lies within
        ``time_tolerance`` of it (half a sample: 0.5 ms at 1 kHz); else its label says "pose of another
        time" and nothing floats beside the robot. All are listed under the panels, violations in red.
    path : the PNG written.
    title : the figure's title.
    mounting_height : height (m, base frame) of the surface the robot stands on, drawn as a
        translucent square under it; None: no surface.
    max_faces : most triangles drawn per snapshot (see :func:`decimate_meshes`).
    time_tolerance : largest time difference (s) at which a snapshot shows an approach's pose.
    view : elevation and azimuth (degrees) of every panel.

    Returns
    -------
    ``path``.
    """
    if not 1 <= len(snapshots) <= MAX_SNAPSHOTS:
        raise ValueError(f"{len(snapshots)} snapshots: one to {MAX_SNAPSHOTS} can be drawn")
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # type: ignore[import-untyped]

    ordered = sorted(approaches, key=lambda a: a.distance)
    width, height = preview_size(len(snapshots), len(ordered))
    fig = Figure(figsize=(width, height))
    columns = min(len(snapshots), COLUMNS)
    rows = math.ceil(len(snapshots) / COLUMNS)
    panels_bottom = height - _TOP - rows * PANEL_SIZE[1]
    used = columns * PANEL_SIZE[0] / width  # fewer than two panels: centred in a wider figure
    grid = fig.add_gridspec(
        rows,
        columns,
        left=(1 - used) / 2 + 0.01,
        right=(1 + used) / 2 - 0.01,
        top=1 - _TOP / height,
        bottom=panels_bottom / height,
        wspace=0.02,
        hspace=0.1,
    )
    colors = _body_colors(snapshots)
    lower, upper = _limits(snapshots, mounting_height)
    times = np.array([s.t for s in snapshots])
    for index, snapshot in enumerate(snapshots):
        ax = fig.add_subplot(grid[index // COLUMNS, index % COLUMNS], projection="3d")
        ax.computed_zorder = False  # the floor first, then the bodies (depth sorted), approaches on top
        ax.view_init(elev=view[0], azim=view[1])
        ax.set(xlim=(lower[0], upper[0]), ylim=(lower[1], upper[1]), zlim=(lower[2], upper[2]))
        ax.set_box_aspect(tuple(upper - lower))  # equal aspect: a metre is as long along x, y and z
        _style_axes(ax)
        if mounting_height is not None:
            corners = [
                (lower[0], lower[1], mounting_height),
                (upper[0], lower[1], mounting_height),
                (upper[0], upper[1], mounting_height),
                (lower[0], upper[1], mounting_height),
            ]
            floor = Poly3DCollection([corners], facecolors=(0.80, 0.72, 0.55, 0.35), edgecolors="0.6")
            floor.set_zorder(0)
            ax.add_collection3d(floor)
        triangles, face_colors, edge_colors = _triangles(decimate_meshes(snapshot.meshes, max_faces), colors)
        if len(triangles):
            bodies = Poly3DCollection(
                triangles,
                facecolors=face_colors,
                edgecolors=edge_colors,
                linewidths=1.5,
                antialiased=False,
                shade=True,
            )
            bodies.set_zorder(1)
            ax.add_collection3d(bodies)
        drawn = [
            (number, approach, bool(abs(times[index] - approach.t) <= time_tolerance))
            for number, approach in enumerate(ordered, start=1)
            if int(np.argmin(np.abs(times - approach.t))) == index
        ]
        for number, approach, at_its_time in drawn:
            if at_its_time:  # a segment on another time's pose would float beside the robot
                _draw_approach(ax, number, approach, at_its_time)
        if drawn:
            _approach_labels(ax, drawn)
        name = f" — {snapshot.label}" if snapshot.label else ""
        ax.set_title(f"t = {snapshot.t:.2f} s{name}", fontsize=10, pad=0)
    _body_legend(fig, colors, snapshots, bottom=(panels_bottom - _LEGEND) / height, height=_LEGEND / height)
    _approach_list(fig, ordered, top=(panels_bottom - _LEGEND) / height, row=_ROW_HEIGHT / height)
    fig.suptitle(title, y=1 - 0.12 / height, va="top", fontsize=13)
    fig.savefig(path, dpi=DPI)
    return path


def _body_colors(snapshots: Sequence[Snapshot]) -> dict[str, tuple[float, float, float, float]]:
    """One colour per robot body, by first appearance; tab10 (tab20 beyond 8) without its reds and greys."""
    from matplotlib import colormaps

    names = list(dict.fromkeys(m.name for s in snapshots for m in s.meshes if not m.world))
    if len(names) <= 8:
        palette = [colormaps["tab10"](i) for i in (0, 1, 2, 4, 5, 6, 8, 9)]
    else:
        palette = [colormaps["tab20"](i) for i in range(20) if i not in (6, 7, 14, 15)]
    return {name: palette[i % len(palette)] for i, name in enumerate(names)}


def _triangles(
    meshes: Sequence[BodyMesh], colors: dict[str, tuple[float, float, float, float]]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(F, 3, 3) corners, (F, 4) RGBA fill and (F, 4) RGBA edge colours of every triangle of the meshes.

    A robot triangle's edge has its fill's colour: the stroke closes the small holes thinning leaves.
    World objects have no edges (their triangulation would show through the translucent fill).
    """
    if not meshes:
        return np.zeros((0, 3, 3)), np.zeros((0, 4)), np.zeros((0, 4))
    corners = [np.asarray(m.vertices, dtype=float)[np.asarray(m.faces, dtype=np.intp)] for m in meshes]
    fill = [np.tile(WORLD_COLOR if m.world else colors[m.name], (len(m.faces), 1)) for m in meshes]
    edge = [np.tile((0.0, 0.0, 0.0, 0.0) if m.world else colors[m.name], (len(m.faces), 1)) for m in meshes]
    return (
        np.concatenate(corners).reshape(-1, 3, 3),
        np.concatenate(fill).reshape(-1, 4),
        np.concatenate(edge).reshape(-1, 4),
    )


def _limits(snapshots: Sequence[Snapshot], mounting_height: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners (m) of the box around every vertex of every snapshot, padded by 5 %."""
    points = [np.asarray(m.vertices, dtype=float).reshape(-1, 3) for s in snapshots for m in s.meshes]
    points = [p for p in points if len(p)] or [np.zeros((1, 3))]
    lower = np.min([p.min(axis=0) for p in points], axis=0)
    upper = np.max([p.max(axis=0) for p in points], axis=0)
    if mounting_height is not None:
        lower[2], upper[2] = min(lower[2], mounting_height), max(upper[2], mounting_height)
    pad = 0.05 * max(float(np.max(upper - lower)), 0.1)
    return lower - pad, upper + pad


def _style_axes(ax: Any) -> None:
    """Light panes, few small ticks: the robot is the picture, the scale a hint."""
    for axis, name in ((ax.xaxis, "x"), (ax.yaxis, "y"), (ax.zaxis, "z")):
        axis.set_pane_color((0.97, 0.97, 0.97, 1.0))
        axis.set_major_locator(_locator())
        axis.set_tick_params(labelsize=6, pad=-2)
        axis.set_label_text(f"{name} [m]", fontsize=7)
        axis.labelpad = -8
    ax.grid(True, linewidth=0.3)


def _locator() -> Any:
    from matplotlib.ticker import MaxNLocator

    return MaxNLocator(nbins=4)


def _draw_approach(ax: Any, number: int, approach: ClosestApproach, at_its_time: bool) -> None:
    """A red segment from point_a to point_b, its ends marked, tagged with its number."""
    a, b = np.asarray(approach.point_a, dtype=float), np.asarray(approach.point_b, dtype=float)
    ax.plot(
        [a[0], b[0]],
        [a[1], b[1]],
        [a[2], b[2]],
        color=APPROACH_COLOR,
        linestyle="-" if at_its_time else "--",
        linewidth=2.0,
        marker="o",
        markersize=4.5,
        markeredgecolor="white",
        markeredgewidth=0.6,
        zorder=5,
    )
    ax.text(
        *(a + b) / 2,
        f" {number} ",
        color=APPROACH_COLOR,
        fontsize=8,
        fontweight="bold",
        zorder=6,
        ha="left",
        va="bottom",
        bbox={"boxstyle": "round,pad=0.1", "facecolor": "white", "edgecolor": APPROACH_COLOR, "lw": 0.6},
    )


def _approach_labels(ax: Any, drawn: Sequence[tuple[int, ClosestApproach, bool]]) -> None:
    """The labels of the approaches drawn in a panel, in its upper left corner (above the robot's reach)."""
    lines = [
        f"{number}  {approach.label}" + ("" if at_its_time else "  (pose of another time)")
        for number, approach, at_its_time in drawn
    ]
    ax.text2D(
        0.01,
        0.99,
        "\n".join(lines),
        transform=ax.transAxes,
        color=APPROACH_COLOR,
        fontsize=7.5,
        va="top",
        zorder=7,
        bbox={"boxstyle": "square,pad=0.2", "facecolor": "white", "edgecolor": "none", "alpha": 0.85},
    )


def _body_legend(
    fig: Figure,
    colors: dict[str, tuple[float, float, float, float]],
    snapshots: Sequence[Snapshot],
    bottom: float,
    height: float,
) -> None:
    """One row of colour patches naming the bodies, the world objects last (grey)."""
    from matplotlib.patches import Patch

    world = list(dict.fromkeys(m.name for s in snapshots for m in s.meshes if m.world))
    handles = [Patch(facecolor=color, label=name) for name, color in colors.items()]
    handles += [Patch(facecolor=WORLD_COLOR, edgecolor="0.5", label=f"{name} (world)") for name in world]
    if handles:
        fig.legend(
            handles=handles,
            loc="center",
            bbox_to_anchor=(0.0, bottom, 1.0, height),
            ncol=len(handles) if len(handles) <= 10 else math.ceil(len(handles) / 2),
            fontsize=8,
            frameon=False,
            handlelength=1.2,
            columnspacing=1.2,
        )


def _approach_list(fig: Figure, ordered: Sequence[ClosestApproach], top: float, row: float) -> None:
    """The approaches, nearest first, a monospace line each (two columns beyond ten), violations in red."""
    text: dict[str, Any] = {"fontsize": 8, "family": "monospace", "va": "top"}
    if not ordered:
        fig.text(0.01, top, "closest approaches: none given", **text)
        return
    bodies = [f"{a.body_a}–{a.body_b}" for a in ordered]
    width = max(len(name) for name in [*bodies, "bodies"])
    header = "  ".join(
        (f"{'#':>2}", f"{'kind':<5}", f"{'bodies':<{width}}", "distance [mm]", "clearance [mm]", "t [s]")
    )
    columns = 2 if len(ordered) > _LIST_ROWS_PER_COLUMN else 1
    per_column = math.ceil(len(ordered) / columns)
    for column in range(columns):
        x = 0.01 + column * 0.5
        fig.text(x, top, "closest approaches, nearest first (red: closer than the clearance)", **text)
        fig.text(x, top - row, header, color="0.35", **text)
        for line, index in enumerate(
            range(column * per_column, min((column + 1) * per_column, len(ordered)))
        ):
            a = ordered[index]
            cells = (
                f"{index + 1:>2}",
                f"{a.kind:<5}",
                f"{bodies[index]:<{width}}",
                f"{1000 * a.distance:>13.1f}",
                f"{1000 * a.clearance:>14.1f}",
                f"{a.t:>5.2f}",
            )
            fig.text(
                x,
                top - (line + 2) * row,
                "  ".join(cells) + ("  VIOLATED" if a.violated else ""),
                color=APPROACH_COLOR if a.violated else "black",
                fontweight="bold" if a.violated else "normal",
                **text,
            )


__all__ = [
    "KEEP_WHOLE",
    "BodyMesh",
    "Snapshot",
    "decimate_meshes",
    "key_times",
    "motion_preview_figure",
    "preview_size",
]
