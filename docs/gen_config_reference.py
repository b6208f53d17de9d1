"""Write the configuration reference from the shipped config tree (run by mkdocs-gen-files).

Every group of the tree ``lwrlab`` reads (``pkg://lwrlab.conf``, the top-level ``conf/``), found
through :func:`lwrlab.resources.config_group`, gets a page; every option of the group a section with
its keys, their values as shipped, and the YAML comments written above or beside them as their
descriptions. A new option, key or comment shows up at the next build; nothing is typed here.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path

import mkdocs_gen_files

from lwrlab.resources import CONFIG_PACKAGE, config_group

KEY = re.compile(r"^(?P<indent> *)(?P<key>[^\s#:][^:#]*?|'[^']*'|\"[^\"]*\"):(?:\s+(?P<value>.*?))?\s*$")


@dataclass
class Key:
    """One key of an option's YAML: dotted name, value as written, comment."""

    name: str
    value: str
    comment: list[str] = field(default_factory=list)


def split_comment(line: str) -> tuple[str, str]:
    """``line`` without its trailing ``# comment`` (outside quotes), and the comment."""
    quote = ""
    for i, char in enumerate(line):
        if char in "'\"" and not quote:
            quote = char
        elif char == quote:
            quote = ""
        elif char == "#" and not quote and (i == 0 or line[i - 1] in " \t"):
            return line[:i].rstrip(), line[i + 1 :].strip()
    return line.rstrip(), ""


def parse(text: str) -> tuple[list[str], list[Key], list[str]]:
    """(the file's leading comment, its keys in order, its defaults list) of one YAML file."""
    header: list[str] = []
    keys: list[Key] = []
    defaults: list[str] = []
    pending: list[str] = []
    stack: list[tuple[int, str]] = []
    started = False
    in_defaults = False
    for raw in text.splitlines():
        body, comment = split_comment(raw)
        if not body.strip():
            if comment:
                pending.append(comment)
            elif not started and pending:
                header, pending = header + pending, []
            continue
        if not started:
            started = True
        indent = len(body) - len(body.lstrip())
        stripped = body.strip()
        if stripped.startswith("- "):
            item = stripped[2:]
            if in_defaults:
                defaults.append(item + (f" — {comment}" if comment else ""))
            elif keys:
                keys[-1].value = (keys[-1].value + ", " if keys[-1].value else "") + item
                if comment:
                    keys[-1].comment.append(comment)
            pending = []
            continue
        match = KEY.match(body)
        if not match:  # a continuation of a flow value
            if keys:
                keys[-1].value += " " + stripped
            continue
        while stack and stack[-1][0] >= indent:
            stack.pop()
        name = ".".join([s for _, s in stack] + [match.group("key").strip("'\"")])
        value = match.group("value") or ""
        in_defaults = name == "defaults"
        if not in_defaults:
            keys.append(Key(name, value, pending + ([comment] if comment else [])))
        pending = []
        if not value:
            stack.append((indent, match.group("key").strip("'\"")))
    for key in keys:  # a mapping key whose children follow: its items are the children's rows
        if not key.value and any(k.name.startswith(key.name + ".") for k in keys):
            key.value = "(mapping)"
        elif key.value.count(", ") and not key.value.startswith(("[", "{")):
            key.value = f"[{key.value}]"
    return header, [k for k in keys if k.value != "(mapping)" or k.comment], defaults


def cell(text: str) -> str:
    """``text`` fit for a markdown table cell."""
    return text.replace("|", "\\|").replace("\n", " ")


def option_section(name: str, path: Path) -> str:
    header, keys, defaults = parse(path.read_text())
    lines = [f"## `{name}`\n"]
    if header:
        lines.append(" ".join(header) + "\n")
    if defaults:
        lines.append("Defaults list: " + "; ".join(f"`{cell(d)}`" for d in defaults) + "\n")
    if keys:
        lines += ["| key | value | description |", "|---|---|---|"]
        lines += [
            f"| `{cell(k.name)}` | `{cell(k.value) or ' '}` | {cell(' '.join(k.comment))} |" for k in keys
        ]
        lines.append("")
    return "\n".join(lines) + "\n"


def groups() -> list[str]:
    """Every config group of the tree: folders holding YAML files, nested ones as ``a/b``."""
    root = files(CONFIG_PACKAGE)
    found = []

    def walk(folder, prefix: str) -> None:
        for entry in sorted(folder.iterdir(), key=lambda e: e.name):
            if entry.is_dir() and not entry.name.startswith(("_", ".")):
                group = f"{prefix}{entry.name}"
                if any(e.name.endswith(".yaml") for e in entry.iterdir()):
                    found.append(group)
                walk(entry, f"{group}/")

    walk(root, "")
    return found


def main() -> None:
    navigation = ["* [Overview](index.md)", "* [config.yaml](root.md)"]
    index = [
        "# Configuration reference\n",
        "Every config group `lwrlab` composes, each option of it (`group=option` on the command line) "
        "and every key of the option as shipped, with the comment of its YAML as its description "
        "(`key=value` overrides it; `_target_` is the class or function the option builds). "
        "Generated from the config tree at each build. How the groups fit together and how settings "
        "are typed and checked: [How configuration works](../../explanation/configuration.md).\n",
        "| group | options |",
        "|---|---|",
    ]
    root = Path(str(files(CONFIG_PACKAGE).joinpath("config.yaml")))
    with mkdocs_gen_files.open("reference/configuration/root.md", "w") as out:
        out.write("# `config.yaml` (the root)\n\n" + option_section("config", root).split("\n", 1)[1])
    for group in groups():
        options = config_group(group)
        page = group.replace("/", "_") + ".md"
        navigation.append(f"* [{group}]({page})")
        index.append(f"| [`{group}`]({page}) | {', '.join(f'`{o}`' for o in sorted(options))} |")
        text = f"# `{group}`\n\n`{group}=<option>` picks one of: {', '.join(sorted(options))}.\n\n"
        text += "".join(option_section(o, options[o]) for o in sorted(options))
        with mkdocs_gen_files.open(f"reference/configuration/{page}", "w") as out:
            out.write(text)
    with mkdocs_gen_files.open("reference/configuration/index.md", "w") as out:
        out.write("\n".join(index) + "\n")
    with mkdocs_gen_files.open("reference/configuration/SUMMARY.md", "w") as out:
        out.write("\n".join(navigation) + "\n")


main()
