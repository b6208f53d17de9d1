#!/usr/bin/env bash
# Identify a robot from its logs (CSV and Parquet), read the results with pandas; then the same logs as a
# geared arm's drives record them (motor angles and motor torques), read through a `drive:` block.
#
# What it shows (README, "Identification from a real robot's logs" and "Arms with drive trains"):
#   1. task=write_example_logs: the simulated KUKA LWR4's shipped 10 s exciting motion and a 10 s
#      validation multisine (20 s by default) written as logs (t, q1…q7 rad, tau1…tau7 N·m at 1 kHz), once as CSV and once
#      as Parquet: stand-ins for what your robot's controller records;
#   2. task=identification plant=log with data.paths (identification logs) and data.validation_paths
#      (logs kept out of the fit, scored on their own): the defaults for logs, i.e. physically
#      consistent bodies (estimator=sdp, prior weight chosen by cross-validation) and the friction law
#      chosen by the data (friction=auto);
#   3. read_results.py: predicted_torque.parquet (measured and predicted torques of every log, with
#      95 % intervals) and friction_choice.csv (every candidate law's held-out error) with pandas;
#   4. a motor-side variant: to_motor_side.py rewrites the logs as gear-driven motors measure them
#      (θ = R·q, τ_motor = R⁻ᵀ·τ, R = diag(gear_ratios)·C), and lwrlab reads them back through the
#      robot's `drive:` block (robot.drive=…: gear ratios, which side each signal is measured on, the
#      reflected rotor-inertia columns `auto`). The fit equals the joint-side one to rounding: the
#      conversion is exact and the simulated arm has no gears. A coupled wrist (motor 7 also turning
#      with joint 6) would be `coupling: [[7, 6, 0.3]]` in DRIVE below.
#
# With your own robot: robot=urdf robot.path=my_arm.urdf (no acceleration limits needed for logs) and
# your files in data.paths; other column names through data.column_map (docs/reference/log-formats.md, "Files and columns").
#
# Run:     examples/logs/run.sh [OUTPUT_FOLDER]        (default: a new temporary folder); about a minute
# Options: LWRLAB=.venv/bin/lwrlab   the lwrlab command (default: `lwrlab` on the PATH)
#          PYTHON=.venv/bin/python   the Python that has lwrlab and pandas (default: the one lwrlab runs on)
# Tracking goes into OUTPUT_FOLDER/mlflow.db, never into the repository's outputs/.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
source "$HERE/../environment.sh" lwrlab_logs "${1:-}"  # LWRLAB, PYTHON, OUT, absolute
cd "$OUT"  # nothing lands in the folder the script was started from
TRACKING=("tracking.uri=sqlite:///$OUT/mlflow.db" "tracking.artifact_location=$OUT/mlartifacts")

# 1. Example logs: identification.csv + validation.csv, and the same as Parquet (no tracking needed).
for format in csv parquet; do
  "$LWRLAB" task=write_example_logs "task.file_format=$format" "task.directory=$OUT/logs/$format" \
    validation.duration=10 plant.show_progress=false tracking=none "hydra.run.dir=$OUT/runs/write_$format" >/dev/null
done
ls -l "$OUT"/logs/*/

# 2. Identify from the CSV log, validate on the Parquet log of another motion.
"$LWRLAB" task=identification plant=log \
  "data.paths=[$OUT/logs/csv/identification.csv]" \
  "data.validation_paths=[$OUT/logs/parquet/validation.parquet]" \
  "${TRACKING[@]}" "hydra.run.dir=$OUT/runs/joint_side"

# 3. The run's files, read with pandas.
"$PYTHON" "$HERE/read_results.py" "$OUT/runs/joint_side"

# 4. Motor side: the drive train described in data, beside the kinematics (one YAML flow mapping,
#    used both to write the motor-side logs and as the robot's drive block).
DRIVE='{gear_ratios: [160, 160, 160, 160, 100, 100, 100], coupling: null, torque_constants: null, position_side: motor, torque_side: motor, rotor_inertia: auto}'
"$PYTHON" "$HERE/to_motor_side.py" "$DRIVE" "$OUT/logs/csv/identification.csv" "$OUT/logs/motor/identification.csv"
"$PYTHON" "$HERE/to_motor_side.py" "$DRIVE" "$OUT/logs/parquet/validation.parquet" "$OUT/logs/motor/validation.parquet"
"$LWRLAB" task=identification plant=log "robot.drive=$DRIVE" \
  "data.paths=[$OUT/logs/motor/identification.csv]" \
  "data.validation_paths=[$OUT/logs/motor/validation.parquet]" \
  "${TRACKING[@]}" "hydra.run.dir=$OUT/runs/motor_side"
"$PYTHON" "$HERE/read_results.py" "$OUT/runs/motor_side"

echo
echo "runs: $OUT/runs/joint_side and $OUT/runs/motor_side (summary.md, base_parameters.csv, figures)"
echo "MLflow: mlflow ui --backend-store-uri sqlite:///$OUT/mlflow.db   (experiment: identification)"
