"""The site's navigation and code blocks stay true.

Fast: every page ``mkdocs.yml``'s nav names exists (written in ``docs/`` or by one of the site's
generators), and every generated table of the site has a source in ``docs/readme_tables.py``. The
tutorials' commands are run as written, each page from a fresh clone, by ``tests/test_tutorials.py``
(slow), which also compares what they print with what the pages show.
"""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
TUTORIALS = sorted((DOCS / "tutorials").glob("*.md"))
GENERATORS = sorted(DOCS.glob("gen_*.py"))


def _nav_targets(entry: object) -> list[str]:
    if isinstance(entry, str):
        return [entry]
    if isinstance(entry, list):
        return [t for item in entry for t in _nav_targets(item)]
    if isinstance(entry, dict):
        return [t for value in entry.values() for t in _nav_targets(value)]
    return []


def test_the_nav_names_only_existing_pages() -> None:
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    generated = "".join(g.read_text() for g in GENERATORS)
    targets = _nav_targets(config["nav"])
    assert len(targets) > 20, targets
    missing = [
        t
        for t in targets
        if not (DOCS / t).is_file() and f'"{t}' not in generated and f"'{t}" not in generated
    ]
    assert missing == [], f"nav names pages neither in docs/ nor generated: {missing}"
    for script in config["plugins"][1]["gen-files"]["scripts"]:
        assert (ROOT / script).is_file(), script


def _tables_script():  # docs/ is not a package: load the script by path
    spec = importlib.util.spec_from_file_location("readme_tables", DOCS / "readme_tables.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["readme_tables"] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def test_every_generated_table_of_the_site_has_a_source() -> None:
    tables = _tables_script()
    assert set(tables.site_blocks()) == set(tables.SOURCES)


def tutorial_commands() -> list[tuple[str, str]]:
    """(page, command) of every ``lwrlab``/``make run`` line in the tutorials' bash blocks."""
    found = []
    for page in TUTORIALS:
        for language, body in re.findall(r"```(\w*)\n(.*?)```", page.read_text(), flags=re.S):
            if language not in ("bash", "sh"):
                continue
            for line in body.splitlines():
                command = line.split(" # ")[0].strip()
                if re.search(r"(?:^|\s)(?:\S*/)?lwrlab\s|^make run", command):
                    found.append((page.name, command))
    return found


def test_the_tutorials_show_commands() -> None:
    assert len(tutorial_commands()) > 10
