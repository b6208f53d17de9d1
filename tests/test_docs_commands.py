"""The site's navigation and code blocks stay true.

Fast: every page ``mkdocs.yml``'s nav names exists (written in ``docs/`` or by one of the site's
generators), and every generated table of the site has a source in ``docs/readme_tables.py``. Slow: the
cheap commands (``tracking=none``) of the tutorial pages' ``bash`` blocks that call ``lwrlab`` or
``make run`` are run as written, with the files the page asks the reader to write (``~/my_lab/…``)
written under a temporary home.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
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


def _write_page_files(page: Path, home: Path) -> None:
    """The files a page's python and yaml blocks ask the reader to write (``~/my_lab/…``)."""
    for body in re.findall(r"```(?:python|yaml)\n(.*?)```", page.read_text(), flags=re.S):
        match = re.match(r"# ~/(my_lab/\S+)\n", body)
        if match:
            path = home / match.group(1)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(body)


def test_the_tutorials_show_commands() -> None:
    assert len(tutorial_commands()) > 10


@pytest.mark.slow
@pytest.mark.parametrize(("page", "command"), [c for c in tutorial_commands() if "tracking=none" in c[1]])
def test_cheap_tutorial_command_runs(page: str, command: str, tmp_path: Path) -> None:
    home = tmp_path / "home"
    _write_page_files(DOCS / "tutorials" / page, home)
    environment = {k: v for k, v in os.environ.items() if not k.startswith("MLFLOW_")}
    environment["HOME"] = str(home)
    line = command.replace(".venv/bin/", f"{Path(sys.executable).parent}/")
    done = subprocess.run(
        ["bash", "-c", line], cwd=tmp_path, env=environment, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-3000:]
