"""Per-job MLflow tracking overhead, measured two ways in one run, against tracking off.

1. Hooks: one real ``lwrlab task=identification`` job (shortened motions) runs untracked; then the
   tracking callback's ``on_job_start`` + ``on_job_end`` are timed on copies of its output folder,
   ``--repeats`` times, into a real SQLite store: params, tags, metrics in batches, the folder as
   artifacts (secrets scan included) and the run status. This is what tracking adds to a job, with
   little noise from the job itself.
2. End to end: the same ``--jobs``-job sweep with ``tracking=none`` and with SQLite tracking, each
   in one process (imports and process start cost the same); (tracked − untracked) / jobs.

The store is created beforehand; its one-time schema creation is reported separately. Goal: ≤ 0.5 s
per job.

    .venv/bin/python benchmarks/tracking.py [--jobs 4] [--repeats 10]
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
SHORT_JOB = [
    "task=identification",
    "trajectory=multisine",
    "trajectory.duration=2",
    "validation.duration=2",
    "plant.show_progress=false",
]
GOAL_S = 0.5


def sweep_seconds(jobs: int, folder: Path, tracking: list[str]) -> float:
    """Wall time of a ``lwrlab -m seed=0..jobs-1`` sweep with the given tracking overrides."""
    command = [
        sys.executable,
        "-m",
        "lwrlab.cli",
        "-m",
        f"seed={','.join(map(str, range(jobs)))}",
        f"hydra.sweep.dir={folder / 'sweep'}",
        *SHORT_JOB,
        *tracking,
    ]
    start = time.perf_counter()
    completed = subprocess.run(command, cwd=REPO_ROOT, capture_output=True, text=True)
    elapsed = time.perf_counter() - start
    if completed.returncode != 0:
        raise SystemExit(f"sweep failed:\n{completed.stderr[-3000:]}")
    return elapsed


def hook_seconds(job_dir: Path, root: Path, uri: str, repeats: int) -> list[float]:
    """Seconds of on_job_start + on_job_end per job, on copies of a real job folder."""
    import json

    from hydra.core.utils import JobReturn, JobStatus
    from omegaconf import OmegaConf

    from lwrlab.tracking import MlflowTracking

    job_config = OmegaConf.load(job_dir / ".hydra" / "config.yaml")
    metrics = json.loads((job_dir / "metrics.json").read_text())
    callback = MlflowTracking(
        tracking_uri=uri,
        experiment="benchmark",
        artifact_location=str(root / "hook_artifacts"),
        log_artifacts=True,
        resume=True,
        companion=False,  # the hooks alone, in this process
    )
    times = []
    for index in range(repeats):
        output_dir = root / "hooks" / str(index)
        shutil.copytree(job_dir, output_dir)
        config = OmegaConf.merge(
            job_config,
            {
                "hydra": {
                    "runtime": {"output_dir": str(output_dir), "cwd": str(REPO_ROOT)},
                    "job": {"name": "cli", "num": index},
                    "mode": "RUN",
                    "overrides": {"task": [f"seed={index}"]},
                }
            },
        )
        start = time.perf_counter()
        callback.on_job_start(config)
        callback.on_job_end(config, JobReturn(status=JobStatus.COMPLETED, _return_value=metrics))
        times.append(time.perf_counter() - start)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=4, help="jobs per end-to-end sweep (default 4)")
    parser.add_argument("--repeats", type=int, default=10, help="timed callback runs (default 10)")
    arguments = parser.parse_args()
    jobs = arguments.jobs
    from lwrlab.tracking.store.sqlite import prepare_sqlite_store

    with tempfile.TemporaryDirectory(prefix="lwrlab_bench_") as scratch:
        root = Path(scratch)
        uri = f"sqlite:///{root / 'store' / 'mlflow.db'}"
        start = time.perf_counter()
        prepare_sqlite_store(uri)
        schema_s = time.perf_counter() - start
        single = root / "single"
        completed = subprocess.run(
            [sys.executable, "-m", "lwrlab.cli", "tracking=none", f"hydra.run.dir={single}", *SHORT_JOB],
            cwd=REPO_ROOT,
            capture_output=True,
            text=True,
        )
        if completed.returncode != 0:
            raise SystemExit(f"job failed:\n{completed.stderr[-3000:]}")
        hooks = hook_seconds(single, root, uri, arguments.repeats)
        folder_mb = sum(p.stat().st_size for p in single.rglob("*") if p.is_file()) / 1e6
        untracked = sweep_seconds(jobs, root / "off", ["tracking=none"])
        tracked = sweep_seconds(
            jobs, root / "on", [f"tracking.uri={uri}", f"tracking.artifact_location={root / 'artifacts'}"]
        )
        artifacts_mb = sum(p.stat().st_size for p in (root / "artifacts").rglob("*") if p.is_file()) / 1e6
    overhead = (tracked - untracked) / jobs
    hooks_sorted = sorted(hooks)
    print(
        f"callback hooks per job         median {hooks_sorted[len(hooks) // 2]:.3f} s, mean {sum(hooks) / len(hooks):.3f} s, "
        f"max {hooks_sorted[-1]:.3f} s  ({len(hooks)} jobs, {folder_mb:.1f} MB output folder each)"
    )
    print(f"jobs per end-to-end sweep      {jobs}")
    print(f"sweep, tracking off            {untracked:8.2f} s  ({untracked / jobs:.2f} s/job)")
    print(f"sweep, tracking into SQLite    {tracked:8.2f} s  ({tracked / jobs:.2f} s/job)")
    print(
        f"tracking overhead              {overhead:8.3f} s/job  ({100 * overhead / (untracked / jobs):.1f} % of a job)"
    )
    print(f"artifacts uploaded             {artifacts_mb:8.1f} MB  ({artifacts_mb / jobs:.1f} MB/job)")
    print(f"store creation (once)          {schema_s:8.2f} s")
    median = hooks_sorted[len(hooks) // 2]
    print(
        f"goal ≤ {GOAL_S} s/job, hooks: {'met' if median <= GOAL_S else 'NOT met'} (median / goal = {median / GOAL_S:.2f}); "
        f"end to end: {'met' if overhead <= GOAL_S else 'NOT met'} (overhead / goal = {overhead / GOAL_S:.2f})"
    )


if __name__ == "__main__":
    main()
