"""Write the configuration reference from the shipped config tree (run by mkdocs-gen-files).

Every group of the tree ``lwrlab`` reads (``pkg://lwrlab.conf``, the top-level ``conf/``), found
through :func:`lwrlab.resources.config_group`, gets a page; every option of the group a section with
its keys, their types, their values as shipped, and the YAML comments written above or beside them as
their descriptions. A key's type is its schema's (``lwrlab.config``, linked first in the option's
defaults list) or, for a plugin's own keys, the annotation of the keyword argument its ``_target_``
takes (read from the source, nothing is imported). A new option, key or comment shows up at the next
build; nothing is typed here.
"""

from __future__ import annotations

import ast
import dataclasses
import re
import sys
import typing
from dataclasses import dataclass, field
from functools import cache
from importlib.resources import files
from pathlib import Path

import mkdocs_gen_files

from lwrlab.config import SCHEMA_GROUP, SCHEMAS
from lwrlab.resources import CONFIG_PACKAGE, config_group

REPOSITORY = Path(__file__).resolve().parents[1]

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


def schema_fields(schema: type, prefix: str) -> dict[str, str]:
    """Dotted key → type of a schema's fields (a field typed by another schema: its fields, nested)."""
    module = sys.modules[schema.__module__]
    types: dict[str, str] = {}
    for klass in reversed(schema.__mro__):
        for name, annotation in getattr(klass, "__annotations__", {}).items():
            text = annotation if isinstance(annotation, str) else typing.get_type_hints(klass)[name].__name__
            nested = getattr(module, text, None)
            if dataclasses.is_dataclass(nested):
                types |= schema_fields(nested, f"{prefix}{name}.")
            else:
                types[f"{prefix}{name}"] = text
    return types


def schema_types(defaults: list[str]) -> dict[str, str]:
    """Key → type from the schemas an option's defaults list links (``/schema/<group>/<name>@<package>``)."""
    by_name = {f"/{SCHEMA_GROUP}/{group}/{name}": schema for group, name, schema in SCHEMAS}
    types: dict[str, str] = {}
    for entry in defaults:
        link, _, package = entry.split(" — ")[0].strip().partition("@")
        if link in by_name:
            types |= schema_fields(by_name[link], "")
            if package and package != "_here_":
                types |= schema_fields(by_name[link], f"{package}.")
    return types


@cache
def signature_types(target: str) -> dict[str, str]:
    """Keyword → annotation of what ``target`` (``package.module.Name``) takes, from its source."""
    module, _, name = target.rpartition(".")
    path = REPOSITORY.joinpath(*module.split(".")).with_suffix(".py")
    if not path.is_file():
        return {}
    tree = ast.parse(path.read_text())
    for node in tree.body:  # a name re-exported from another module: read it there
        if isinstance(node, ast.ImportFrom) and node.module and any(a.name == name for a in node.names):
            return signature_types(f"{node.module}.{name}")
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef) and node.name == name:
            init = next(
                (n for n in node.body if isinstance(n, ast.FunctionDef) and n.name == "__init__"), None
            )
            node = init if init is not None else node
        if isinstance(node, ast.FunctionDef) and (node.name == name or node.name == "__init__"):
            arguments = [*node.args.args, *node.args.kwonlyargs]
            return {a.arg: ast.unparse(a.annotation) for a in arguments if a.annotation is not None}
    return {}


def key_types(keys: list[Key], defaults: list[str], preset: bool = True) -> dict[str, str]:
    """Dotted key → type of an option's keys: its schemas', else its plugins' keyword annotations, else
    (a preset's override of another group's key, with ``preset``) that key's type in its group."""
    types = schema_types(defaults)
    targets = {
        k.name.removesuffix("_target_").rstrip("."): k.value.strip("'\"")
        for k in keys
        if k.name.endswith("_target_")
    }
    for key in keys:
        if key.name in types or key.name.endswith(("_target_", "_partial_", "_convert_")):
            continue
        node, _, leaf = key.name.rpartition(".")
        if node in targets:
            annotation = signature_types(targets[node]).get(leaf)
            if annotation:
                types[key.name] = annotation
        if preset and key.name not in types and key.name in tree_types():
            types[key.name] = tree_types()[key.name]
    return types


def code_cell(text: str) -> str:
    """``text`` as code in a markdown table cell (a pipe inside a code span needs no escape)."""
    return text.replace("\n", " ").replace("`", "'")


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
        types = key_types(keys, defaults)
        lines += ["| key | type | value | description |", "|---|---|---|---|"]
        lines += [
            f"| `{code_cell(k.name)}` | {f'`{code_cell(types[k.name])}`' if k.name in types else ''} "
            f"| `{code_cell(k.value) or ' '}` | {cell(' '.join(k.comment))} |"
            for k in keys
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


@cache
def tree_types() -> dict[str, str]:
    """``group.key`` → type over every option of every group: what a preset's override of it is."""
    types = {f"{k}": t for k, t in schema_types(["/schema/root/config@_here_"]).items()}
    for group in groups():
        if group in ("experiment",) or group.startswith("hydra"):
            continue
        for path in config_group(group).values():
            _, keys, defaults = parse(path.read_text())
            global_package = path.read_text().startswith("# @package _global_")
            for key, annotation in key_types(keys, defaults, preset=False).items():
                types.setdefault(key if global_package else f"{group}.{key}", annotation)
    return types


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
