"""Write the CLI reference page from the program itself (run by mkdocs-gen-files).

``lwrlab --help`` is run as a user runs it (its list of config groups and options, without the
composed config it prints after them), and each subcommand's help comes from its own argument parser
(``lwrlab.cli.SUBCOMMANDS``), so the page says what the installed program accepts.
"""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import mkdocs_gen_files

from lwrlab.cli import SUBCOMMANDS

PROGRAM = Path(sys.executable).parent / "lwrlab"


def main_help() -> str:
    """``lwrlab --help`` up to the composed config (which the configuration reference shows)."""
    done = subprocess.run([str(PROGRAM), "--help"], capture_output=True, text=True, check=True, timeout=300)
    return done.stdout.split("== Config ==")[0].rstrip() + "\n"


def subcommand_help(name: str) -> str:
    """``lwrlab <name> --help``, from the subcommand's own parser."""
    parser = importlib.import_module(SUBCOMMANDS[name]).build_parser()
    parser.prog = f"lwrlab {name}"
    return parser.format_help()


def page() -> str:
    sections = [
        "# Command line\n",
        "`lwrlab` runs a job (a Hydra app: `group=option` and `key=value` overrides, `-m` for a sweep), "
        'or, with a subcommand first, works on the MLflow store. `make run ARGS="…"` is '
        "`.venv/bin/lwrlab …`. Generated from the installed program at each build.\n",
        "## `lwrlab`\n",
        f"```text\n{main_help()}```\n",
        "Every key of every option: [Configuration reference](configuration/index.md).\n",
    ]
    for name in SUBCOMMANDS:
        sections += [f"## `lwrlab {name}`\n", f"```text\n{subcommand_help(name)}```\n"]
    return "\n".join(sections)


with mkdocs_gen_files.open("reference/cli.md", "w") as out:
    out.write(page())
