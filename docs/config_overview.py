"""The configuration overview's table: every config group, its options and its default, from the tree.

``docs/explanation/configuration.md`` shows it between ``<!-- generated: config_groups -->`` and
``<!-- /generated -->``; ``docs/readme_tables.py config_groups`` writes it there, and
``tests/test_docs_consistency.py`` fails when the page lacks an option the tree has. Read from the
YAML files only (nothing is imported but :mod:`lwrlab.resources`)::

    .venv/bin/python docs/config_overview.py     # prints the table
"""

from __future__ import annotations

import re
from importlib.resources import files
from pathlib import Path

from lwrlab.resources import CONFIG_PACKAGE, config_group

DEFAULT_ENTRY = re.compile(r"^\s*-\s+(?P<group>[\w/]+)(?:@(?P<package>\w+))?:\s*(?P<option>[\w.]+)")
TARGET = re.compile(r"^_target_:\s*(?P<target>[\w.]+)", re.M)


def groups() -> list[str]:
    """Every config group of the tree: folders holding YAML files, nested ones as ``a/b``."""
    found = []

    def walk(folder: Path, prefix: str) -> None:
        for entry in sorted(folder.iterdir(), key=lambda e: e.name):
            if entry.is_dir() and not entry.name.startswith(("_", ".")):
                group = f"{prefix}{entry.name}"
                if any(e.name.endswith(".yaml") for e in entry.iterdir()):
                    found.append(group)
                walk(entry, f"{group}/")

    walk(Path(str(files(CONFIG_PACKAGE))), "")
    return found


def defaults() -> dict[str, list[str]]:
    """Group → ``option`` (or ``option`` as ``package``) that ``config.yaml``'s defaults list picks."""
    chosen: dict[str, list[str]] = {}
    text = Path(str(files(CONFIG_PACKAGE).joinpath("config.yaml"))).read_text()
    for line in text.split("defaults:", 1)[1].splitlines()[1:]:
        if not line.startswith("  -"):
            break
        match = DEFAULT_ENTRY.match(line)
        if match and match.group("option") != "null":
            package = match.group("package")
            option = f"`{match.group('option')}`" + (f" (as `{package}`)" if package else "")
            chosen.setdefault(match.group("group"), []).append(option)
    return chosen


def code_location(group: str, options: dict[str, Path]) -> str:
    """Where the options' code lives: the ``plugins/<kind>/`` folder or the package that every option's
    ``_target_`` is in; else the group's folder in ``conf/``."""
    modules = []
    for path in options.values():
        match = TARGET.search(path.read_text())
        if match is not None:
            modules.append(match.group("target").split(".")[:-1])
    if len(modules) < len(options):
        return f"`conf/{group}/`"
    shared = []
    for parts in zip(*modules, strict=False):
        if len(set(parts)) > 1:
            break
        shared.append(parts[0])
    if shared[:1] == ["plugins"]:
        return f"`{'/'.join(shared[:2])}/`"
    return f"`{'.'.join(shared)}`"


def overview_table() -> str:
    """The markdown table: group, its options (sorted), the default, where the code lives."""
    chosen = defaults()
    lines = ["| group | options | default | code |", "|---|---|---|---|"]
    for group in groups():
        options = config_group(group)
        names = ", ".join(f"`{name}`" for name in sorted(options))
        default = ", ".join(chosen.get(group, [])) or (
            "Hydra's `basic`" if group.startswith("hydra/") else "none"
        )
        lines.append(f"| `{group}` | {names} | {default} | {code_location(group, options)} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(overview_table(), end="")
