"""Time and peak memory of ``task=identification plant=log`` against the length of the log.

A 7-joint (LWR4), 1 kHz log of the simulator's multisine motion is written for every length
(``task=write_example_logs trajectory=multisine trajectory.duration=…``, Parquet, kept in
``--logs``), then identified with the defaults for logs (estimator ``sdp``, ``weight: auto``) against
the same 20 s validation log. Each identification runs in its own process, started by a wrapper
process that reads ``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss`` once it has ended: the peak
resident memory of numpy, pinocchio and the solvers (tracemalloc sees only Python's allocations).

    .venv/bin/python benchmarks/long_logs.py                      # 10 s … 1 h
    .venv/bin/python benchmarks/long_logs.py --lengths 10 300
    .venv/bin/python benchmarks/long_logs.py --code /tmp/old      # a copy of lwrlab/, plugins/, conf/
                                                                  # from before: the same logs, old code
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

LENGTHS_S = (10, 60, 300, 1200, 3600)

_MEASURED = """
import json, resource, subprocess, sys, time
start = time.perf_counter()
result = subprocess.run(sys.argv[1:], capture_output=True, text=True)
wall = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
print(json.dumps({"rc": result.returncode, "wall_s": wall, "peak_mb": peak, "tail": result.stderr[-1500:]}))
"""


def _lwrlab(*overrides: str) -> list[str]:
    return [sys.executable, "-m", "lwrlab.cli", "tracking=none", *overrides]


def write_log(length_s: int, logs: Path) -> Path:
    """The simulator's identification log of ``length_s`` seconds (written once), and its validation log."""
    folder = logs / f"{length_s}s"
    if not (folder / "identification.parquet").exists():
        subprocess.run(
            _lwrlab(
                "task=write_example_logs",
                "trajectory=multisine",
                f"trajectory.duration={length_s}",
                "task.file_format=parquet",
                f"task.directory={folder}",
                "plant.show_progress=false",
                f"hydra.run.dir={logs}/runs/write_{length_s}",
            ),
            check=True,
            capture_output=True,
        )
    return folder


def identify(folder: Path, validation: Path, run_dir: Path, code: Path | None) -> dict:
    """Wall time (s) and peak RSS (MB) of one identification, in a fresh process."""
    env = dict(os.environ)
    if code is not None:  # the copy's packages come before the installed ones
        env["PYTHONPATH"] = os.pathsep.join([str(code), env.get("PYTHONPATH", "")])
    # started in the copy: ``python -m`` puts the working directory first on the path, before PYTHONPATH
    cwd = None if code is None else code
    command = _lwrlab(
        "task=identification",
        "plant=log",
        f"data.path={folder / 'identification.parquet'}",
        f"data.validation_path={validation}",
        f"hydra.run.dir={run_dir}",
    )
    result = subprocess.run(
        [sys.executable, "-c", _MEASURED, *command],
        capture_output=True,
        text=True,
        env=env,
        check=True,
        cwd=cwd,
    )
    return json.loads(result.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--lengths", type=int, nargs="+", default=list(LENGTHS_S), help="log lengths (s)")
    parser.add_argument("--logs", type=Path, default=Path("outputs/long_logs"), help="where the logs go")
    parser.add_argument("--code", type=Path, default=None, help="run this copy of the code instead")
    args = parser.parse_args()
    args.logs = args.logs.resolve()  # the runs of --code start in the copy
    code = None if args.code is None else args.code.resolve()
    validation = write_log(10, args.logs) / "validation.parquet"
    label = "installed" if args.code is None else str(args.code)
    print(f"| log length | samples | wall (s) | peak RSS (MB) | code: {label}")
    print("|---:|---:|---:|---:|")
    for length in args.lengths:
        folder = write_log(length, args.logs)
        run_dir = args.logs / "runs" / f"identify_{length}_{int(time.time())}"
        figures = identify(folder, validation, run_dir, code)
        if figures["rc"] != 0:
            print(f"| {length} s | failed: {figures['tail'].strip().splitlines()[-1:]} |")
            continue
        print(f"| {length} s | {length * 1000 + 1} | {figures['wall_s']:.1f} | {figures['peak_mb']:.0f} |")


if __name__ == "__main__":
    main()
