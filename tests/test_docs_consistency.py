"""The manual holds together, read as a newcomer reads it (fast: the pages only, nothing is run).

- no placeholder (``@@NAME@@``) is left on a page;
- a sentence that points at a section, a step, a table or a list below or above has one there;
- a figure a page quotes from a generated table (``docs/readme_tables.py``) is that table's, and the
  figures written once and included (the status, ``make run``'s output) are the same wherever shown;
- history stays in the changelog: no "was … before", "last round" or "speed work" on a user page;
- the lessons start from a fresh clone: shipped inputs only, every output block filled, every
  picture there; commands call the clone's programs (``.venv/bin/…``) in the same way everywhere;
- the README is a front door of at most 150 lines that installs before it uses ``.venv``;
- the words of the glossary are linked where a lesson first uses them.

The lessons themselves run end to end in ``tests/test_tutorials.py`` (slow).
"""

from __future__ import annotations

import importlib.util
import re
import sys
import tomllib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
README = ROOT / "README.md"
CHANGELOG_PAGE = DOCS / "changelog.md"
PAGES = [README, *sorted(p for p in DOCS.rglob("*.md") if p != CHANGELOG_PAGE)]
"""The pages a reader reads (the changelog is history by design)."""
LESSONS = [DOCS / "getting-started.md", *sorted((DOCS / "tutorials").glob("*.md"))]
PAPER = ROOT.parent / "shared" / "seed" / "000_cc0cb678eec2a463.txt"


def _script(name: str):  # docs/ is not a package: load its scripts by path
    spec = importlib.util.spec_from_file_location(name, DOCS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def prose(text: str) -> str:
    """A page with its fenced blocks and HTML comments blanked (its lines keep their numbers)."""

    def blank(match: re.Match[str]) -> str:
        return "\n" * match.group().count("\n")

    text = re.sub(r"<!--.*?-->", blank, text, flags=re.S)
    return re.sub(r"(?ms)^ *```.*?^ *```[ \t]*$", blank, text)


def relative(path: Path) -> str:
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else path.name


# --- placeholders and references ----------------------------------------------------------------


def test_no_placeholder_is_left_on_a_page() -> None:
    left = {relative(p): re.findall(r"@@[^@\s]+@@", p.read_text()) for p in PAGES}
    left |= {relative(p): re.findall(r"@@[^@\s]+@@", p.read_text()) for p in (DOCS / "snippets").glob("*.md")}
    assert {page: found for page, found in left.items() if found} == {}


POINTERS: dict[str, tuple[str, str]] = {
    # phrase pattern: (where the thing must be, what it is: a regex a line of it matches)
    r"\b(?:next|following) (?:section|step)s?\b|\b(?:section|sections|step|steps) below\b": (
        "after",
        r"^#{1,6} ",
    ),
    r"\b(?:previous|last) section\b|\b(?:section|sections) above\b": ("before", r"^#{1,6} "),
    r"\b(?:table|tables) below\b|\bfollowing table\b": ("after", r"^\s*\|"),
    r"\b(?:table|tables|formats?) above\b": ("before", r"^\s*\|"),
    r"\b(?:list|items) below\b": ("after", r"^\s*[-*] "),
    r"\b(?:list|items) above\b": ("before", r"^\s*[-*] "),
    r"\b(?:figure|picture|image) below\b": ("after", r"!\["),
    r"\b(?:command|commands|sweep) above\b": ("before", r"^ *```bash"),
    r"\b(?:command|commands) below\b": ("after", r"^ *```bash"),
}
"""A sentence's pointer, and what must stand before or after it on the page for it to point at."""


def pointers(page: Path) -> Iterator[str]:
    """The pointers of ``page`` that point at nothing: "as in the next section" where none follows."""
    text = page.read_text()
    readable = prose(text)
    lines = text.splitlines()
    for pattern, (side, target) in POINTERS.items():
        for found in re.finditer(pattern, readable, flags=re.I):
            where = readable[: found.start()].count("\n")
            scope = lines[where + 1 :] if side == "after" else lines[:where]
            if not any(re.search(target, s) for s in scope):
                yield f"{relative(page)}:{where + 1}: '{found.group()}' points at nothing {side} it"
    for found in re.finditer(r"\bstep (\d+)\b", readable):
        if not re.search(rf"(?m)^#{{2,3}} {found.group(1)}\. ", text):
            yield f"{relative(page)}: 'step {found.group(1)}' but the page has no step {found.group(1)}"


def test_a_sentence_pointing_at_a_section_finds_it() -> None:
    assert [problem for page in PAGES for problem in pointers(page)] == []


def test_the_pointer_check_fails_where_nothing_follows(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text(
        "# Title\n\nRecord the log, then identify as in the next section:\n\n| key | what |\n|---|---|\n"
    )
    assert len(list(pointers(page))) == 1
    page.write_text("# Title\n\nIdentify as in the next section.\n\n## Identify\n\nText, then step 2.\n")
    assert [p for p in pointers(page) if "step 2" in p]  # no "## 2." heading
    page.write_text("# Title\n\nIdentify as in the next section.\n\n## 2. Identify\n\nAs in step 2.\n")
    assert list(pointers(page)) == []


# --- figures and their sources -----------------------------------------------------------------


def markdown_table(body: str) -> list[dict[str, str]]:
    """The rows of a markdown table as {header: cell}."""
    lines = [line for line in body.strip().splitlines() if line.startswith("|")]
    header = [c.strip() for c in lines[0].strip("|").split("|")]
    return [
        dict(zip(header, (c.strip() for c in line.strip("|").split("|")), strict=False)) for line in lines[2:]
    ]


def generated_tables() -> dict[str, list[dict[str, str]]]:
    tables = _script("readme_tables")
    return {name: markdown_table(body) for name, (_, body) in tables.site_blocks().items() if body.strip()}


def _row(table: list[dict[str, str]], **wanted: str) -> dict[str, str]:
    found = [row for row in table if all(row.get(k) == v for k, v in wanted.items())]
    assert len(found) == 1, (wanted, found)
    return found[0]


@dataclass(frozen=True)
class Claim:
    """A figure a page quotes (the group of ``pattern``) and where it comes from."""

    page: str
    pattern: str
    source: Callable[[dict[str, list[dict[str, str]]]], float]
    """The figure from the site's generated tables (by name)."""
    significant: int = 2
    """The quote agrees with its source to this many significant figures."""


def _monitor(column: str, model: str = "identified", thresholds: str = "state", estimator: str = "observer"):
    return lambda t: float(
        _row(t["monitor"], model=model, thresholds=thresholds, estimator=estimator)[column]
    )


CLAIMS = [
    Claim("docs/benchmarks.md", r"median delay of ([\d.]+) ms", _monitor("median delay [ms]"), 3),
    Claim("docs/benchmarks.md", r"a torque error of ([\d.]+) N·m", _monitor("τ_ext RMS error [N·m]")),
    Claim("docs/benchmarks.md", r"detects all (\d+) contacts of ≥ 10 N", _monitor("contacts ≥ 10 N")),
    Claim(
        "docs/benchmarks.md",
        r"only (\d+) of the \d+ contacts cross",
        _monitor("detectable", model="CAD", thresholds="constant"),
    ),
    Claim("docs/benchmarks.md", r"the largest (\d+) ms\)", _monitor("max delay [ms]")),
    Claim(
        "docs/benchmarks.md",
        r"the torque error is ([\d.]+) N·m",
        _monitor("τ_ext RMS error, raw truth [N·m]"),
    ),
    Claim(
        "docs/paper.md",
        r"and FC3 \(([\d.]+) N·m",
        lambda t: float(_row(t["table2"], parameter="FC3")["truth"]),
    ),
    Claim(
        "docs/paper.md",
        r"and FC3 \([\d.]+ N·m, %σ ([\d.]+)\)",
        lambda t: float(_row(t["table2"], parameter="FC3")["pct_sigma"]),
    ),
]
"""Figures quoted in prose from a generated table: regenerate the table, and these must follow."""


def _significant(value: float, digits: int) -> str:
    return f"{value:.{digits}g}"


def test_quoted_figures_agree_with_their_generated_tables() -> None:
    tables = generated_tables()
    wrong = []
    for claim in CLAIMS:
        text = " ".join((ROOT / claim.page).read_text().split())
        found = re.search(claim.pattern, text)
        assert found, f"{claim.page} no longer says {claim.pattern!r}: update the claim with the page"
        quoted, source = float(found.group(1)), claim.source(tables)
        if _significant(quoted, claim.significant) != _significant(source, claim.significant):
            wrong.append(f"{claim.page}: {found.group(0)!r} but its generated table says {source:g}")
    assert wrong == []


def test_the_fig6_report_runs_the_seeds_its_table_shows() -> None:
    text = " ".join((DOCS / "paper.md").read_text().split())
    commands = re.findall(r"experiment=paper_fig6_criteria \"?task\.seeds=\[([\d,]+)\]", text)
    assert commands, "paper.md no longer shows the Fig. 6 command beside its tables"
    shown = {len(seeds.split(",")) for seeds in commands}
    table = generated_tables().get("fig6")
    if table:
        shown.add(int(float(table[0]["seeds"])))
    assert len(shown) == 1, f"paper.md's Fig. 6 commands and table disagree on the seeds: {shown}"
    assert not re.search(r"over \d+ seeds", text) or f"over {shown.pop()} seeds" in text


def test_the_claim_check_sees_a_figure_that_moved() -> None:
    table = markdown_table(
        "| model | thresholds | estimator | median delay [ms] |\n|---|---|---|--:|\n| identified | state | observer | 11.5 |\n"
    )
    claim = Claim("x", r"(\d+)", _monitor("median delay [ms]"), 3)
    assert _significant(claim.source({"monitor": table}), 3) == _significant(11.5, 3)
    assert _significant(12.0, 3) != _significant(claim.source({"monitor": table}), 3)


def test_the_status_names_the_packaged_version() -> None:
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert f"**Version {version}" in (DOCS / "snippets" / "status.md").read_text()


def test_what_make_run_prints_is_the_same_in_the_readme_and_getting_started() -> None:
    lessons = _script("tutorial_outputs")
    shown = lessons.first_text(README).lines
    assert shown == lessons.first_output(DOCS / "getting-started.md").lines
    assert any("Identification" in line for line in shown)


def test_the_citation_is_the_papers() -> None:
    about = (DOCS / "about.md").read_text()
    doi = re.search(r"doi:(10\.\d+/[\w.]+)\]", about)
    assert doi is not None, "about.md names no DOI"
    assert re.search(rf"doi\s*=\s*\{{{re.escape(doi.group(1))}\}}", about), "the BibTeX entry has another DOI"
    assert doi.group(1) in README.read_text()
    if not PAPER.is_file():
        pytest.skip(f"the paper's text is not here ({PAPER}): a user's clone has no ../shared")
    assert doi.group(1) in PAPER.read_text()


# --- lists generated from the code --------------------------------------------------------------


def test_the_configuration_overview_lists_every_option_of_every_group() -> None:
    """The overview's table is the config tree's (``docs/config_overview.py``): an option added to a
    group and not to the page fails here; ``docs/readme_tables.py config_groups`` rewrites it."""
    overview = _script("config_overview")
    page = (DOCS / "explanation" / "configuration.md").read_text()
    block = re.search(r"<!-- generated: config_groups -->\n(.*?)<!-- /generated -->", page, re.S)
    assert block is not None, "configuration.md has no generated config_groups table"
    missing = [
        f"{group}={option}"
        for group in overview.groups()
        for option in overview.config_group(group)
        if f"`{option}`"
        not in next((row for row in block.group(1).splitlines() if f"| `{group}` |" in row), "")
    ]
    assert missing == [], f"options missing from the page: {missing}"
    assert block.group(1) == overview.overview_table()


# --- history and commands ----------------------------------------------------------------------

HISTORY = [
    r"\blast round\b",
    r"\bspeed work\b",
    r"\bbefore the [\w-]+ study\b",
    r"\(before\)",
    r"\bearlier code\b",
    r"\bprevious code\b",
    r"\bwhat changed\b(?! from one version)(?! between versions)(?!:)",
    r"\bflaky\b",
    r"\bprevious (?:default|release|sdp)\b",
    r"\bthe release before\b",
    r"\bas before\b",
    r"\bold: ",
    r"\bwas \d[\d.,]*\s*(?:s|min|ms|%)\b",
    r"\bbefore, \d",
    r"\bnow: wall\b",
]
"""How history reads on a user page; it belongs in CHANGELOG.md."""


def test_pages_describe_what_is_and_the_changelog_what_was() -> None:
    found = [
        f"{relative(page)}: {match.group()!r}"
        for page in PAGES
        for pattern in HISTORY
        for match in re.finditer(pattern, prose(page.read_text()), flags=re.I)
    ]
    assert found == []


def bash_lines(page: Path) -> Iterator[str]:
    for body in re.findall(r"```bash\n(.*?)```", page.read_text(), flags=re.S):
        for line in body.splitlines():
            if line.strip() and not line.lstrip().startswith("#"):
                yield line.strip()


def test_commands_call_the_clones_programs_by_their_path() -> None:
    bare = [
        f"{relative(page)}: {line}"
        for page in PAGES
        for line in bash_lines(page)
        if re.match(r"^(?:\w+=\S+\s+)*(?:lwrlab|mlflow|python)\s", line)
    ]
    assert bare == []


def test_lessons_start_from_a_fresh_clone_and_show_what_they_print() -> None:
    lessons = _script("tutorial_outputs")
    for page in LESSONS:
        text = page.read_text()
        assert "../shared" not in text, f"{relative(page)} reads data a user's clone does not have"
        outputs = [b.output for b in lessons.blocks(text) if b.output is not None]
        assert outputs, f"{relative(page)} shows no output"
        assert all(any(line.strip() for line in o.lines) for o in outputs), (
            f"{relative(page)}: an empty output"
        )
        for image in re.findall(r"<!-- picture: \S+ -->\n!\[[^\]]*\]\(([^)]+)\)", text):
            assert (page.parent / image).is_file(), f"{relative(page)}: {image} is not there"
    assert {p.stem for p in LESSONS} >= {
        "own-robot",
        "logs",
        "sweep-mlflow",
        "plugin",
        "drive-trains",
        "monitoring",
    }


def test_the_readme_is_a_front_door() -> None:
    text = README.read_text()
    lines = text.splitlines()
    assert len(lines) <= 150, len(lines)
    install = next(i for i, line in enumerate(lines) if "python3 -m venv .venv" in line)
    first_use = next(i for i, line in enumerate(lines) if ".venv/bin/" in line)
    assert install < first_use, "the README uses .venv before it creates it"
    for image in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        assert (ROOT / image).is_file(), image
    for link in ("docs/about.md", "docs/glossary.md", "docs/getting-started.md", "make run", "make test"):
        assert link in text, link


# --- the glossary ------------------------------------------------------------------------------

TERMS = {
    r"%σ": "relative-standard-deviation",
    r"\bNRMS\b": "rms-and-nrms",
    r"\bbase parameters?\b": "base-parameters",
    r"\bW_b\b": "regressor",
    r"\bprior share\b": "prior-share",
    r"\bcoverage\b": "coverage",
    r"\bidentifiability\b": "identifiability",
    r"\btrue robot\b": "simulated-truth",
    r"\bpoorly known\b": "poorly-known",
    r"\bexpected (?:std|standard deviation)\b": "expected-standard-deviation",
}
"""Words a newcomer meets and the glossary's section that explains each."""
LINKED_PAGES = [*LESSONS, DOCS / "index.md", DOCS / "explanation" / "chain.md"]


def unlinked_first_uses(page: Path) -> Iterator[str]:
    text = re.sub(r"`[^`\n]*`", "``", prose(page.read_text()))  # inline code is a name, not a word
    text = "\n".join(line for line in text.splitlines() if not line.startswith("#"))  # nor a heading
    links = [(m.start(), m.end(), m.group(2)) for m in re.finditer(r"\[([^\]]*)\]\(([^)]*)\)", text)]
    for term, anchor in TERMS.items():
        first = re.search(term, text, flags=re.I)
        if first is None:
            continue
        inside = [target for start, end, target in links if start <= first.start() < end]
        if not any(f"glossary.md#{anchor}" in target for target in inside):
            line = text[: first.start()].count("\n") + 1
            yield f"{relative(page)}: '{first.group()}' first used unlinked (prose line {line})"


def test_glossary_words_are_linked_where_a_lesson_first_uses_them() -> None:
    assert [problem for page in LINKED_PAGES for problem in unlinked_first_uses(page)] == []


def test_every_glossary_anchor_is_a_section_of_the_glossary() -> None:
    headings = re.findall(r"(?m)^### (.+)$", (DOCS / "glossary.md").read_text())
    anchors = {re.sub(r"[^\w\s-]", "", h).strip().lower().replace(" ", "-") for h in headings}
    used = {a for p in PAGES for a in re.findall(r"glossary\.md#([\w-]+)", p.read_text())}
    assert set(TERMS.values()) <= anchors and used <= anchors, (used - anchors, set(TERMS.values()) - anchors)


# --- the lessons' runner (docs/tutorial_outputs.py) ------------------------------------------


def test_the_runner_pairs_each_command_block_with_what_it_prints() -> None:
    lessons = _script("tutorial_outputs")
    page = "# T\n\n```bash\necho a\n```\n\n```text\na\n```\n\nProse.\n\n```text\nnot an output\n```\n"
    found = lessons.blocks(page)
    assert [b.language for b in found] == ["bash", "text", "text"]
    assert found[0].output is found[1] and found[1].output is None and found[2].output is None
    assert list(
        lessons.commands(lessons.blocks("```bash\nls a \\\n  b  # files\n# a comment\n\n```\n")[0])
    ) == ["ls a    b  # files"]


def test_the_runner_compares_lines_by_their_text_and_numbers_within_tolerance() -> None:
    lessons = _script("tutorial_outputs")
    shown = ["fit 0.569 %, mean RMS 0.1003 N·m", "…", "stages: identification 1.4 s"]
    printed = ["[…] noise", "fit 0.571 %, mean RMS 0.1004 N·m", "x", "stages: identification 9.9 s"]
    assert lessons.match(shown, printed)[1] == []  # within 5 %; durations are the machine's
    assert lessons.match(shown, ["fit 0.7 %, mean RMS 0.1003 N·m", "stages: identification 1 s"])[1]
    assert lessons.match(shown, ["fit 0.569 %, mean RMS 0.1003 N·m"])[1]  # a line no longer printed
    table = ["| joint | rms | fit_cpu_s [s] |", "|--:|--:|--:|", "| 2 | 0.0998 | 0.3 |"]
    printed_table = ["| joint | rms | fit_cpu_s [s] |", "|--:|--:|--:|", "| 1 | 0.2 | 9 |", "| 2 | 0.1 | 7 |"]
    assert lessons.match(table, printed_table)[1] == []  # row 2 found by its first cell, timing column free
    assert lessons.match(table, [*printed_table[:2], "| 2 | 0.2 | 0.3 |"])[1]


def test_the_runner_writes_paths_times_and_ids_as_a_readers() -> None:
    lessons = _script("tutorial_outputs")
    clone, home = Path("/tmp/lesson-x/lwrlab"), Path("/tmp/lesson-x/home")
    raw = (
        "bar 10%|█\r[2026-11-28 23:46:28,697][lwrlab][INFO] - artifacts written to "
        "/tmp/lesson-x/lwrlab/outputs/runs/2026-11-28/23-46-26-131192\nrun c53c2d564e984f42a276f338691722ad"
    )
    assert lessons.normalise(raw, clone, home) == [
        "[…][lwrlab][INFO] - artifacts written to /home/you/lwrlab/outputs/runs/<date>/<time>",
        "run <id>",
    ]


def test_every_headline_metric_is_in_the_catalogue_with_its_unit() -> None:
    from lwrlab.tracking.job_config.metric_catalogue import CATALOGUE, describe
    from lwrlab.tracking.job_config.naming import HEADLINE_METRICS

    for name, (unit, _) in HEADLINE_METRICS.items():
        family = describe(name)
        assert family is not None and family.unit == unit, name
    assert describe("rms_joint12").name == "rms_joint<k>" and describe("com_error_mm").unit == "mm"
    assert len({f.name for f in CATALOGUE}) == len(CATALOGUE)
