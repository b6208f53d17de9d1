"""A tracked identification from a 10 s log and a default exciting motion against a previous release,
measured in the same run.

The previous release (default ``58e8bc8``) is checked out into a temporary git worktree and run
through the same interpreter and packages (``PYTHONPATH`` pointing at it), so that only lwrlab's
code differs. The simulator's 10 s exciting motion and 20 s validation motion are written as logs
(1 kHz CSV); then, in alternating rounds (A then B, B then A, …: a change of machine load hits
both alike), ``lwrlab task=identification plant=log`` and ``lwrlab task=excitation`` (its
defaults), each with SQLite tracking into a store of its own, one process each, timed from
outside (wall, and CPU: user + system of the process and its children, the tracking companion
included). Beside it, in this process and for this code only, the tracking hooks of one
identification (``on_job_start`` + ``on_job_end`` on copies of the job's output folder) and the
MLflow Model logging within them.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 nice -n 10 .venv/bin/python benchmarks/release_speed.py \
        [--baseline 58e8bc8] [--rounds 5] [--jobs identification excitation]

Prints, for each job, the medians and the ratios A/B taken round by round (their median). Goals:
each job within 1.00× the previous release's CPU time, tracking hooks ≤ 0.4 s a job.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

REPOSITORY = Path(__file__).resolve().parents[1]
GOAL_RATIO = 1.00
GOAL_HOOKS_S = 0.4


def _timed(command: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float]:
    """Wall and CPU seconds (user + system of the process and its children) of ``command``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run(command, cwd=cwd, env=env, check=True, capture_output=True, text=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _environment(code: Path) -> dict[str, str]:
    """This environment with ``code`` first on the import path and no store of the user's."""
    env = {key: value for key, value in os.environ.items() if key != "MLFLOW_TRACKING_URI"}
    env["PYTHONPATH"] = str(code)
    return env


def _tracking(folder: Path, name: str) -> list[str]:
    """The overrides that track into the SQLite store of ``name`` (a job kind and a code) in ``folder``."""
    store = folder / f"store_{name}"
    return [
        f"tracking.uri=sqlite:///{store / 'mlflow.db'}",
        f"tracking.artifact_location={store / 'artifacts'}",
    ]


def identification(folder: Path, name: str, round_: int, tracked: bool = True) -> list[str]:
    """The command of one tracked identification of the logs in ``folder``."""
    return [
        sys.executable,
        "-m",
        "lwrlab.cli",
        "task=identification",
        "plant=log",
        f"data.path={folder / 'logs' / 'identification.csv'}",
        f"data.validation_path={folder / 'logs' / 'validation.csv'}",
        f"hydra.run.dir={folder / f'run_{name}_{round_}'}",
        *(_tracking(folder, f"identification_{name}") if tracked else ["tracking=none"]),
    ]


def excitation(folder: Path, name: str, round_: int) -> list[str]:
    """The command of one tracked exciting motion with the defaults."""
    return [
        sys.executable,
        "-m",
        "lwrlab.cli",
        "task=excitation",
        f"hydra.run.dir={folder / f'excitation_{name}_{round_}'}",
        *_tracking(folder, f"excitation_{name}"),
    ]


JOBS: dict[str, tuple[str, Callable[[Path, str, int], list[str]]]] = {
    "identification": ("tracked identification (10 s log)", identification),
    "excitation": ("tracked task=excitation (defaults)", excitation),
}


def hook_seconds(job_dir: Path, root: Path, repeats: int) -> tuple[list[float], list[float]]:
    """Seconds of the tracking hooks of one job (``benchmarks/tracking.py``'s measure) and of the
    MLflow Model logging within them, ``repeats`` times after one that warms the process up."""
    import lwrlab.tracking.lifecycle.job_run as job_run
    from lwrlab.tracking.store.sqlite import prepare_sqlite_store

    sys.path.insert(0, str(REPOSITORY / "benchmarks"))
    from tracking import hook_seconds as tracking_hook_seconds

    uri = f"sqlite:///{root / 'mlflow.db'}"
    prepare_sqlite_store(uri)
    log_model = job_run.log_and_register
    model_times: list[float] = []

    def timed_log_model(*args: Any, **kwargs: Any) -> Any:
        started = time.perf_counter()
        try:
            return log_model(*args, **kwargs)
        finally:
            model_times.append(time.perf_counter() - started)

    job_run.log_and_register = timed_log_model
    try:
        times = tracking_hook_seconds(job_dir, root, uri, repeats + 1)
    finally:
        job_run.log_and_register = log_model
    return times[1:], model_times[1:]


def _ratios(times: dict[str, list[tuple[float, float]]]) -> list[tuple[str, float, float, float]]:
    """(what, median A, median B, median of the round-by-round ratios A/B) for wall and CPU."""
    rows = []
    for what, index in (("wall", 0), ("CPU", 1)):
        a = [t[index] for t in times["A"]]
        b = [t[index] for t in times["B"]]
        ratio = statistics.median(x / y for x, y in zip(a, b, strict=True))
        rows.append((what, statistics.median(a), statistics.median(b), ratio))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="58e8bc8", help="the previous release (a git revision)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--hook-repeats", type=int, default=5)
    parser.add_argument("--jobs", nargs="+", choices=sorted(JOBS), default=list(JOBS))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="lwrlab_release_") as scratch:
        folder = Path(scratch)
        baseline = folder / "baseline"
        subprocess.run(
            ["git", "worktree", "add", "--detach", str(baseline), args.baseline],
            cwd=REPOSITORY,
            check=True,
            capture_output=True,
        )
        try:
            codes = {"A": REPOSITORY, "B": baseline}
            subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "lwrlab.cli",
                    "task=write_example_logs",
                    "tracking=none",
                    f"task.directory={folder / 'logs'}",
                    f"hydra.run.dir={folder / 'write'}",
                ],
                cwd=folder,
                env=_environment(REPOSITORY),
                check=True,
                capture_output=True,
            )
            for job in args.jobs:  # stores and templates built before the rounds
                for name, code in codes.items():
                    _timed(JOBS[job][1](folder, name, -1), _environment(code), folder)
            times = {job: {name: [] for name in codes} for job in args.jobs}
            for round_ in range(args.rounds):
                order = list(codes) if round_ % 2 == 0 else list(reversed(codes))
                for job in args.jobs:
                    for name in order:
                        times[job][name].append(
                            _timed(JOBS[job][1](folder, name, round_), _environment(codes[name]), folder)
                        )
                print(
                    f"round {round_ + 1}/{args.rounds}: "
                    + "; ".join(
                        f"{job} "
                        + ", ".join(f"{name} {values[-1][0]:.2f} s" for name, values in times[job].items())
                        for job in args.jobs
                    ),
                    flush=True,
                )
            hooks: list[float] = []
            models: list[float] = []
            if "identification" in args.jobs:
                hooks, models = hook_seconds(folder / "run_A_0", folder / "hooks", args.hook_repeats)
        finally:
            subprocess.run(
                ["git", "worktree", "remove", "--force", str(baseline)], cwd=REPOSITORY, capture_output=True
            )
    goals = []
    for job in args.jobs:
        rows = _ratios(times[job])
        print(f"\n| {JOBS[job][0]} | this (s) | {args.baseline} (s) | A/B (median of pairs) |")
        print("|---|---:|---:|---:|")
        for what, a_s, b_s, ratio in rows:
            print(f"| {what} | {a_s:.2f} | {b_s:.2f} | {ratio:.3f} |")
        goals.append(f"{job} CPU {rows[1][3]:.3f} (wall {rows[0][3]:.3f})")
    print(f"\ngoals: CPU ratio ≤ {GOAL_RATIO:.2f}: " + "; ".join(goals))
    if hooks:
        hooks_s, model_s = statistics.median(hooks), statistics.median(models)
        print(
            f"tracking hooks per job: median {hooks_s:.3f} s, of which MLflow Model logging {model_s:.3f} s "
            f"(goal ≤ {GOAL_HOOKS_S} s)"
        )


if __name__ == "__main__":
    main()
