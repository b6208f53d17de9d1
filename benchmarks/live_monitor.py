"""The live monitor over ROS 2: two processes over DDS on 127.0.0.1, the simulated robot and the monitor.

1. **Pushes**: the simulated LWR4 (``task=sim_robot``: ``plant=simulated``'s true robot in MuJoCo)
   stands, plays the shipped exciting motion, stands again, and is pushed ``--pushes`` times
   (20–60 N on links 3–7, standing and moving); ``task=live_monitor`` runs with the model
   ``task=identification`` identifies on the defaults. Scored against the pushes: detected, false
   alarms, delay from the force's rise to the alarm; then ``task=monitor`` on the run's bag
   offline: the same alarms?
2. **Endurance**: ``--minutes`` at 1 kHz, 7 joints, the arm holding still: samples dropped,
   latency (a sample's publication to its estimates' publication) median and 99th percentile, the
   monitor's CPU share of one core, the time from the monitor's start to its first estimate (the
   robot publishing before it starts).
3. **Rates**: ``--rate-seconds`` at each of ``--rates`` Hz: where the monitor (or the robot's
   publisher) stops keeping up.

    .venv/bin/python benchmarks/live_monitor.py                     # about 15 minutes on 2 cores
    .venv/bin/python benchmarks/live_monitor.py --minutes 1 --rate-seconds 5   # a quick look
    .venv/bin/python benchmarks/live_monitor.py --nice -10   # ahead of other jobs (root), as robots run

Every process talks on loopback only (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) on a domain of
its own. The runs stay in ``--output`` (default outputs/live_monitor).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

REPOSITORY = Path(__file__).resolve().parents[1]
LWRLAB = [sys.executable, "-m", "lwrlab.cli"]
START_DELAY_S = 3.0
"""task=sim_robot's default standing before its motion (s)."""


def _environment(domain: int) -> dict[str, str]:
    return {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_DOMAIN_ID": str(domain)}


def _run(args: list[str], env: dict[str, str]) -> None:
    done = subprocess.run([*LWRLAB, *args], env=env, capture_output=True, text=True, check=False)
    if done.returncode:
        raise SystemExit(f"{' '.join(args)} failed:\n{done.stdout[-3000:]}{done.stderr[-3000:]}")


NICENESS = [0]
"""The robot's and the monitor's niceness (``--nice``): below 0, ahead of the machine's other jobs,
as a robot's processes run."""


def _start(args: list[str], env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [*LWRLAB, *args],
        env=env,
        stdout=log.open("wb"),
        stderr=subprocess.STDOUT,
        preexec_fn=(lambda: os.nice(NICENESS[0])) if NICENESS[0] else None,
    )


def _wait_for(log: Path, text: str, process: subprocess.Popen[bytes], timeout: float) -> None:
    """Until ``text`` appears in ``log`` (the robot publishing), or fail."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if text in log.read_text(errors="replace"):
            return
        if process.poll() is not None:
            raise SystemExit(f"{log} ended before '{text}':\n{log.read_text()[-3000:]}")
        time.sleep(0.1)
    raise SystemExit(f"no '{text}' in {log} within {timeout:g} s")


def _pair(
    folder: Path,
    model: Path,
    robot_args: list[str],
    domain: int,
    *,
    robot_first: bool,
    monitor_args: tuple[str, ...] = (),
) -> tuple[dict[str, float], dict[str, float]]:
    """Run the robot and the monitor side by side; their metrics."""
    env = _environment(domain)
    shutil.rmtree(folder, ignore_errors=True)  # a run's bag goes into a new folder
    folder.mkdir(parents=True)
    robot_log, monitor_log = folder / "robot.log", folder / "monitor.log"
    robot_dir, monitor_dir = folder / "robot", folder / "monitor"
    monitor_cmd = [
        "task=live_monitor",
        f"task.model={model}",
        "task.idle_stop_s=1.0",
        f"hydra.run.dir={monitor_dir}",
        "tracking=none",
        *monitor_args,
    ]
    robot_cmd = ["task=sim_robot", f"hydra.run.dir={robot_dir}", "tracking=none", *robot_args]
    if robot_first:
        robot = _start([*robot_cmd, "task.wait_for_subscriber_s=0"], env, robot_log)
        _wait_for(robot_log, "publishing", robot, 1800)
        monitor = _start(monitor_cmd, env, monitor_log)
    else:
        monitor = _start(monitor_cmd, env, monitor_log)
        robot = _start(robot_cmd, env, robot_log)
    for process, log in ((robot, robot_log), (monitor, monitor_log)):
        if process.wait(timeout=7200):
            raise SystemExit(f"{log} failed:\n{log.read_text()[-3000:]}")
    read = json.loads
    return read((robot_dir / "metrics.json").read_text()), read((monitor_dir / "metrics.json").read_text())


def pushes(output: Path, model: Path, count: int) -> str:
    """Every push detected? False alarms, delays, and the same alarms offline on the bag."""
    folder = output / "pushes"
    hold_after = max(5.0, 0.6 * count)
    _, metrics = _pair(
        folder,
        model,
        [f"task.random_pushes={count}", "task.stamps=sim", f"task.hold_after_s={hold_after}"],
        31,
        robot_first=False,
    )
    contacts = pd.read_csv(folder / "robot" / "contacts.csv")
    found = pd.read_csv(folder / "monitor" / "detections.csv")
    matched, delays = set(), []
    for _, push in contacts.iterrows():
        hits = found[(found.raised >= push.start) & (found.start <= push.end + 0.1)]
        if len(hits):
            matched.add(hits.index[0])
            delays.append(1e3 * (hits.raised.iloc[0] - push.start))
    offline_dir = folder / "offline"
    _run(
        [
            "task=monitor",
            "plant=log",
            f"task.model={model}",
            f"data.paths=[{folder / 'monitor' / 'live_bag'}]",
            f"hydra.run.dir={offline_dir}",
            "tracking=none",
        ],
        _environment(31),
    )
    offline = pd.read_csv(offline_dir / "detections.csv")
    offline = offline[offline.estimator == "observer"].reset_index(drop=True)
    same = len(offline) == len(found) and np.allclose(
        offline[["start", "raised", "end"]].to_numpy(),
        found[["start", "raised", "end"]].to_numpy(),
        atol=1e-9,
    )
    standing = sum(_standing(folder, push.start, hold_after) for _, push in contacts.iterrows())
    rows = [
        ("pushes (standing / moving)", f"{len(contacts)} ({standing} / {len(contacts) - standing})"),
        ("detected", f"{len(delays)} of {len(contacts)}"),
        ("false alarms", str(len(found) - len(matched))),
        (
            "delay from the force's rise, median / largest",
            f"{np.median(delays):.1f} / {np.max(delays):.1f} ms",
        ),
        ("samples dropped", f"{metrics['dropped_samples']:.0f}"),
        ("alarms offline on the run's bag", "identical" if same else f"{len(offline)} (differ)"),
    ]
    return "## Live monitor: pushes\n\n" + _table(rows)


def _standing(folder: Path, start: float, hold_after_s: float) -> bool:
    """Whether the robot stood still when a push began: before its motion or after it."""
    truth = pd.read_parquet(folder / "robot" / "truth.parquet", columns=["t"])
    motion_start = truth.t.iloc[0] + START_DELAY_S
    return bool(start < motion_start or start > truth.t.iloc[-1] - hold_after_s)


def endurance(output: Path, model: Path, minutes: float) -> str:
    """Samples dropped, latency, CPU share and start to first estimate at 1 kHz for ``minutes``."""
    robot, monitor = _pair(
        output / "endurance",
        model,
        ["task.motion=hold", f"task.duration_s={60.0 * minutes}"],
        32,
        robot_first=True,
        monitor_args=("task.record=true",),
    )
    rows = [
        ("run", f"{minutes:g} min at 1 kHz, 7 joints"),
        ("samples (dropped)", f"{monitor['samples']:.0f} ({monitor['dropped_samples']:.0f})"),
        (
            "latency median / 99th percentile / largest",
            f"{monitor['latency_median_ms']:.2f} / {monitor['latency_p99_ms']:.2f} / "
            f"{monitor['latency_max_ms']:.1f} ms",
        ),
        ("monitor's CPU, share of one core", f"{100 * monitor['cpu_share']:.0f} %"),
        ("sample path, per sample", f"{monitor['observer_us_per_sample']:.0f} µs"),
        ("start to first estimate", f"{monitor['start_to_first_estimate_s']:.2f} s"),
        ("robot's publications late by more than a period", f"{robot['late_publications']:.0f}"),
    ]
    return "## Live monitor: endurance\n\n" + _table(rows)


def rates(output: Path, model: Path, rates_hz: list[float], seconds: float) -> str:
    """Where the monitor stops keeping up."""
    rows = []
    for k, rate in enumerate(rates_hz):
        robot, monitor = _pair(
            output / f"rate_{rate:g}",
            model,
            [
                "task.motion=hold",
                f"task.duration_s={seconds}",
                f"task.rate_hz={rate}",
                "task.topics.truth_torque=",
                "task.topics.truth_contact=",
            ],
            33 + k,
            robot_first=False,
            monitor_args=("task.record=false",),
        )
        rows.append(
            (
                f"{rate:g} Hz",
                f"{robot['samples_published']:.0f}",
                f"{robot['late_publications']:.0f}",
                f"{monitor['samples']:.0f}",
                f"{monitor['dropped_samples']:.0f}",
                f"{monitor['latency_median_ms']:.2f}",
                f"{monitor['latency_p99_ms']:.2f}",
                f"{100 * monitor['cpu_share']:.0f} %",
            )
        )
    head = ("rate", "published", "late", "monitored", "dropped", "latency median ms", "latency p99 ms", "CPU")
    return "## Live monitor: rates\n\n" + _table(rows, head)


def _table(rows: list[tuple[str, ...]], head: tuple[str, ...] = ("", "")) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join(["---"] * len(head)) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=10.0, help="the endurance run at 1 kHz (min)")
    parser.add_argument("--rates", type=float, nargs="*", default=[1000.0, 2000.0, 4000.0, 8000.0])
    parser.add_argument("--rate-seconds", type=float, default=20.0, help="each rate's run (s)")
    parser.add_argument("--pushes", type=int, default=12)
    parser.add_argument("--output", type=Path, default=REPOSITORY / "outputs" / "live_monitor")
    parser.add_argument(
        "--only", choices=["pushes", "endurance", "rates"], nargs="*", help="some parts (default: all)"
    )
    parser.add_argument(
        "--nice", type=int, default=0, help="niceness of the robot and the monitor (below 0 needs root)"
    )
    args = parser.parse_args(argv)
    NICENESS[0] = args.nice
    model = args.output / "identified"
    if not (model / "identified_model.yaml").is_file():
        _run(["task=identification", f"hydra.run.dir={model}", "tracking=none"], _environment(30))
    parts = args.only or ["pushes", "endurance", "rates"]
    if "pushes" in parts:
        print(pushes(args.output, model, args.pushes), flush=True)
    if "endurance" in parts:
        print(endurance(args.output, model, args.minutes), flush=True)
    if "rates" in parts:
        print(rates(args.output, model, args.rates, args.rate_seconds), flush=True)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(
        f"machine: {os.cpu_count()} cores, load {load} (1, 5, 15 min) at the end; robot and monitor at "
        f"niceness {args.nice}; runs in {args.output}"
    )


if __name__ == "__main__":
    main()
