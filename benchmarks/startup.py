"""What a user waits for: ``lwrlab task=identification`` on a 10 s log, end to end, against the import floor.

Writes the simulator's 10 s exciting motion and 20 s validation motion as logs (1 kHz CSV) into a
temporary folder, then times, in alternating rounds (so a change of machine load hits all alike):

- ``python -c "import numpy, pinocchio"``: the floor no Python robotics tool goes below;
- ``lwrlab task=identification plant=log …`` with tracking off;
- the same with tracking on, logging into a new SQLite MLflow store each round (a new project);
- the same with tracking on, logging into one store that earlier runs created (the usual case).

A new store is a copy of MLflow's empty migrated database (:mod:`lwrlab.tracking.store.schema_template`),
built once per MLflow version; it is built before the rounds, so that all rounds time the same thing.
Prints the median wall time of each and its ratio to the floor, and the same for CPU time (user +
system), which other processes on a busy machine disturb less than wall time.

``--chain`` also times the whole chain, ``lwrlab`` with its defaults (what ``make run`` runs), tracking
into the existing store.

    .venv/bin/python benchmarks/startup.py [--rounds 3] [--chain]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]
LWRLAB = [sys.executable, "-m", "lwrlab.cli"]


def _timed(command: list[str], cwd: Path) -> tuple[float, float]:
    """Wall time and CPU time (user + system, the process and its children) of ``command``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run(command, cwd=cwd, check=True, capture_output=True, text=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--chain", action="store_true", help="also time the whole chain (make run's job)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        subprocess.run(
            [
                *LWRLAB,
                "task=write_example_logs",
                "tracking=none",
                f"task.directory={folder}",
                f"hydra.run.dir={folder / 'write'}",
            ],
            cwd=REPOSITORY,
            check=True,
            capture_output=True,
        )
        job = [
            *LWRLAB,
            "task=identification",
            "plant=log",
            f"data.path={folder / 'identification.csv'}",
            f"data.validation_path={folder / 'validation.csv'}",
        ]

        def tracked(store: Path, run_dir: Path) -> list[str]:
            return [
                *job,
                f"hydra.run.dir={run_dir}",
                f"hydra.callbacks.mlflow.tracking_uri=sqlite:///{store / 'mlflow.db'}",
                f"hydra.callbacks.mlflow.artifact_location={store / 'artifacts'}",
            ]

        shared_store = folder / "shared_store"
        subprocess.run(
            tracked(shared_store, folder / "first"), cwd=REPOSITORY, check=True, capture_output=True
        )  # also builds the template
        times: dict[str, list[tuple[float, float]]] = {
            "import numpy, pinocchio (floor)": [],
            "identification, tracking off": [],
            "identification, tracking on, new store": [],
            "identification, tracking on, existing store": [],
        }
        if args.chain:
            times["the whole chain (make run), tracking on, existing store"] = []
        for k in range(args.rounds):
            times["import numpy, pinocchio (floor)"].append(
                _timed([sys.executable, "-c", "import numpy, pinocchio"], folder)
            )
            times["identification, tracking off"].append(
                _timed([*job, "tracking=none", f"hydra.run.dir={folder / f'off{k}'}"], REPOSITORY)
            )
            times["identification, tracking on, new store"].append(
                _timed(tracked(folder / f"store{k}", folder / f"on{k}"), REPOSITORY)
            )
            times["identification, tracking on, existing store"].append(
                _timed(tracked(shared_store, folder / f"shared{k}"), REPOSITORY)
            )
            if args.chain:
                chain = [*LWRLAB, *tracked(shared_store, folder / f"chain{k}")[len(job) :]]
                times["the whole chain (make run), tracking on, existing store"].append(
                    _timed(chain, REPOSITORY)
                )
            print(
                f"round {k + 1}/{args.rounds}: "
                + ", ".join(f"{name} {values[-1][0]:.2f} s" for name, values in times.items()),
                flush=True,
            )
    walls = {name: statistics.median(wall for wall, _ in values) for name, values in times.items()}
    cpus = {name: statistics.median(cpu for _, cpu in values) for name, values in times.items()}
    floor = "import numpy, pinocchio (floor)"
    print("\n## What a user waits for\n")
    print("| what | median wall (s) | × floor | median CPU (s) | × floor |\n|---|---:|---:|---:|---:|")
    for name in times:
        print(
            f"| {name} | {walls[name]:.2f} | {walls[name] / walls[floor]:.1f} | {cpus[name]:.2f} | {cpus[name] / cpus[floor]:.1f} |"
        )


if __name__ == "__main__":
    main()
