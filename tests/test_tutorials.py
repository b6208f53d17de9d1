"""Every lesson of the manual runs from a fresh clone and prints what its page shows.

``docs/tutorial_outputs.py --check``, one page at a time: the page's commands run in order in a new
folder holding the repository's tracked files and its ``.venv`` (no ``outputs/``, no ``../shared``, a
new home), and every line each output block shows must be printed again, in order, its numbers within
5 % (durations excepted), every metric the runs logged must be in the metric catalogue (the
manual's metric reference), and nothing is left at the clone's root (scratch files go under
``outputs/``). A page whose commands changed what they print is rewritten by
``.venv/bin/python docs/tutorial_outputs.py <page>``. Slow: about three minutes for all on two cores.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

from lwrlab.tracking.job_config.metric_catalogue import describe

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("tutorial_outputs", ROOT / "docs" / "tutorial_outputs.py")
lessons = importlib.util.module_from_spec(spec)
sys.modules["tutorial_outputs"] = lessons  # dataclasses look their module up there
spec.loader.exec_module(lessons)

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("page", lessons.LESSONS, ids=lambda p: p.stem)
def test_a_lesson_prints_what_its_page_shows(page: Path, tmp_path: Path) -> None:
    if not (ROOT / ".venv" / "bin" / "lwrlab").is_file():
        pytest.skip("the lessons run the clone's .venv/bin/lwrlab, which this checkout has not installed")
    run = lessons.run_page(page, tmp_path)
    problems = lessons.check(page, run)
    logged = {
        name for path in run.clone.glob("outputs/**/metrics.json") for name in json.loads(path.read_text())
    }
    problems += [
        f"metric {name} is not in lwrlab.tracking.job_config.metric_catalogue"
        for name in sorted(logged)
        if describe(name) is None
    ]
    # a lesson's scratch files go under outputs/ (git ignores it): the clone's root stays as cloned
    problems += [
        f"{entry.name} left at the clone's root (write scratch files under outputs/)"
        for entry in sorted(run.clone.iterdir())
        # outputs/, and what the page runner itself keeps there (what the lesson printed so far)
        if not entry.is_symlink() and entry.name not in {"outputs", lessons.PRINTED_FILE}
    ]
    assert problems == [], (
        f"{page.name} differs from a new run (rewrite it: docs/tutorial_outputs.py {page.stem}):\n"
        + "\n".join(problems)
    )
