"""No module of ``lwrlab`` or ``plugins`` grows past :data:`MAX_LINES` lines.

A module that long holds several jobs: split it by the jobs it holds (a value object, its
serialisation, its figure…), not by line count, each part with a docstring saying what it owns.
"""

from __future__ import annotations

from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]
PACKAGES = ("lwrlab", "plugins")
MAX_LINES = 450


def line_count(path: Path) -> int:
    """The number of lines of a text file."""
    return len(path.read_text(encoding="utf-8").splitlines())


def oversized(root: Path = REPOSITORY, limit: int = MAX_LINES) -> list[str]:
    """``"path: N lines"`` for every Python module under the packages with more than ``limit`` lines."""
    found = []
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            if "conf" in path.relative_to(root).parts[1:2]:
                continue
            lines = line_count(path)
            if lines > limit:
                found.append(f"{path.relative_to(root)}: {lines} lines")
    return found


def test_no_module_is_over_the_limit() -> None:
    found = oversized()
    assert not found, (
        f"{len(found)} module(s) over {MAX_LINES} lines (split each by the jobs it holds):\n"
        + "\n".join(found)
    )


def test_the_check_names_an_oversized_module(tmp_path: Path) -> None:
    (tmp_path / "lwrlab").mkdir()
    (tmp_path / "plugins").mkdir()
    (tmp_path / "lwrlab" / "small.py").write_text("x = 1\n" * 3)
    (tmp_path / "plugins" / "big.py").write_text("x = 1\n" * 5)
    assert oversized(tmp_path, limit=4) == ["plugins/big.py: 5 lines"]
