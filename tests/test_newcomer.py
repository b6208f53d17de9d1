"""A newcomer's first hour: the README's and the manual's own commands, in the order a newcomer runs them.

One shared store (a temporary folder is the working directory, its ``outputs/`` the runs and the
MLflow store), every task and subcommand driven with the inputs the pages give: the README, getting
started, the own-robot tutorial (example-robot-data's UR5 as "my arm", no SRDF), the logs tutorial,
the sweep tutorial, and, for the tasks those pages only name, the how-to pages' commands (a log with
columns of its own read through a prefix column map, known logs that a motion is designed around). Each
command runs as a reader types it (``.venv/bin/…`` is the running environment's, ``make run
ARGS="…"`` its ``lwrlab …``, nothing on ``PATH`` but the system's); where a page's command would run
long, overrides shrink its durations or its sweep (``shrink``), never its inputs. The sweep
tutorial's second, nine-job sweep (``noise_sweep``) is left out: the parallel launcher and ``lwrlab
report`` it leads to are driven by the other steps. Placeholders are filled as a reader fills them: a
run folder ``outputs/runs/<date>/<time>/<file>`` is the newest one holding that file (or the run of
the step named in ``uses``), a sweep's parent run id is read from what the sweep printed, the printed
MLflow UI command is run as printed (with ``--help``: it would serve until stopped).

The test fails on any traceback in any output, on a command that fails where the page says it
works, and on a failure that is not one ``lwrlab:`` line naming its cause and fix. It prints the
time of every command (the table of ``newcomer_timings.md``).
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_own_robot_motion import example_robots

pytestmark = pytest.mark.slow

BIN = Path(sys.executable).parent
REAL_LWR4 = Path(__file__).resolve().parents[2] / "shared" / "data" / "kuka_lwr4_hw"
TRACEBACK = "Traceback (most recent call last)"


@dataclass(frozen=True)
class Step:
    """One command of a page, as written there."""

    page: str
    command: str
    shrink: tuple[str, ...] = ()
    """Overrides appended to keep the command short (durations, sweep sizes)."""
    fails_with: str | None = None
    """The page shows this command failing: exit 1, one ``lwrlab:`` line containing this text."""
    needs_real_logs: bool = False
    uses: str | None = None
    """``outputs/runs/<date>/<time>/…`` is the run of the earlier step with this command (None: the
    newest run holding the file)."""
    prepare: Callable[[Path], None] | None = None
    """Writes what the reader brings (their robot's logs) into the folder before the command."""


GAINS = np.array([2.0, 2.5, 1.5, 1.2, 0.8, 0.6, 0.5])
"""N·m/A: the drive gains of the reader's robot, whose logs hold motor currents."""


def _current_logs(root: Path) -> None:
    """The reader's current logs (``current1…N``, A): the simulated unloaded and loaded logs' torques
    through the drive gains."""
    for source, target in (("example_logs", "u.csv"), ("loaded_logs", "l.csv")):
        log = pd.read_csv(root / "outputs" / source / "identification.csv")
        for j, gain in enumerate(GAINS, start=1):
            log[f"current{j}"] = log.pop(f"tau{j}") / gain
        log.to_csv(root / target, index=False)


def _prefixed_log(root: Path) -> None:
    """The reader's log with columns of their own: ``time, pos_1…, eff_1…`` (the simulated log's)."""
    log = pd.read_csv(root / "outputs" / "example_logs" / "identification.csv")
    joints = range(1, len(GAINS) + 1)
    names = {"t": "time"} | {f"q{j}": f"pos_{j}" for j in joints} | {f"tau{j}": f"eff_{j}" for j in joints}
    log.rename(columns=names).to_csv(root / "outputs" / "my_log.csv", index=False)


SHORT_MOTIONS = ("validation.duration=4",)
"""The 20 s cross-validation motion cut to 4 s (the shipped exciting motion stays as it is)."""

STEPS = (
    # README: the two commands, overrides, a sweep, a table, the comparison
    Step("README.md", "make run"),
    Step("README.md", 'make run ARGS="task=identification robot=panda"', SHORT_MOTIONS),
    Step(
        "README.md",
        'make run ARGS="-m task=identification seed=0,1,2 plant.torque_noise_std=0.05,0.1"',
        SHORT_MOTIONS,
    ),
    Step("README.md", 'make run ARGS="experiment=paper_table2"', SHORT_MOTIONS),
    Step("README.md", ".venv/bin/lwrlab compare --experiment identification"),
    # getting started
    Step("getting-started.md", ".venv/bin/lwrlab --version"),
    Step("getting-started.md", 'make run ARGS="experiment=noiseless"', SHORT_MOTIONS),
    Step(
        "getting-started.md",
        'make run ARGS="task=identification robot=urdf robot.path=/path/to/arm.urdf '
        'robot.acceleration_limits=10"',
        SHORT_MOTIONS,
    ),
    Step(
        "getting-started.md",
        'make run ARGS="robot=identified robot.source=outputs/runs/<date>/<time>/identified_model.yaml"',
        SHORT_MOTIONS,
        uses="make run",  # the main job's own model
    ),
    Step(
        "getting-started.md",
        'make run ARGS="task=identification statistics=block_bootstrap"',
        (*SHORT_MOTIONS, "statistics.resamples=20"),
    ),
    Step(
        "getting-started.md",
        'make run ARGS="task=excitation criterion=cond"',
        ("trajectory.duration=3", "optimizer.max_iterations=40"),
    ),
    Step(
        "getting-started.md",
        'make run ARGS="experiment=paper_fig5_duration"',
        ("task.durations=[2,3]", "optimizer.max_iterations=30", *SHORT_MOTIONS),
    ),
    Step(
        "getting-started.md",
        'make run ARGS="experiment=paper_fig6_criteria"',
        ("task.seeds=[0]", "trajectory.duration=3", "optimizer.max_iterations=30", *SHORT_MOTIONS),
    ),
    Step(
        "getting-started.md",
        'make run ARGS="experiment=estimator_benchmark"',
        (
            'hydra.sweeper.params={estimator: "ols,sdp", task.noise: standard, seed: "0"}',
            "trajectory.duration=3",
            *SHORT_MOTIONS,
        ),
    ),
    # your own robot: a UR5 without an SRDF
    Step(
        "tutorials/own-robot.md",
        ".venv/bin/lwrlab task=excitation robot=urdf robot.path=my_arm.urdf",
        fails_with="robot.acceleration_limits",
    ),
    Step(
        "tutorials/own-robot.md",
        ".venv/bin/lwrlab task=excitation robot=urdf robot.path=my_arm.urdf robot.acceleration_limits=10 "
        "'trajectory.constraints.world.obstacles=[{name: pillar, shape: cylinder, radius: 0.1, "
        "length: 1.5, xyz: [0.5, 0.4, 0.75]}]'",
    ),
    Step(
        "tutorials/own-robot.md",
        ".venv/bin/lwrlab task=write_example_logs robot=urdf robot.path=my_arm.urdf "
        "robot.acceleration_limits=10 trajectory.from_file=outputs/runs/<date>/<time>/exciting_motion.yaml "
        "task.file_format=bag",
        SHORT_MOTIONS,
    ),
    Step(
        "tutorials/own-robot.md",
        ".venv/bin/lwrlab task=identification robot=urdf robot.path=my_arm.urdf plant=log "
        '"data.paths=[outputs/example_logs/identification_bag]" '
        '"data.validation_paths=[outputs/example_logs/validation_bag]"',
    ),
    # identification from logs
    Step(
        "tutorials/logs.md",
        ".venv/bin/lwrlab task=identification robot=urdf robot.path=$D/kuka_lwr4.urdf plant=log "
        '"data.paths=[$D/measurements_2.npz,$D/measurements_3.npz]" '
        '"data.validation_paths=[$D/measurements_1.npz]" '
        "'data.column_map={t: times, q: positions, dq: velocities, tau: torques}'",
        needs_real_logs=True,
    ),
    Step("tutorials/logs.md", 'make run ARGS="task=write_example_logs"', SHORT_MOTIONS),
    Step(
        "tutorials/logs.md",
        ".venv/bin/lwrlab task=identification plant=log "
        '"data.paths=[outputs/example_logs/identification.csv]" '
        '"data.validation_paths=[outputs/example_logs/validation.csv]"',
    ),
    Step(
        "reference/log-formats.md",
        '.venv/bin/lwrlab task=identification plant=log "data.paths=[outputs/my_log.csv]" '
        "'data.column_map={t: time, q: pos_, tau: eff_}'",
        prepare=_prefixed_log,
    ),
    Step(
        "tutorials/next-motion.md",
        ".venv/bin/lwrlab task=excitation task.known_logs=[outputs/example_logs/identification.csv]",
        ("trajectory.duration=3", "optimizer.max_iterations=40"),
    ),
    # a sweep compared in MLflow
    Step(
        "tutorials/sweep-mlflow.md",
        ".venv/bin/lwrlab -m hydra/launcher=parallel task=identification estimator=ols,wls,sdp seed=0,1",
        SHORT_MOTIONS,
    ),
    Step("tutorials/sweep-mlflow.md", ".venv/bin/lwrlab compare --experiment identification"),
    Step(
        "tutorials/sweep-mlflow.md",
        ".venv/bin/lwrlab compare --experiment identification --param estimator=sdp --by seed",
    ),
    Step(
        "tutorials/sweep-mlflow.md", ".venv/bin/lwrlab compare --parent <parent run id printed by the sweep>"
    ),
    Step("tutorials/sweep-mlflow.md", "<the MLflow UI command compare printed> --help"),
    Step(
        "tutorials/sweep-mlflow.md",
        'make run ARGS="-m experiment=tune_processing"',
        ("hydra.sweeper.n_trials=2", "task=identification", *SHORT_MOTIONS),
    ),
    Step("tutorials/sweep-mlflow.md", ".venv/bin/lwrlab report --experiment paper_fig6_criteria"),
    Step("paper.md", ".venv/bin/lwrlab report --experiment paper_table2"),
    Step("tutorials/sweep-mlflow.md", ".venv/bin/lwrlab sync"),
    Step(
        "tutorials/sweep-mlflow.md",
        ".venv/bin/lwrlab --config-path /abs/path/<run>/.hydra --config-name config",
    ),
    # the tasks the tutorials only name, with their how-to pages' commands
    Step(
        "how-to/model-registry.md",
        ".venv/bin/lwrlab task=identification tracking.register_model=robot",
        SHORT_MOTIONS,
    ),
    Step("how-to/model-registry.md", ".venv/bin/lwrlab model list kuka_lwr4"),
    Step("how-to/model-registry.md", ".venv/bin/lwrlab model alias kuka_lwr4 1 champion"),
    Step(
        "how-to/model-registry.md",
        ".venv/bin/lwrlab task=monitor plant=log task.model=models:/kuka_lwr4@champion "
        "'data.paths=[outputs/example_logs/validation.csv]'",
    ),
    Step(
        "how-to/tool-recognition.md",
        'make run ARGS="task=write_example_logs tool=large_roller task.directory=outputs/loaded_logs"',
        SHORT_MOTIONS,
    ),
    Step(
        "how-to/payload.md",
        "lwrlab task=payload plant=log task.unloaded_model=outputs/runs/<date>/<time>/identified_model.yaml "
        "'task.loaded_paths=[outputs/loaded_logs/identification.csv]'",
        uses=".venv/bin/lwrlab task=identification plant=log "
        '"data.paths=[outputs/example_logs/identification.csv]" '
        '"data.validation_paths=[outputs/example_logs/validation.csv]"',
    ),
    Step(
        "how-to/payload.md",
        "lwrlab task=drive_gains plant=log 'task.unloaded_paths=[u.csv]' 'task.loaded_paths=[l.csv]' "
        "task.payload.mass=2.0 'task.payload.com=[0.05,0,0.1]'",
        ("task.payload.mass=null", "task.payload.com=null", "task.payload.tool=large_roller"),
        prepare=_current_logs,
    ),
    Step(
        "how-to/tool-recognition.md",
        'make run ARGS="experiment=paper_table3_tools"',
        ("trajectory.duration=4", "task.tool_motion.duration=4", "task.tool_motion_candidates=2"),
    ),
    Step(
        "how-to/tool-recognition.md",
        'make run ARGS="experiment=tool_recognition_benchmark"',
        (
            "task.n_seeds=1",
            "trajectory.duration=4",
            "task.tool_motion.duration=4",
            "task.tool_motion_candidates=2",
        ),
    ),
    Step(
        "paper.md",
        'make run ARGS="experiment=paper_table4_force"',
        ("task.tools=[large_roller]", "task.feedbacks=[estimate]"),
    ),
)


def _newest(root: Path, name: str) -> Path:
    """The newest run folder under ``outputs/runs`` holding ``name``: the run a reader just made."""
    found = sorted((root / "outputs" / "runs").glob(f"*/*/{name}"), key=lambda p: p.stat().st_mtime)
    assert found, f"no run folder holds {name} yet"
    return found[-1].parent


class Newcomer:
    """Runs the steps in one folder, filling the placeholders as a reader would."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.printed = ""  # everything the commands printed so far
        self.runs: dict[str, Path] = {}  # the run folder each command made
        robots = example_robots()
        self.words = {
            "my_arm.urdf": str(robots / "ur_description" / "urdf" / "ur5_robot.urdf"),
            "/path/to/arm.urdf": str(robots / "ur_description" / "urdf" / "ur5_robot.urdf"),
            "$D": str(REAL_LWR4),
        }

    def command_line(self, step: Step) -> str:
        line = step.command
        words = re.match(r'^make run(?: ARGS="(.*)")?$', line)
        if words is not None:  # what `make run` runs once .venv exists
            line = f".venv/bin/lwrlab {words.group(1) or ''}".strip()
        elif line.startswith("lwrlab "):
            line = ".venv/bin/" + line
        for word, value in self.words.items():
            line = line.replace(word, value)
        for name in re.findall(r"outputs/runs/<date>/<time>/(\S+?)[\"' ]", line + " "):
            folder = self.runs[step.uses] if step.uses is not None else _newest(self.root, name)
            line = line.replace(f"outputs/runs/<date>/<time>/{name}", str(folder / name))
        if "<parent run id printed by the sweep>" in line:
            parents = re.findall(r"lwrlab compare --parent (\w+)", self.printed)
            assert parents, "no sweep printed its parent run id"
            line = line.replace("<parent run id printed by the sweep>", parents[-1])
        if "<the MLflow UI command compare printed>" in line:
            commands = re.findall(r"MLflow UI: (.+?), then open ", self.printed)
            assert commands, "lwrlab compare printed no MLflow UI command"
            line = line.replace("<the MLflow UI command compare printed>", commands[-1])
        if "/abs/path/<run>/.hydra" in line:
            line = line.replace("/abs/path/<run>/.hydra", str(_newest(self.root, ".hydra/config.yaml")))
        line = re.sub(r"(?<![\w/])\.venv/bin/", f"{BIN}/", line)
        return " ".join([line, *map(shlex.quote, step.shrink)])

    def run(self, step: Step) -> tuple[str, float, list[str]]:
        """Run one step; return the command run, its seconds and what is wrong with it."""
        if step.prepare is not None:
            step.prepare(self.root)
        line = self.command_line(step)
        before = set((self.root / "outputs" / "runs").glob("*/*"))
        environment = {k: v for k, v in os.environ.items() if not k.startswith("MLFLOW_")}
        environment |= {"HOME": str(self.root / "home"), "PATH": "/usr/bin:/bin"}  # the README's set-up
        started = time.perf_counter()
        done = subprocess.run(
            ["bash", "-c", line], cwd=self.root, env=environment, capture_output=True, text=True, timeout=900
        )
        seconds = time.perf_counter() - started
        made = sorted(set((self.root / "outputs" / "runs").glob("*/*")) - before)
        if made:
            self.runs[step.command] = made[-1]
        output = done.stdout + done.stderr
        self.printed += output
        problems = []
        if TRACEBACK in output:
            problems.append("a traceback reached the user")
        user_lines = [text for text in done.stderr.splitlines() if text.startswith("lwrlab: ")]
        if step.fails_with is None and done.returncode != 0:
            problems.append(f"exit {done.returncode} where the page shows it working")
        if step.fails_with is not None and not (
            done.returncode == 1 and len(user_lines) == 1 and step.fails_with in user_lines[0]
        ):
            problems.append(f"exit {done.returncode}, not one `lwrlab:` line naming {step.fails_with!r}")
        if done.returncode != 0 and (len(user_lines) != 1 or "HYDRA_FULL_ERROR" in done.stderr):
            problems.append("a failure that is not one `lwrlab:` line")
        if problems:
            problems.append(f"output:\n{output[-3000:]}")
        return line, seconds, problems


def test_a_newcomer_runs_the_pages_in_order_without_a_traceback(tmp_path: Path) -> None:
    (tmp_path / "home").mkdir()
    newcomer = Newcomer(tmp_path)
    rows, failures = [], []
    for step in STEPS:
        if step.needs_real_logs and not (REAL_LWR4 / "measurements_1.npz").is_file():
            rows.append(f"| {step.page} | `{step.command}` | skipped: no {REAL_LWR4} |")
            continue
        line, seconds, problems = newcomer.run(step)
        rows.append(f"| {step.page} | `{step.command}` | {seconds:.1f} s |")
        if problems:
            failures.append(f"{step.page}: {line}\n  " + "\n  ".join(problems))
    table = "\n".join(["| page | command | wall time |", "|---|---|---|", *rows])
    (tmp_path / "newcomer_timings.md").write_text(table + "\n")
    print(table)
    assert not failures, "\n\n".join(failures)
