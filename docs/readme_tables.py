"""Rewrite the site's result tables from runs, so that no figure in them is typed by hand.

Each generated table sits between ``<!-- generated: <name> -->`` and ``<!-- /generated -->`` in a page
of the documentation site (``docs/**/*.md``) or in README.md. For every name this script runs the
command that produces it (a preset and ``lwrlab report``, or a benchmark), in a temporary folder
with its own MLflow store, takes the table from the output and writes it between the markers::

    .venv/bin/python docs/readme_tables.py                    # every table (about 50 minutes on 2 cores)
    .venv/bin/python docs/readme_tables.py table2 fig6       # some of them
    .venv/bin/python docs/readme_tables.py table2 --check    # exit 1 if the page differs from a new run

``--check`` compares numbers to 3 significant figures (BLAS builds differ in the last digits); the
slow test suite runs it on Table II.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]
README = REPOSITORY / "README.md"
DOCS = REPOSITORY / "docs"
BIN = Path(sys.executable).parent
BLOCK = re.compile(r"(<!-- generated: (?P<name>\w+) -->\n)(?P<body>.*?)(<!-- /generated -->)", re.S)
NUMBER = re.compile(r"−?-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


@dataclass(frozen=True)
class Source:
    """How one generated table is produced."""

    commands: tuple[tuple[str, ...], ...]
    """Commands run in order in a fresh folder (``lwrlab`` and ``python`` from this environment)."""
    table: Callable[[str, Path], str]
    """The markdown table, from the last command's output and the folder."""
    minutes: float
    """About how long it takes on 2 cores."""
    figures: tuple[tuple[str, str], ...] = ()
    """(glob in the run folder, path in the repository) of figures the page shows beside the table."""


def _report_table(heading: str) -> Callable[[str, Path], str]:
    """The first markdown table after ``heading`` in the newest ``report.md``."""

    def table(_: str, folder: Path) -> str:
        report = max((folder / "outputs" / "reports").glob("*/report.md"))
        return first_table(report.read_text().split(heading, 1)[1])

    return table


def _printed_table(after: str) -> Callable[[str, Path], str]:
    """The first markdown table printed after the line containing ``after``."""
    return lambda output, _: first_table(output.split(after, 1)[1])


def _relabelled(table: Callable[[str, Path], str], labels: dict[str, str]) -> Callable[[str, Path], str]:
    """``table`` with labels renamed (a study's setting names, as the page calls them)."""

    def renamed(output: str, folder: Path) -> str:
        text = table(output, folder)
        for old, new in labels.items():
            text = text.replace(old, new)
        return text

    return renamed


MODEL_STUDY = (
    "python",
    str(REPOSITORY / "benchmarks" / "model_study.py"),
    *("--output", "study.csv", "--settings", "ols (sign", "sdp auto, min (sign", "ols, friction auto"),
    "sdp auto, friction auto (default",
)
"""The model study of the four settings the manual compares (the defaults for logs, least squares, and each
with the other friction choice)."""
SETTINGS = {
    "sdp auto, min (sign friction)": "`sdp`, `weight: auto`, `friction=sign`",
    "sdp auto, friction auto (default for logs)": "**defaults for logs**: `sdp`, `weight: auto`, `friction=auto`",
    "ols (sign friction)": "`ols`",
    "ols, friction auto": "`ols`, `friction=auto`",
}


def _file_table(pattern: str) -> Callable[[str, Path], str]:
    """The markdown table in the newest file matching ``pattern`` under the folder."""
    return lambda _, folder: first_table(max(folder.glob(pattern)).read_text())


NEXT_MOTION = (("python", str(REPOSITORY / "benchmarks" / "next_motion.py"), "--output", "next_motion"),)
"""One run of the next-motion benchmark prints the four tables of its section."""

SOURCES = {
    "config_groups": Source(
        (("python", str(DOCS / "config_overview.py")),),
        lambda output, _: first_table(output),
        0.1,
    ),
    "table2": Source(
        (("lwrlab", "experiment=paper_table2"), ("lwrlab", "report", "--experiment", "paper_table2")),
        _report_table("## Table II"),
        0.3,
    ),
    "fig5": Source(
        (
            ("lwrlab", "experiment=paper_fig5_duration", "task.durations=[2,4,6,8,10]"),
            ("lwrlab", "report", "--experiment", "paper_fig5_duration", "--kinds", "fig5"),
        ),
        _report_table("## Fig. 5"),
        3.0,
    ),
    "fig6": Source(
        (
            ("lwrlab", "experiment=paper_fig6_criteria", "task.seeds=[0,1,2]"),
            ("lwrlab", "report", "--experiment", "paper_fig6_criteria", "--kinds", "fig6"),
        ),
        _report_table("## Fig. 6"),
        3.0,
    ),
    "fig6_preset": Source(
        (("lwrlab", "experiment=paper_fig6_criteria", "task.seeds=[0,1,2]", "tracking=none"),),
        _printed_table("Mean over joints of the cross-validation error"),
        3.0,
    ),
    "startup": Source(
        (("python", str(REPOSITORY / "benchmarks" / "startup.py"), "--rounds", "3", "--chain"),),
        _printed_table("## What a user waits for"),
        2.0,
    ),
    "processing": Source(
        (("python", str(REPOSITORY / "benchmarks" / "processing_study.py"), "--output", "study.csv"),),
        _printed_table("on motions not in the fit"),
        4.0,
    ),
    "model_study_lwr4": Source(
        (
            (
                "python",
                str(REPOSITORY / "benchmarks" / "model_study.py"),
                *("--data", "lwr4+", "--output", "study.csv"),
                *("--settings", "ols (sign", "friction auto (default"),
            ),
        ),
        _relabelled(
            _printed_table("validation ‖τ−τ̂‖/‖τ‖ (%)"),
            {
                "column": "split",
                "ols (sign friction)": "ols",
                "sdp auto, friction auto (default for logs)": "defaults for logs",
            },
        ),
        3.0,
    ),
    "model_study": Source(
        ((*MODEL_STUDY, "--data", "lwr4+", "ours", "second"),),
        _relabelled(_printed_table("summary over the new-motion splits"), SETTINGS),
        8.0,
    ),
    "model_study_geared": Source(
        ((*MODEL_STUDY, "--data", "geared"),),
        _relabelled(_printed_table("summary over the new-motion splits of the geared arms"), SETTINGS),
        4.0,
    ),
    "own_robots": Source(
        (("python", str(REPOSITORY / "benchmarks" / "own_robot_motion.py")),),
        _printed_table("## Exciting motions of robots nobody here wrote"),
        3.0,
    ),
    "estimator_benchmark": Source(
        (("lwrlab", "-m", "experiment=estimator_benchmark", "hydra/launcher=parallel"),),
        _file_table("outputs/multiruns/*/*/estimator_benchmark_summary.md"),
        10.0,
        (("outputs/multiruns/*/*/estimator_benchmark.png", "docs/figures/estimator_benchmark.png"),),
    ),
    "monitor": Source(
        (("python", str(REPOSITORY / "benchmarks" / "monitor.py"), "--output", "scenario"),),
        _printed_table("## Collision detection on the MuJoCo scenario"),
        5.0,
    ),
    **{
        f"live_monitor_{part}": Source(
            (
                (
                    "python",
                    str(REPOSITORY / "benchmarks" / "live_monitor.py"),
                    "--only",
                    part,
                    "--nice",
                    "-10",
                ),
            ),
            _printed_table(f"## Live monitor: {part}"),
            minutes,
        )
        for part, minutes in (("pushes", 2.0), ("endurance", 12.0), ("rates", 3.0))
    },
    **{
        f"live_painting_{part}": Source(
            (
                (
                    "python",
                    str(REPOSITORY / "benchmarks" / "live_painting.py"),
                    "--only",
                    part,
                    "--nice",
                    "-10",
                ),
            ),
            _printed_table(f"## Live painting: {part}"),
            minutes,
        )
        for part, minutes in (("path", 4.0), ("drills", 2.0))
    },
    "zoo_members": Source(
        (("python", str(REPOSITORY / "benchmarks" / "zoo.py"), "--list"),), _printed_table("## members"), 0.1
    ),
    **{
        f"zoo_{choice}": Source(
            (("python", str(REPOSITORY / "benchmarks" / "zoo.py"), "--choice", choice),),
            _printed_table(f"## {choice}"),
            15.0,
        )
        for choice in (
            "friction",
            "intervals",
            "thresholds",
            "prior",
            "cutoff",
            "near_rest",
            "operation",
            "realisations",
        )
    },
    **{
        f"zoo_{choice}_cycle": Source(
            (
                (
                    "python",
                    str(REPOSITORY / "benchmarks" / "zoo.py"),
                    "--choice",
                    choice,
                    "--no-real",
                    "--fit-logs",
                    "fit",
                    "p2p",
                ),
            ),
            _printed_table(f"## {choice} (fitted on fit + p2p)"),
            15.0,
        )
        for choice in ("friction", "intervals", "prior", "cutoff", "near_rest")
    },
    "cutoff_cycles": Source(
        (("python", str(REPOSITORY / "benchmarks" / "cutoff_cycles.py")),),
        _printed_table("## Cut-offs on point-to-point cycles, against the default"),
        8.0,
    ),
    "next_motion": Source(
        NEXT_MOTION,
        _printed_table("## Errors against robot seconds"),
        15.0,
        (("next_motion/next_motion.png", "docs/figures/next_motion.png"),),
    ),
    "next_motion_targets": Source(NEXT_MOTION, _printed_table("## Task-aware against D-optimal"), 15.0),
    "next_motion_timing": Source(NEXT_MOTION, _printed_table("## Designing a 10 s motion conditioned"), 15.0),
    "next_motion_figures": Source(NEXT_MOTION, _printed_table("## Figures to reach"), 15.0),
}
"""Every generated table of the site, by the name in its marker."""


def first_table(text: str) -> str:
    """The first markdown table (consecutive ``|`` lines) in ``text``, with a final newline."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    end = next((i for i in range(start, len(lines)) if not lines[i].startswith("|")), len(lines))
    return "\n".join(lines[start:end]) + "\n"


_printed_outputs: dict[tuple[tuple[str, ...], ...], str] = {}
"""The output of commands already run in this process: tables printed by one run (sources with the same
commands) are taken from it, the commands run once."""


def produce(name: str) -> str:
    """Run ``name``'s commands in a fresh folder and return its table (a printed table of commands
    already run for another table is taken from their output)."""
    source = SOURCES[name]
    if source.commands in _printed_outputs:
        return source.table(_printed_outputs[source.commands], Path())
    with tempfile.TemporaryDirectory(prefix=f"readme-{name}-") as tmp:
        folder = Path(tmp)
        output = ""
        # The folder's own store, whatever store the caller's environment points MLflow at.
        environment = {k: v for k, v in os.environ.items() if not k.startswith("MLFLOW_")}
        for command in source.commands:
            program = str(BIN / command[0])
            done = subprocess.run(
                [program, *command[1:]],
                cwd=folder,
                env=environment,
                capture_output=True,
                text=True,
                check=False,
            )
            if done.returncode != 0:
                raise SystemExit(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr[-3000:]}")
            output = done.stdout
        for pattern, destination in source.figures:
            shutil.copyfile(max(folder.glob(pattern)), REPOSITORY / destination)
        _printed_outputs[source.commands] = output
        return source.table(output, folder)


def numbers(table: str) -> list[float]:
    """The numbers of a table, in reading order (− read as a minus sign)."""
    return [float(n.replace("−", "-")) for n in NUMBER.findall(table)]


def same_figures(a: str, b: str, significant: int = 3) -> bool:
    """True if the two tables hold the same numbers to ``significant`` figures."""
    x, y = numbers(a), numbers(b)
    return len(x) == len(y) and all(
        f"{u:.{significant}g}" == f"{v:.{significant}g}" for u, v in zip(x, y, strict=False)
    )


def blocks(text: str) -> dict[str, str]:
    """The generated tables of one page by name."""
    return {m.group("name"): m.group("body") for m in BLOCK.finditer(text)}


def pages() -> list[Path]:
    """The files that may hold generated tables: the README and the site's pages."""
    return [README, *sorted(DOCS.rglob("*.md"))]


def site_blocks() -> dict[str, tuple[Path, str]]:
    """Every generated table of the README and the site by name, with the file holding it."""
    return {name: (page, body) for page in pages() for name, body in blocks(page.read_text()).items()}


def replace(text: str, name: str, table: str) -> str:
    """``text`` with the block ``name`` holding ``table``."""
    return BLOCK.sub(
        lambda m: m.group(1) + table + m.group(4) if m.group("name") == name else m.group(0), text
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help=f"tables to rewrite (default all: {', '.join(SOURCES)})")
    parser.add_argument("--check", action="store_true", help="compare with the pages, change nothing")
    args = parser.parse_args(argv)
    present = site_blocks()
    names = args.names or list(SOURCES)
    for name in names:
        if name not in SOURCES or name not in present:
            raise SystemExit(f"unknown table {name!r}: the site's generated tables are {sorted(present)}")
    stale, tables = [], {}
    for name in names:
        print(f"{name}: running (about {SOURCES[name].minutes:g} min)", flush=True)
        tables[name] = produce(name)
        page, body = present[name]
        if args.check and not same_figures(body, tables[name]):
            stale.append(name)
            print(f"{name}: {page.relative_to(REPOSITORY)} differs from a new run:\n{tables[name]}")
    if args.check:
        return 1 if stale else 0
    for name, table in tables.items():
        page = present[name][0]
        page.write_text(replace(page.read_text(), name, table))  # read again: edits made while runs ran
        print(f"rewrote {name} in {page.relative_to(REPOSITORY)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
