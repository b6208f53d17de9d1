"""Every command the README and the manual show is exercised: docs that drift from the code fail here.

Commands are read from the README's fenced bash blocks and from inline code that starts like a
command. A job command (``make run ARGS="…"``, ``lwrlab …``) composes with its overrides and passes
the settings checks; a subcommand (``lwrlab compare …``) parses with its own argument parser; a
benchmark's options exist in its parser; a module run with ``-m`` runs. The README's own plugin
examples (``~/my_lab/…``) are written to disk and used as the README says. Commands that need a
cluster, a database host or a finished run are listed in ``ELSEWHERE`` with the test or CI step
that covers them, so a new command with no coverage fails the test.
"""

from __future__ import annotations

import importlib
import importlib.util
import re
import shlex
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from composing import compose_config
from hydra.utils import instantiate

from lwrlab.cli import SUBCOMMANDS
from lwrlab.pipeline.config_checks import violations

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCUMENTS = [README, *sorted((ROOT / "docs").rglob("*.md"))]
"""The README and the manual's pages (docs/): every command either shows is checked."""


def documents_text() -> str:
    """The README and every page of the manual, one after the other."""
    return "\n\n".join(path.read_text() for path in DOCUMENTS)


AS_IS = {
    "make test": "CI runs it (.ci/run)",
    "make run": "CI's slow suite runs the main job (tests/test_end_to_end.py)",
}
"""The README's two commands, exactly as written, with what runs them."""

ELSEWHERE = {
    "mlflow ui": "tests/test_server.py serves a store with `mlflow server` (same app)",
    "mlflow server": "tests/test_server.py starts `mlflow server` on 127.0.0.1",
    "createdb": "PostgreSQL is not available here; the server test covers the tracking path",
    "--config-path": "tests/test_sweeps.py re-runs a logged config",
    "pip install": "the install itself: CI's `make test` installs a clean clone the same way",
}
"""Commands covered by another test or by CI, by a fragment they contain, with where."""

SHELL_OPERATORS = {">", ">>", "<", "&", "|", ";", "&&", "||"}
"""Where a command's own words end on the page's line."""

COMMAND = re.compile(r"^(?:\w+=\S+\s+)*(?:\.venv/bin/)?(?:lwrlab|python|mlflow|make|createdb)\b")


def _fenced_commands(text: str) -> Iterator[str]:
    for language, body in re.findall(r"```(\w*)\n(.*?)```", text, flags=re.S):
        if language in ("bash", "sh"):
            yield from _join_continuations(body.splitlines())


def _join_continuations(lines: list[str]) -> Iterator[str]:
    pending = ""
    for line in lines:
        line = line.split(" # ")[0].rstrip() if not line.lstrip().startswith("#") else ""
        if line.endswith("\\"):
            pending += line[:-1] + " "
            continue
        line = (pending + line).strip()
        pending = ""
        if COMMAND.match(line):
            yield line


def _inline_commands(text: str) -> Iterator[str]:
    for code in re.findall(r"`([^`\n]+)`", text):
        named_only = re.fullmatch(r"(?:\.venv/bin/)?lwrlab \w+", code)  # `lwrlab compare`: a name
        command = re.match(r"^(?:\.venv/bin/)?lwrlab |^make run|^(?:\.venv/bin/)?python benchmarks/", code)
        if command and not named_only:
            yield code


def readme_commands() -> list[str]:
    text = documents_text()
    return sorted(set(_fenced_commands(text)) | set(_inline_commands(text)))


def _covered_elsewhere(command: str) -> str | None:
    if command in AS_IS:
        return AS_IS[command]
    return next((where for fragment, where in ELSEWHERE.items() if fragment in command), None)


def _words(command: str) -> list[str]:
    """The command's words after shell expansion of the README's variables (D, HOME)."""
    shared = ROOT.parent / "shared" / "data" / "kuka_lwr4_hw"
    command = command.replace("$D", str(shared)).replace("$HOME", "/home/user").replace("~", "/home/user")
    command = re.sub(r"<(\w+)>", r"\1", command)  # outputs/runs/<date>/<time>/…: the reader's run
    words = shlex.split(command)
    # what the shell does around the command (redirections, running it in the background) is not its
    operators = [i for i, w in enumerate(words) if w in SHELL_OPERATORS or re.match(r"^\d?>", w)]
    words = words[: operators[0]] if operators else words
    while words and re.match(r"^\w+=", words[0]):  # PYTHONPATH=… prefix
        words.pop(0)
    if words[:2] == ["make", "run"]:
        args = [w[len("ARGS=") :] for w in words if w.startswith("ARGS=")]
        return ["lwrlab", *shlex.split(args[0] if args else "")]
    return words


def _first_of_sweep(override: str) -> str:
    """``key=a,b,c`` → ``key=a`` (commas inside brackets or braces belong to one value)."""
    key, _, value = override.partition("=")
    depth = 0
    for i, char in enumerate(value):
        depth += 1 if char in "[{(" else -1 if char in "]})" else 0
        if char == "," and depth == 0:
            return f"{key}={value[:i]}"
    return override


def _job_overrides(words: list[str]) -> list[str]:
    overrides = []
    for word in words[1:]:
        if word == "-m" or word.startswith("hydra/launcher=") or word.startswith("hydra.searchpath"):
            continue  # launchers and search paths are Hydra's, composed below where they matter
        if "…" in word:  # `robot=…`: the reader's own robot
            continue
        overrides.append(_first_of_sweep(word))
    return overrides


def test_the_readme_shows_commands() -> None:
    commands = readme_commands()
    assert len(commands) > 40, commands  # the extraction itself works
    assert any(c.startswith("make run ARGS=") for c in commands)
    assert any("compare --experiment" in c for c in commands)


@pytest.mark.parametrize("command", readme_commands())
def test_readme_command_is_exercised(command: str, tmp_path: Path) -> None:
    if _covered_elsewhere(command):
        return
    words = _words(command)
    if words[0] == "python" or words[0].endswith("/python"):
        if words[1] == "-m":  # a module of the package, run as the README says
            done = subprocess.run([sys.executable, *words[1:]], capture_output=True, text=True, timeout=120)
            assert done.returncode == 0, done.stderr
            return
        _write_readme_files(tmp_path)  # a script the page itself asks the reader to write
        script = ROOT / words[1] if (ROOT / words[1]).is_file() else tmp_path / words[1]
        assert script.is_file(), f"{words[1]} named in the README does not exist"
        source = script.read_text()
        for option in (w.split("=")[0] for w in words[2:] if w.startswith("--")):
            assert f'"{option}"' in source, f"{words[1]} has no option {option}"
        return
    assert words[0].endswith("lwrlab"), command
    if len(words) > 1 and words[1] in SUBCOMMANDS:
        parser = importlib.import_module(SUBCOMMANDS[words[1]]).build_parser()
        parser.parse_args(words[2:])  # exits (fails the test) on an option that does not exist
        return
    overrides = _job_overrides(words)
    # The README's own plugins (~/my_lab/…, plugins/estimators/ridge.py), written where it says:
    # the reader's search path is the written conf/, their modules importable as the README sets up.
    _write_readme_files(tmp_path)
    if any(w.startswith("hydra.searchpath") for w in words) or "ridge" in command:
        overrides.append(f"hydra.searchpath=[file://{tmp_path / 'conf'}]")
    sys.path.insert(0, str(tmp_path))
    estimators = importlib.import_module("plugins.estimators")
    estimators.__path__.append(str(tmp_path / "plugins" / "estimators"))
    try:
        cfg = compose_config(*overrides)
        assert violations(cfg) == [], command
        if "criterion=inverse_trace" in overrides:
            criterion = instantiate(cfg.criterion)
            w = np.random.default_rng(0).standard_normal((50, 6))
            value, gradient = criterion.value_and_gradient(w)
            assert np.isfinite(value) and gradient.shape == w.shape
        if "estimator=ridge" in overrides:
            estimator = instantiate(cfg.estimator)
            assert estimator.get_params() == {"alpha": 1e-3}
    finally:
        sys.path.remove(str(tmp_path))
        estimators.__path__.remove(str(tmp_path / "plugins" / "estimators"))
        for name in ("my_criteria", "plugins.estimators.ridge"):
            sys.modules.pop(name, None)


def _write_readme_files(root: Path) -> None:
    """The files the README's and the manual's python and yaml blocks ask the reader to write, under
    ``root``."""
    text = documents_text()
    for body in re.findall(r"```(?:python|yaml)\n(.*?)```", text, flags=re.S):
        match = re.match(r"# (?:~/my_lab/)?((?:conf|plugins)/\S+|\w+\.py)\n", body)
        if match:
            path = root / match.group(1)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(body)


def _tables_script():  # docs/ is not a package: load the script by path
    spec = importlib.util.spec_from_file_location("readme_tables", ROOT / "docs" / "readme_tables.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["readme_tables"] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def test_every_generated_table_has_a_source() -> None:
    tables = _tables_script()
    assert set(tables.site_blocks()) == set(tables.SOURCES)


def test_the_table_check_compares_figures() -> None:
    tables = _tables_script()
    table = "| a | b |\n|:--|--:|\n| x | 1.2345 |\n| y | −0.5 |\n"
    assert tables.same_figures(table, table.replace("1.2345", "1.2346"))  # beyond 3 figures
    assert not tables.same_figures(table, table.replace("1.2345", "1.25"))
    assert not tables.same_figures(table, table.replace("−0.5", "0.5"))


@pytest.mark.slow
def test_table2_in_the_readme_is_what_a_run_gives() -> None:
    done = subprocess.run(
        [sys.executable, str(ROOT / "docs" / "readme_tables.py"), "table2", "--check"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stdout + done.stderr
