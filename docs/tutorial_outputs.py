"""Run the manual's lessons from a fresh clone, and write (or check) the output each page shows.

A lesson (``docs/getting-started.md``, ``docs/tutorials/*.md``) is a series of ``bash`` blocks the reader
types in order; a ``text`` block right after a ``bash`` block (blank lines between them at most) is what
that block prints, abridged: the lines the page chooses. This script runs every command of a page in
order, as a reader with a fresh clone would: in a new folder holding the repository's tracked files
(linked) and its ``.venv``, with an empty ``outputs/``, a new home (``~``), no ``../shared`` and the
folder's own MLflow store. A ``python`` or ``yaml`` block whose first line is ``# PATH`` is a file the page
asks the reader to write: it is written there (``~/…`` in the home, else in the clone) when the page
reaches it. Commands that start a server or need a robot or the network (``SKIPPED``) are not run.

    .venv/bin/python docs/tutorial_outputs.py                  # rewrite every lesson's outputs (about 3 min)
    .venv/bin/python docs/tutorial_outputs.py logs monitoring  # some lessons, by page name
    .venv/bin/python docs/tutorial_outputs.py logs --check     # exit 1 where a page differs from a new run

Rewriting keeps the lines a page shows and takes their text from the new run; an empty ``text`` block
gets every printed line (abridge it by hand, then rewrite). A line is found again by its text with the
numbers left out (in a table row, its first cell too), in order; one whose text changed takes the
printed line most like it, and is listed for a reader to look at. ``--check`` (the slow test
``tests/test_tutorials.py``) requires every line the page shows to be printed, in order, with each of its
numbers within 5 % of the new run's; durations (a number followed by s, ms or min, and the columns of a
table headed by one) are the machine's and are not compared. Paths, times and ids are written as the
reader's would be (``/home/you/lwrlab`` for the clone, ``<date>/<time>``, ``<id>``, ``python3.x``). A ``<!-- picture:
GLOB -->`` line before an image copies the newest file matching GLOB in the clone to the image's path.
"""

from __future__ import annotations

import argparse
import difflib
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]
DOCS = REPOSITORY / "docs"
LESSONS = [DOCS / "getting-started.md", *sorted((DOCS / "tutorials").glob("*.md"))]
"""The pages run as lessons, in the order a newcomer reads them."""
MIRRORS = {REPOSITORY / "README.md": DOCS / "getting-started.md"}
"""Pages whose first ``text`` block is a copy of a lesson's first output block (``make run``'s), not run."""
SKIPPED = {
    "mlflow ui": "serves the store until stopped (tests/test_server.py serves one)",
    "mlflow server": "serves the store until stopped (tests/test_server.py)",
    "ros2 ": "needs a robot and ROS 2",
    "make test": "the test suite itself",
    "python3 -m venv": "the clone's .venv exists already",
    "pip install": "the clone's .venv is installed already",
    "git clone": "the clone is made by this script",
    "cd lwrlab": "the clone is the working folder",
}
"""Commands not run, by a fragment, with the reason."""
PRINTED_FILE = ".printed"
"""What the lesson printed so far, in the clone (``$LWRLAB_PRINTED``): where an id the page asks the
reader to copy is read."""
COPIED = {
    "compare --parent <id>": (
        'compare --parent "$(grep -o \'compare --parent [0-9a-f]\\{32\\}\' "$LWRLAB_PRINTED"'
        " | tail -1 | cut -d' ' -f3)\""
    ),
}
"""Placeholders of a command filled as the reader fills them: the parent run id the sweep printed."""
HOME_SHOWN = "/home/you"
CLONE_SHOWN = f"{HOME_SHOWN}/lwrlab"
TOLERANCE = 0.05
MAKE_VARIABLES = {"ARGS", "MAKEFLAGS", "MFLAGS", "MAKELEVEL", "MAKEOVERRIDES", "PYTHON"}
"""What an enclosing make exports to the commands it runs (its command line's variables among them)."""
LIKENESS = 0.6
"""How alike (difflib's ratio of the lines without their numbers) a printed line must be to take the
place of a page's line whose text changed, when rewriting."""
MARK = "\x1e"

FENCE = re.compile(r"^(?P<indent> *)```(?P<language>\w*)\s*$")
NUMBER = re.compile(r"(?<![\w.=#])[-−+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?!\w)")
"""A number of a printed line; one right after ``=`` or ``#`` (``seed=1``, job ``#1``) is part of the text."""
DURATION = re.compile(r"^\s?(?:s|ms|min|µs)\b")
DURATION_COLUMN = re.compile(r"(?:_s|_ms|_us)\b|\[(?:s|ms|µs)\]|seconds|time", re.I)
STAMP = re.compile(r"^.*?\[\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d+\]")
"""A log record's time stamp, and a progress bar's frame that the record interrupted before it."""
RUN_FOLDER = re.compile(r"\d{4}-\d\d-\d\d([/_])\d\d-\d\d-\d\d(?:-\d+)?")
RUN_TIME = re.compile(r"(?<![\w-])\d\d-\d\d-\d\d-\d{6}(?![\w-])")
IDENTIFIER = re.compile(r"\b[0-9a-f]{32}\b")
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


@dataclass
class Block:
    """A fenced block of a page: its language, its lines (indentation removed) and where it sits."""

    language: str
    lines: list[str]
    start: int
    """Index of the page line after the opening fence."""
    indent: str
    output: Block | None = None
    """For a ``bash`` block: the ``text`` block right after it (what it prints)."""


@dataclass
class Run:
    """What the commands of each ``bash`` block printed (normalised lines) and the clone's folder."""

    printed: dict[int, list[str]] = field(default_factory=dict)
    failed: dict[int, int] = field(default_factory=dict)
    """Blocks a command of which exited with a status other than 0, with that status."""
    clone: Path | None = None


def blocks(text: str) -> list[Block]:
    """The fenced blocks of a page, each ``bash`` block with its output block."""
    found: list[Block] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        opening = FENCE.match(lines[i])
        if not opening:
            i += 1
            continue
        indent = opening.group("indent")
        end = next(j for j in range(i + 1, len(lines)) if lines[j].strip() == "```")
        body = [
            line[len(indent) :] if line.startswith(indent) else line.lstrip() for line in lines[i + 1 : end]
        ]
        block = Block(opening.group("language"), body, i + 1, indent)
        between = lines[found[-1].start + len(found[-1].lines) + 1 : i] if found else ["x"]
        if (
            block.language == "text"
            and found
            and found[-1].language == "bash"
            and not any(s.strip() for s in between)
        ):
            found[-1].output = block
        found.append(block)
        i = end + 1
    return found


def commands(block: Block) -> Iterator[str]:
    """The commands of a ``bash`` block: continuation lines joined, comments and blank lines left out."""
    pending = ""
    for line in block.lines:
        if line.rstrip().endswith("\\"):
            pending += line.rstrip()[:-1] + " "
            continue
        command = (pending + line).strip()
        pending = ""
        if command and not command.startswith("#"):
            yield command


def skipped(command: str) -> str | None:
    """Why ``command`` is not run, or None."""
    return next((why for fragment, why in SKIPPED.items() if fragment in command), None)


def normalise(raw: str, clone: Path, home: Path) -> list[str]:
    """Printed text as the page shows it: progress bars, colours, stamps, paths and ids as a reader's."""
    shown = []
    for line in ANSI.sub("", raw).split("\n"):
        line = line.split("\r")[-1].rstrip()  # a progress bar's last frame (often blank)
        for path, written in ((clone, CLONE_SHOWN), (REPOSITORY, CLONE_SHOWN), (home, HOME_SHOWN)):
            line = line.replace(str(path.resolve()), written).replace(str(path), written)
        line = STAMP.sub("[…]", line)
        line = RUN_TIME.sub("<time>", RUN_FOLDER.sub(lambda m: f"<date>{m.group(1)}<time>", line))
        line = re.sub(r"\bpython3\.\d+\b", "python3.x", line)  # the reader's Python may be another
        shown.append(IDENTIFIER.sub("<id>", line))
    return shown


def skeleton(line: str) -> str:
    """A line without its numbers (a table row keeps its first cell): what finds it again in a new run."""
    text = line.strip()
    if text.startswith("|"):
        cells = [c.strip() for c in text.strip("|").split("|")]
        rest = [re.sub(r"-{3,}", "--", NUMBER.sub("#", c)) for c in cells[1:]]
        first = re.sub(r"-{3,}", "--", cells[0])
        return "|".join([first, *rest])
    return " ".join(NUMBER.sub("#", text).split())


def numbers(line: str, skip_columns: set[int]) -> list[float | None]:
    """The line's numbers in order; None for a duration (not compared)."""
    text = line.strip()
    parts = [c for c in text.strip("|").split("|")] if text.startswith("|") else [text]
    found: list[float | None] = []
    for column, part in enumerate(parts):
        for match in NUMBER.finditer(part):
            duration = column in skip_columns or DURATION.match(part[match.end() :])
            found.append(None if duration else float(match.group().replace("−", "-")))
    return found


def duration_columns(shown: list[str], index: int) -> set[int]:
    """The columns of durations of the table the page's line ``index`` belongs to (by its header)."""
    if not shown[index].strip().startswith("|"):
        return set()
    start = index
    while start > 0 and shown[start - 1].strip().startswith("|"):
        start -= 1
    header = [c.strip() for c in shown[start].strip().strip("|").split("|")]
    return {i for i, cell in enumerate(header) if DURATION_COLUMN.search(cell)}


def most_like(line: str, printed: list[str], start: int) -> int | None:
    """The printed line from ``start`` on that reads most like ``line`` (at least :data:`LIKENESS`)."""
    scores = [
        (difflib.SequenceMatcher(None, skeleton(line), skeleton(printed[j])).ratio(), j)
        for j in range(start, len(printed))
    ]
    best = max(scores, default=(0.0, None))
    return best[1] if best[0] >= LIKENESS else None


def match(shown: list[str], printed: list[str], adopt: bool = False) -> tuple[list[str], list[str]]:
    """(the page's lines with the new run's text, the differences): see the module's docstring.

    ``adopt`` (rewriting): a line whose text changed is replaced by the printed line most like it."""
    rewritten, problems, position = list(shown), [], 0
    for i, line in enumerate(shown):
        if not line.strip() or line.strip() == "…":
            continue
        wanted = skeleton(line)
        found = next((j for j in range(position, len(printed)) if skeleton(printed[j]) == wanted), None)
        if found is None and adopt and (like := most_like(line, printed, position)) is not None:
            problems.append(f"text changed: {line.strip()}\n    now: {printed[like].strip()}")
            position, rewritten[i] = like + 1, printed[like]
            continue
        if found is None:
            problems.append(f"not printed (in this order): {line.strip()}")
            continue
        position = found + 1
        rewritten[i] = printed[found]
        columns = duration_columns(shown, i)
        for old, new in zip(numbers(line, columns), numbers(printed[found], columns), strict=True):
            if (
                old is not None
                and new is not None
                and not math.isclose(old, new, rel_tol=TOLERANCE, abs_tol=1e-9)
            ):
                problems.append(f"{line.strip()}\n    now: {printed[found].strip()}")
                break
    return rewritten, problems


def _files_to_write(block: Block, clone: Path, home: Path) -> Path | None:
    first = block.lines[0] if block.lines else ""
    path_match = re.fullmatch(r"# (~/)?([\w./-]+\.(?:py|yaml|csv))", first.strip())
    if block.language not in ("python", "yaml") or not path_match:
        return None
    target = (home if path_match.group(1) else clone) / path_match.group(2)
    if REPOSITORY in target.resolve().parents:
        raise SystemExit(f"{first}: the page would write into the repository itself")
    return target


def fresh_clone(folder: Path) -> tuple[Path, Path]:
    """(clone, home) in ``folder``: the repository's tracked top-level entries linked, ``.venv`` too."""
    clone, home = folder / "lwrlab", folder / "home"
    clone.mkdir()
    home.mkdir()
    tracked = subprocess.run(["git", "ls-files"], cwd=REPOSITORY, capture_output=True, text=True, check=True)
    for entry in sorted({line.split("/")[0] for line in tracked.stdout.splitlines()} | {".venv"}):
        if entry != "outputs" and (REPOSITORY / entry).exists():
            (clone / entry).symlink_to(REPOSITORY / entry)
    (clone / "outputs").mkdir()
    return clone, home


def run_page(page: Path, folder: Path) -> Run:
    """Run ``page``'s commands in a fresh clone under ``folder``: what each bash block printed."""
    clone, home = fresh_clone(folder)
    # a reader's shell: no MLflow, venv or ROS 2 settings (the test suite's own domain), nor what an
    # enclosing `make test ARGS=…` exports (make puts its command line's variables into the environment,
    # which `make run` would read)
    environment = {
        k: v
        for k, v in os.environ.items()
        if not k.startswith(("MLFLOW_", "VIRTUAL_ENV", "ROS_")) and k not in MAKE_VARIABLES
    }
    real_home = Path.home()
    environment |= {
        "HOME": str(home),
        "MAKEFLAGS": "-o .venv/.installed",  # never reinstall .venv from the clone (a link to the repository's)
        "MPLCONFIGDIR": environment.get("MPLCONFIGDIR", str(real_home / ".cache" / "matplotlib")),
        "LWRLAB_CACHE_DIR": environment.get("LWRLAB_CACHE_DIR", str(real_home / ".cache" / "lwrlab")),
    }
    printed = clone / PRINTED_FILE
    script = [f"cd {clone}", f"export LWRLAB_PRINTED='{printed}'", f"exec > >(tee -a '{printed}') 2>&1"]
    ordered = blocks(page.read_text())
    for index, block in enumerate(ordered):
        target = _files_to_write(block, clone, home)
        if target is not None:
            script += [
                f"mkdir -p '{target.parent}'",
                f"cat > '{target}' <<'LWRLAB_PAGE_FILE'",
                *block.lines,
                "LWRLAB_PAGE_FILE",
            ]
        if block.language != "bash":
            continue
        for command in commands(block):
            if skipped(command):
                continue
            for placeholder, filled in COPIED.items():
                command = command.replace(placeholder, filled)
            script += [f"printf '{MARK}BLOCK {index}\\n'", command, f"printf '{MARK}EXIT %d\\n' $?"]
    done = subprocess.run(
        ["bash", "-c", "\n".join(script)], env=environment, stdout=subprocess.PIPE, timeout=1800, check=False
    )
    outcome, current = Run(clone=clone), None
    for chunk in done.stdout.decode("utf-8", "replace").split(MARK):
        head, _, rest = chunk.partition("\n")
        if head.startswith("BLOCK "):
            current = int(head.split()[1])
            outcome.printed.setdefault(current, []).extend(normalise(rest, clone, home))
        elif head.startswith("EXIT ") and current is not None and int(head.split()[1]) != 0:
            outcome.failed.setdefault(current, int(head.split()[1]))
    return outcome


def failures(page: Path, run: Run) -> list[str]:
    """The blocks that failed where the page expects no error (no ``lwrlab:`` line in their output)."""
    problems = []
    for index, block in enumerate(blocks(page.read_text())):
        shown = block.output.lines if block.output is not None else []
        if index in run.failed and not any(s.startswith("lwrlab:") for s in shown):
            tail = "\n".join(run.printed[index][-40:])
            problems.append(f"block {index} failed (exit status {run.failed[index]}):\n{tail}")
    return problems


def _replace_block(lines: list[str], block: Block, new: list[str]) -> None:
    lines[block.start : block.start + len(block.lines)] = [f"{block.indent}{s}".rstrip() for s in new]


def rewrite(page: Path, run: Run) -> list[str]:
    """Write the new run's outputs (and pictures) into ``page``; the lines that could not be kept."""
    text = page.read_text()
    lines = text.splitlines()
    problems = [p for p in failures(page, run) if "block" in p and not _fills(page, p)]
    for index, block in reversed(list(enumerate(blocks(text)))):
        if block.output is None:
            continue
        printed = [s for s in run.printed.get(index, []) if s.strip()]
        shown = block.output.lines
        if not any(s.strip() for s in shown):
            new = printed
        else:
            new, differences = match(shown, printed, adopt=True)
            problems += [d for d in differences if d.startswith(("not printed", "text changed"))]
        _replace_block(lines, block.output, new)
    assert run.clone is not None
    for i, line in enumerate(lines):
        picture = re.match(r"\s*<!-- picture: (\S+) -->", line)
        if picture:
            image = re.search(r"\]\(([^)]+)\)", lines[i + 1])
            assert image, f"{page.name}: the line after {line.strip()} shows no image"
            copy_picture(run.clone, picture.group(1), (page.parent / image.group(1)).resolve())
    page.write_text("\n".join(lines) + "\n")
    return problems


def _fills(page: Path, problem: str) -> bool:
    """Whether the failed block of ``problem`` has an empty output block (a new block: filled, not judged)."""
    index = int(problem.split()[1])
    output = blocks(page.read_text())[index].output
    return output is not None and not any(s.strip() for s in output.lines)


def copy_picture(clone: Path, pattern: str, destination: Path) -> None:
    found = sorted(clone.glob(pattern), key=lambda p: p.stat().st_mtime)
    if not found:
        raise SystemExit(f"no file {pattern} in the clone for {destination.name}")
    shutil.copyfile(found[-1], destination)


def check(page: Path, run: Run) -> list[str]:
    """The differences between what ``page`` shows and what ``run`` printed (empty: the page holds)."""
    problems = failures(page, run)
    for index, block in enumerate(blocks(page.read_text())):
        if block.output is not None:
            printed = [s for s in run.printed.get(index, []) if s.strip()]
            problems += [f"block {index}: {p}" for p in match(block.output.lines, printed)[1]]
    assert run.clone is not None
    for pattern in re.findall(r"<!-- picture: (\S+) -->", page.read_text()):
        if not any(run.clone.glob(pattern)):
            problems.append(f"no file {pattern} for the page's picture")
    return problems


def first_output(page: Path) -> Block:
    found = next((b.output for b in blocks(page.read_text()) if b.output is not None), None)
    if found is None:
        raise SystemExit(f"{page.name} shows no output block")
    return found


def first_text(page: Path) -> Block:
    found = next((b for b in blocks(page.read_text()) if b.language == "text"), None)
    if found is None:
        raise SystemExit(f"{page.name} has no text block")
    return found


def mirror(page: Path, source: Path) -> None:
    """Copy ``source``'s first output block into ``page``'s first ``text`` block."""
    lines = page.read_text().splitlines()
    _replace_block(lines, first_text(page), first_output(source).lines)
    page.write_text("\n".join(lines) + "\n")


def lesson(name: str) -> Path:
    found = [p for p in LESSONS if p.stem == name]
    if not found:
        raise SystemExit(f"unknown lesson {name!r}: {', '.join(p.stem for p in LESSONS)}")
    return found[0]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pages", nargs="*", help="lessons by page name (default: all)")
    parser.add_argument("--check", action="store_true", help="compare with the pages, change nothing")
    args = parser.parse_args(argv)
    pages = [lesson(n) for n in args.pages] if args.pages else LESSONS
    failed = False
    for page in pages:
        print(f"{page.relative_to(REPOSITORY)}: running", flush=True)
        with tempfile.TemporaryDirectory(prefix=f"lesson-{page.stem}-") as folder:
            run = run_page(page, Path(folder))
            problems = check(page, run) if args.check else rewrite(page, run)
        for problem in problems:
            print(f"  {problem}")
        failed |= bool(problems)
    if not args.check:
        for page, source in MIRRORS.items():
            if source in pages:
                mirror(page, source)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
