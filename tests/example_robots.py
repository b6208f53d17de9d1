"""Files of example-robot-data for tests, which skip where it is not installed."""

from __future__ import annotations

import pytest


def example_robot_files(*paths: str) -> list[str]:
    """The absolute paths of example-robot-data's ``paths`` (relative to its ``robots`` share), or skip
    the test when the package is not installed."""
    example = pytest.importorskip("plugins.robots.example_robot")
    try:
        return [example.example_robot_file(path) for path in paths]
    except (FileNotFoundError, ImportError) as error:
        pytest.skip(f"example-robot-data is not installed ({error})")
