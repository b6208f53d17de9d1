"""Per-job MLflow tracking overhead: the same sweep with tracking off and with tracking into SQLite.

Both sweeps run the real ``lwrlab`` identification job (shortened motions) through Hydra's basic
launcher in one process each, so process start and imports cost the same in both; the difference
divided by the number of jobs is what tracking adds to a job (params, tags, metrics in batches, the
output folder as artifacts, run status). The store is created beforehand (its one-time schema
creation is reported separately). Goal: ≤ 0.5 s per job.

    .venv/bin/python benchmarks/tracking.py [--jobs 4]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
SHORT_JOB = ["trajectory=multisine", "trajectory.duration=2", "validation.duration=2", "plant.show_progress=false"]
GOAL_S = 0.5


def sweep_seconds(jobs: int, folder: Path, tracking: list[str]) -> float:
    """Wall time of a ``lwrlab -m seed=0..jobs-1`` sweep with the given tracking overrides."""
    command = [
        sys.executable, "-m", "lwrlab.cli", "-m", f"seed={','.join(map(str, range(jobs)))}",
        f"hydra.sweep.dir={folder / 'sweep'}", *SHORT_JOB, *tracking,
    ]
    start = time.perf_counter()
    completed = subprocess.run(command, cwd=REPO_ROOT, capture_output=True, text=True)
    elapsed = time.perf_counter() - start
    if completed.returncode != 0:
        raise SystemExit(f"sweep failed:\n{completed.stderr[-3000:]}")
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=4, help="jobs per sweep (default 4)")
    jobs = parser.parse_args().jobs
    from lwrlab.tracking.store import prepare_sqlite_store

    with tempfile.TemporaryDirectory(prefix="lwrlab_bench_") as scratch:
        root = Path(scratch)
        uri = f"sqlite:///{root / 'store' / 'mlflow.db'}"
        start = time.perf_counter()
        prepare_sqlite_store(uri)
        schema_s = time.perf_counter() - start
        untracked = sweep_seconds(jobs, root / "off", ["tracking=none"])
        tracked = sweep_seconds(jobs, root / "on", [f"tracking.uri={uri}", f"tracking.artifact_location={root / 'artifacts'}"])
        artifacts_mb = sum(p.stat().st_size for p in (root / "artifacts").rglob("*") if p.is_file()) / 1e6
    overhead = (tracked - untracked) / jobs
    print(f"jobs per sweep                 {jobs}")
    print(f"sweep, tracking off            {untracked:8.2f} s  ({untracked / jobs:.2f} s/job)")
    print(f"sweep, tracking into SQLite    {tracked:8.2f} s  ({tracked / jobs:.2f} s/job)")
    print(f"tracking overhead              {overhead:8.3f} s/job  ({100 * overhead / (untracked / jobs):.1f} % of a job)")
    print(f"artifacts uploaded             {artifacts_mb:8.1f} MB  ({artifacts_mb / jobs:.1f} MB/job)")
    print(f"store creation (once)          {schema_s:8.2f} s")
    print(f"goal ≤ {GOAL_S} s/job: {'met' if overhead <= GOAL_S else 'NOT met'} (overhead / goal = {overhead / GOAL_S:.2f})")


if __name__ == "__main__":
    main()
