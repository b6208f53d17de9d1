"""What a user waits for: ``lwrlab task=identification`` on a 10 s log, end to end, against the import floor.

Writes the simulator's 10 s exciting motion and 20 s validation motion as logs (1 kHz CSV) into a
temporary folder, then times, in alternating rounds (so a change of machine load hits all alike):

- ``python -c "import numpy, pinocchio"``: the floor no Python robotics tool goes below;
- ``lwrlab task=identification plant=log …`` with tracking off;
- the same with tracking on (a fresh SQLite MLflow store per round).

Prints the median wall time of each and its ratio to the floor.

    .venv/bin/python benchmarks/startup.py [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]
LWRLAB = [sys.executable, "-m", "lwrlab.cli"]


def _timed(command: list[str], cwd: Path) -> float:
    started = time.perf_counter()
    subprocess.run(command, cwd=cwd, check=True, capture_output=True, text=True)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        subprocess.run([*LWRLAB, "task=write_example_logs", "tracking=none", f"task.directory={folder}", f"hydra.run.dir={folder / 'write'}"],
                       cwd=REPOSITORY, check=True, capture_output=True)
        job = [*LWRLAB, "task=identification", "plant=log", f"data.path={folder / 'identification.csv'}",
               f"data.validation_path={folder / 'validation.csv'}"]
        times: dict[str, list[float]] = {"import numpy, pinocchio (floor)": [], "identification, tracking off": [], "identification, tracking on": []}
        for k in range(args.rounds):
            times["import numpy, pinocchio (floor)"].append(_timed([sys.executable, "-c", "import numpy, pinocchio"], folder))
            times["identification, tracking off"].append(_timed([*job, "tracking=none", f"hydra.run.dir={folder / f'off{k}'}"], REPOSITORY))
            store = folder / f"store{k}"
            times["identification, tracking on"].append(_timed(
                [*job, f"hydra.run.dir={folder / f'on{k}'}", f"hydra.callbacks.mlflow.tracking_uri=sqlite:///{store / 'mlflow.db'}",
                 f"hydra.callbacks.mlflow.artifact_location={store / 'artifacts'}"], REPOSITORY))
            print(f"round {k + 1}/{args.rounds}: " + ", ".join(f"{name} {values[-1]:.2f} s" for name, values in times.items()), flush=True)
    floor = statistics.median(times["import numpy, pinocchio (floor)"])
    print(f"\n| what | median wall (s) | × floor |\n|---|---:|---:|")
    for name, values in times.items():
        median = statistics.median(values)
        print(f"| {name} | {median:.2f} | {median / floor:.1f} |")


if __name__ == "__main__":
    main()
