#!/usr/bin/env bash
# A small sweep of estimators tracked in MLflow, `lwrlab compare` on it, and the runs as a pandas table.
#
# What it shows (README, "Tracking, sweeps and reports"):
#   1. a multirun (-m): estimator=ols,sdp × seed=0,1 (the seed draws another simulated robot and noise),
#      task=identification on short motions (a 4 s multisine to identify from, 4 s to validate on),
#      tracked into a SQLite store of its own: one parent run for the sweep, one nested run per job,
#      named by what differs (`sdp · seed=1 · identification`);
#   2. lwrlab compare: the FINISHED runs grouped by what they differ in (the estimator; seeds pooled as
#      replication), headline metrics as mean ± std, written as compare.md / .csv / .html and a figure,
#      and logged once more as a run `compare · estimator` in the same experiment;
#   3. runs_table.py: the same runs read with mlflow.search_runs into a pandas DataFrame.
#
# Run:     examples/sweep_and_compare/run.sh [OUTPUT_FOLDER]   (default: a new temporary folder); about a minute
# Options: LWRLAB=.venv/bin/lwrlab   the lwrlab command (default: `lwrlab` on the PATH)
#          PYTHON=.venv/bin/python   the Python that has lwrlab and MLflow (default: the one lwrlab runs on)
# Browse it afterwards: mlflow ui --backend-store-uri sqlite:///OUTPUT_FOLDER/mlflow.db
# Tracking goes into OUTPUT_FOLDER/mlflow.db, never into the repository's outputs/.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
source "$HERE/../environment.sh" lwrlab_sweep "${1:-}"  # LWRLAB, PYTHON, OUT, absolute
cd "$OUT"  # nothing lands in the folder the script was started from
STORE="sqlite:///$OUT/mlflow.db"
EXPERIMENT=example_sweep

# 1. The sweep: 4 jobs, one after another (hydra/launcher=parallel runs them 2 at a time).
"$LWRLAB" -m task=identification estimator=ols,sdp seed=0,1 \
  trajectory=multisine trajectory.duration=4 validation.duration=4 \
  "experiment_name=$EXPERIMENT" "tracking.uri=$STORE" "tracking.artifact_location=$OUT/mlartifacts" \
  "hydra.sweep.dir=$OUT/sweep" >"$OUT/sweep.log" 2>&1 || { tail -n 40 "$OUT/sweep.log"; exit 1; }
echo "sweep: 4 jobs in $OUT/sweep (console output in $OUT/sweep.log)"

# 2. Compare the runs: one row per estimator, seeds pooled.
"$LWRLAB" compare --tracking-uri "$STORE" --experiment "$EXPERIMENT" --output "$OUT/compare"

# 3. The runs as a pandas table, from MLflow.
"$PYTHON" "$HERE/runs_table.py" "$STORE" "$EXPERIMENT" "$OUT/runs.csv"
