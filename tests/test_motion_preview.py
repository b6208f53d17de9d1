"""The motion preview: the PNG at its size, approaches in red, meshes thinned, key times well spread."""

from __future__ import annotations

from itertools import combinations
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from lwrlab.excitation.approaches import ClosestApproach
from lwrlab.figures import motion_preview
from lwrlab.figures.motion_preview import (
    DPI,
    KEEP_WHOLE,
    PANEL_SIZE,
    BodyMesh,
    Snapshot,
    decimate_meshes,
    key_times,
    motion_preview_figure,
    preview_size,
)

BOX_FACES = np.array(  # two triangles per side; corner i is (x, y, z) = bits (4, 2, 1) of i
    [
        *([0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5]),  # x = lower, x = upper
        *([0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6]),  # y = lower, y = upper
        *([0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]),  # z = lower, z = upper
    ]
)


def box(
    name: str, lower: tuple[float, float, float], upper: tuple[float, float, float], world: bool = False
) -> BodyMesh:
    """An axis-aligned box (m) as a 12-triangle mesh."""
    corners = np.array(
        [[x, y, z] for x in (lower[0], upper[0]) for y in (lower[1], upper[1]) for z in (lower[2], upper[2])]
    )
    return BodyMesh(name, corners, BOX_FACES, world)


TABLE = box("table", (0.35, -0.4, 0.0), (0.9, 0.4, 0.3), world=True)


def arm(t: float) -> tuple[BodyMesh, ...]:
    """A 3-body arm: a column, an upper arm swinging about z with time, a forearm hanging from its end."""
    angle = 0.3 * t
    reach = 0.45 * np.array([np.cos(angle), np.sin(angle)])
    hand = reach * (1 + 0.1 * t)
    return (
        box("column", (-0.06, -0.06, 0.0), (0.06, 0.06, 0.5)),
        box(
            "upper_arm",
            (min(0, reach[0]) - 0.05, min(0, reach[1]) - 0.05, 0.45),
            (max(0, reach[0]) + 0.05, max(0, reach[1]) + 0.05, 0.55),
        ),
        box(
            "forearm", (hand[0] - 0.04, hand[1] - 0.04, 0.5 - 0.05 * t), (hand[0] + 0.04, hand[1] + 0.04, 0.5)
        ),
        TABLE,
    )


TIMES = (0.0, 2.5, 5.0, 7.5)
SNAPSHOTS = [
    Snapshot(t, arm(t), label)
    for t, label in zip(TIMES, ("start pose", "", "closest to itself", ""), strict=True)
]
SELF = ClosestApproach(  # violated: 5 mm < 10 mm
    "self", "column", "forearm", 0.005, 5.0, np.array([0.06, 0.0, 0.3]), np.array([0.3, 0.1, 0.3]), 0.01
)
WORLD = ClosestApproach(
    "world", "forearm", "table", 0.05, 2.5, np.array([0.45, 0.3, 0.37]), np.array([0.45, 0.3, 0.3]), 0.01
)


def pixels(n_snapshots: int, n_approaches: int) -> tuple[float, float]:
    """Height and width (px) of the preview; the saved image rounds them to a whole pixel."""
    width, height = preview_size(n_snapshots, n_approaches)
    return height * DPI, width * DPI


def red(image: np.ndarray) -> np.ndarray:
    """Pixels of the approach red (no body colour, grey or black comes near it)."""
    return (image[..., 0] > 0.7) & (image[..., 1] < 0.3) & (image[..., 2] < 0.3)


def panels_and_list(image: np.ndarray, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """The panels' interiors (each panel row without its title and label band) and the list under them."""
    top = motion_preview._TOP
    bands = [
        image[round((top + (r + 0.25) * PANEL_SIZE[1]) * DPI) : round((top + (r + 1) * PANEL_SIZE[1]) * DPI)]
        for r in range(rows)
    ]
    below = image[round((top + rows * PANEL_SIZE[1] + motion_preview._LEGEND) * DPI) :]
    return np.concatenate(bands), below


def test_preview_is_written_at_its_size_with_the_approaches_in_red(tmp_path: Path) -> None:
    path = motion_preview_figure(SNAPSHOTS, [WORLD, SELF], tmp_path / "preview.png", "three boxes")
    assert path == tmp_path / "preview.png"
    assert path.stat().st_size > 30_000
    image = imread(path)
    assert image.shape[:2] == pytest.approx(pixels(len(SNAPSHOTS), 2), abs=1)
    assert image.shape[1] == 3 * 484  # three panels of 4.4 in at 110 dpi
    assert image.shape[0] > 2 * PANEL_SIZE[1] * DPI  # two rows of panels
    panels, listed = panels_and_list(image, rows=2)
    assert red(panels).sum() > 50  # the segments and their markers, inside the panels
    assert red(listed).sum() > 50  # the violated approach's line of the list


def test_no_approach_no_red(tmp_path: Path) -> None:
    image = imread(motion_preview_figure(SNAPSHOTS, [], tmp_path / "preview.png", "three boxes"))
    assert image.shape[:2] == pytest.approx(pixels(len(SNAPSHOTS), 0), abs=1)
    assert not red(image).any()


def test_only_violations_are_listed_in_red(tmp_path: Path) -> None:
    image = imread(motion_preview_figure(SNAPSHOTS, [WORLD], tmp_path / "preview.png", "three boxes"))
    panels, listed = panels_and_list(image, rows=2)
    assert red(panels).sum() > 50
    assert not red(listed).any()


def test_without_mounting_surface_and_with_one_snapshot(tmp_path: Path) -> None:
    path = motion_preview_figure(
        SNAPSHOTS[:1], [SELF], tmp_path / "one.png", "one pose", mounting_height=None
    )
    assert imread(path).shape[:2] == pytest.approx(pixels(1, 1), abs=1)


@pytest.mark.parametrize("count", [0, 7])
def test_one_to_six_snapshots(tmp_path: Path, count: int) -> None:
    with pytest.raises(ValueError, match="snapshots"):
        motion_preview_figure([SNAPSHOTS[0]] * count, [], tmp_path / "preview.png", "too many")
    assert not (tmp_path / "preview.png").exists()


def link(name: str, faces: int) -> BodyMesh:
    """A mesh of ``faces`` separate triangles, face i made of vertices 3i, 3i + 1, 3i + 2."""
    return BodyMesh(name, np.zeros((3 * faces, 3)), np.arange(3 * faces).reshape(faces, 3))


def test_thinning_keeps_every_kth_face_of_the_large_meshes_within_the_budget() -> None:
    links = [link(f"link{i}", 1000 + 37 * i) for i in range(7)]
    meshes = [*links, TABLE]
    thinned = decimate_meshes(meshes, max_faces=4000)
    assert sum(len(m.faces) for m in thinned) <= 4000
    assert thinned[-1] is TABLE  # small meshes stay whole
    step = (thinned[0].faces[1, 0] - thinned[0].faces[0, 0]) // 3
    assert step == 2  # 7777 triangles into 4000 - 12: one in two
    for before, after in zip(links, thinned[:-1], strict=True):
        assert after.name == before.name
        np.testing.assert_array_equal(after.faces, before.faces[::step])
    # the smallest step that fits: one less would draw too many
    assert sum(-(-len(m.faces) // (step - 1)) for m in links) + len(TABLE.faces) > 4000
    assert decimate_meshes(meshes, max_faces=100_000) == tuple(meshes)  # within the budget: untouched
    assert [len(m.faces) for m in decimate_meshes([link("a", KEEP_WHOLE + 1)], max_faces=1)] == [1]
    with pytest.raises(ValueError, match="max_faces"):
        decimate_meshes(meshes, max_faces=0)


def test_the_figure_draws_thinned_snapshots(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    drawn: list[int] = []

    def counted(meshes, max_faces):
        thinned = decimate_meshes(meshes, max_faces)
        drawn.append(sum(len(m.faces) for m in thinned))
        return thinned

    monkeypatch.setattr(motion_preview, "decimate_meshes", counted)
    heavy = [Snapshot(t, (*(link(f"link{i}", 1000) for i in range(7)), TABLE)) for t in TIMES]
    motion_preview_figure(heavy, [SELF], tmp_path / "heavy.png", "heavy", max_faces=2000)
    assert len(drawn) == len(TIMES)
    assert all(500 < faces <= 2000 for faces in drawn)


T = np.linspace(0.0, 10.0, 1001)  # s


def test_key_times_start_the_two_closest_approaches_then_spread() -> None:
    farther = ClosestApproach("self", "column", "upper_arm", 0.2, 8.8, np.zeros(3), np.zeros(3))
    world = ClosestApproach("world", "forearm", "table", 0.05, 7.1042, np.zeros(3), np.zeros(3))
    closest = ClosestApproach("self", "column", "forearm", 0.005, 3.41, np.zeros(3), np.zeros(3))
    chosen = key_times(T, [farther, world, closest], n=6)
    assert len(chosen) == 6
    times = [t for t, _ in chosen]
    assert times == sorted(times)
    assert set(times) <= set(T)  # samples of the motion
    labels = dict(chosen)
    assert labels[0.0] == "start pose"
    assert labels[3.41] == "closest to itself"
    assert labels[T[710]] == "closest to the world"
    assert labels[10.0] == "end pose"
    assert min(np.diff(times)) >= 0.05 * 10.0
    assert key_times(T, [farther, world, closest], n=3) == [
        (0.0, "start pose"),
        (3.41, "closest to itself"),
        (T[710], "closest to the world"),
    ]


def test_key_times_keep_their_spacing_and_merge_an_approach_at_the_start() -> None:
    at_start = ClosestApproach("self", "column", "forearm", 0.005, 0.0, np.zeros(3), np.zeros(3))
    chosen = key_times(T, [at_start], n=50)
    assert chosen[0] == (0.0, "start pose · closest to itself")
    assert 6 < len(chosen) < 50  # fewer than asked: 5 % of 10 s apart leaves room for about 20
    assert all(abs(a - b) >= 0.5 - 1e-9 for (a, _), (b, _) in combinations(chosen, 2))
    assert key_times(T, [], n=1) == [(0.0, "start pose")]
    with pytest.raises(ValueError, match="n = 0"):
        key_times(T, [], n=0)
