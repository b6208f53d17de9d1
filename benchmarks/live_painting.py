"""Painting through ROS 2: the controller and the simulated robot, two processes over DDS on 127.0.0.1.

1. **Path**: the optimised painting path of the large roller painted in one process
   (``task=painting``: the identified model, its force estimate fed back) and live
   (``task=sim_painting_robot`` beside ``task=live_painting``) on the same path, wall and
   controller: the contact force's RMS error (estimate against the wall's sensor), the coverage,
   missed control periods, the command latency (state received to command published), the
   controller's own time per state, and the highest rate that time leaves room for. Live twice: the
   robot on the wall clock (as a robot runs) and in lockstep with the controller.
2. **Drills**, each on the path's first stroke, the robot on the wall clock: the joint-state stream
   stalls 50 ms; the torque readings jump (the force estimate passes its limit); the wall moves 2 cm
   away mid-stroke. Each must end in a safe stop with its reason.

    .venv/bin/python benchmarks/live_painting.py                  # about 5 minutes on 2 cores
    .venv/bin/python benchmarks/live_painting.py --only drills    # the drills alone
    .venv/bin/python benchmarks/live_painting.py --nice -10       # ahead of other jobs (root), as robots run

Every process talks on loopback only (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) on a domain of
its own. The runs stay in ``--output`` (default outputs/live_painting).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]
LWRLAB = [sys.executable, "-m", "lwrlab.cli"]
ROLLER = "large_roller"
KEY = f"{ROLLER}_identified_estimate"
COMMON = [f"task.tools=[{ROLLER}]", "controller=force_pi", "tracking=none"]
"""Both processes and the in-process run: one roller, the force PI on its estimate, no MLflow."""
DRILLS = {
    "the joint states stall 50 ms": "task.robot.stalls=[{after_s: 3.5, duration_s: 0.05}]",
    "the torque readings jump": "task.robot.torque_jumps=[{after_s: 3.5, duration_s: 0.2, offset: [0, 40, 0, 20, 0, 0, 0]}]",
    "the wall moves 2 cm away": "task.robot.wall_moves=[{after_s: 3.5, distance: -0.02}]",
}
"""Each drill 3.5 s after the robot's first command: the move to the start and the 2 s approach are
over, the roller is on the path's first stroke."""
DRILL_PATH_S = 6.0
"""s of the path (the approach included) a drill run plays."""
NICENESS = [0]
"""The robot's and the controller's niceness (``--nice``)."""


def _environment(domain: int) -> dict[str, str]:
    return {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_DOMAIN_ID": str(domain)}


def _command(args: list[str]) -> list[str]:
    return ["nice", "-n", str(NICENESS[0]), *LWRLAB, *args] if NICENESS[0] else [*LWRLAB, *args]


def _in_process(folder: Path) -> dict[str, float]:
    """``task=painting`` on the live run's path and contact settings (the roller starts on the wall)."""
    args = [
        "task=painting",
        *COMMON,
        "task.models=[identified]",
        "task.feedbacks=[estimate]",
        "task.comparison_controller=null",
        "task.contact.standoff=0.0",
        f"hydra.run.dir={folder}",
    ]
    done = subprocess.run(_command(args), capture_output=True, text=True, check=False)
    if done.returncode:
        raise SystemExit(f"task=painting failed:\n{done.stderr[-3000:]}")
    return json.loads((folder / "metrics.json").read_text())


def _live(folder: Path, domain: int, *overrides: str) -> tuple[dict[str, float], dict[str, float], str]:
    """The robot and the controller on ``domain``: their metrics and the controller's stop reason."""
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    env = _environment(domain)
    settings = [*COMMON, "task.robot.idle_stop_s=1.0", *overrides]
    with (folder / "robot.log").open("wb") as log:
        robot = subprocess.Popen(
            _command(["task=sim_painting_robot", *settings, f"hydra.run.dir={folder / 'robot'}"]),
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
        controller = subprocess.run(
            _command(["task=live_painting", *settings, f"hydra.run.dir={folder / 'controller'}"]),
            env=env,
            capture_output=True,
            text=True,
            check=False,
        )
        try:
            robot.wait(timeout=60)
        finally:
            robot.kill()
    if controller.returncode:
        raise SystemExit(f"task=live_painting failed:\n{controller.stderr[-3000:]}")
    read = json.loads
    reason = (folder / "controller" / "stop_reason.txt").read_text().strip()
    return (
        read((folder / "robot" / "metrics.json").read_text()),
        read((folder / "controller" / "metrics.json").read_text()),
        reason,
    )


def _table(rows: list[tuple[str, ...]], head: tuple[str, ...]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join(["---"] * len(head)) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def path(output: Path) -> str:
    """The whole path in process and live (real time, lockstep)."""
    rms, coverage = f"rms_{KEY}_estimated_vs_measured", f"coverage_{KEY}"
    in_process = _in_process(output / "in_process")
    rows = [
        (
            "in process",
            f"{in_process[rms]:.3f}",
            "1.00",
            f"{100 * in_process[coverage]:.1f} %",
            "",
            "",
            "",
            "",
            "",
            "",
        )
    ]
    for k, (name, overrides) in enumerate(
        (("live, real time", ()), ("live, lockstep", ("task.robot.lockstep_s=0.5",)))
    ):
        robot, live, reason = _live(output / name.replace(", ", "_").replace(" ", "_"), 60 + k, *overrides)
        scored = rms in live
        rows.append(
            (
                name,
                f"{live[rms]:.3f}" if scored else "–",
                f"{live[rms] / in_process[rms]:.2f}" if scored else "–",
                f"{100 * live[coverage]:.1f} %" if scored else "–",
                reason.split(":")[0],
                f"{live['missed_periods']:.0f} / {robot['late_periods']:.0f}",
                f"{live['latency_median_ms']:.2f}",
                f"{live['latency_p99_ms']:.2f}",
                f"{live['compute_median_ms']:.2f} / {live['compute_p99_ms']:.2f}",
                f"{1e3 / live['compute_p99_ms']:.0f}",
            )
        )
    head = (
        "run",
        "force RMS error N",
        "× in process",
        "coverage",
        "stopped",
        "missed periods / robot late",
        "latency median ms",
        "latency p99 ms",
        "controller per state median / p99 ms",
        "rate its p99 fits Hz",
    )
    return f"## Live painting: path\n\n{_table(rows, head)}"


def drills(output: Path) -> str:
    """Each drill on the first stroke: the stop and its reason."""
    rows = []
    for k, (name, drill) in enumerate(DRILLS.items()):
        robot, live, reason = _live(
            output / f"drill_{k}", 70 + k, drill, f"task.contact.max_duration={DRILL_PATH_S}"
        )
        rows.append(
            (
                name,
                "yes" if live["stopped_on_fault"] == 1.0 else "no",
                reason,
                f"{100 * live['path_progress']:.0f} %",
                f"{robot['samples_withheld']:.0f}",
            )
        )
    head = ("drill", "stopped on it", "reason", "path commanded", "states withheld")
    return f"## Live painting: drills\n\n{_table(rows, head)}"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", type=Path, default=REPOSITORY / "outputs" / "live_painting")
    parser.add_argument("--only", choices=["path", "drills"], nargs="*", help="some parts (default: all)")
    parser.add_argument(
        "--nice", type=int, default=0, help="niceness of the robot and the controller (below 0 needs root)"
    )
    args = parser.parse_args(argv)
    NICENESS[0] = args.nice
    parts = {"path": path, "drills": drills}
    for name in args.only or list(parts):
        print(parts[name](args.output), flush=True)


if __name__ == "__main__":
    main()
