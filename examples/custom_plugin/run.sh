#!/usr/bin/env bash
# A plugin outside lwrlab: a friction law of one's own (module + YAML in its own folder), used once.
#
# What it shows (README, "Adding a plugin"): a plugin is one module plus one YAML, and nothing in lwrlab
# is edited. Here:
#   my_friction.py                      the law FC·sign(v) + FV·v + FD·v·|v| (its own term, FD1…FDN),
#                                       implementing lwrlab.model.friction_laws.FrictionLaw;
#   conf/friction/quadratic_drag.yaml   its config: `_target_: my_friction.QuadraticDrag` and its one
#                                       setting, in a config folder of its own (conf/<group>/<option>.yaml).
# lwrlab finds the YAML through Hydra's search path (hydra.searchpath=[file://…/conf]) and imports the
# module from PYTHONPATH; then `friction=quadratic_drag` is an option like the shipped ones:
#   1. --cfg job --package friction prints the composed friction node (the YAML was found);
#   2. task=identification on the simulated KUKA LWR4 (shipped 10 s exciting motion, 10 s validation)
#      fits the drag columns beside the inertial and friction parameters. The simulated arm has no drag
#      (its friction is the paper's law), so FD1…FD7 come out near zero, within a few σ.
# The same works for any plugin group: an estimator (conf/estimator/), an excitation criterion
# (conf/criterion/, README "Your own criterion, outside lwrlab"), a trajectory, a classifier, …
#
# Run:     examples/custom_plugin/run.sh [OUTPUT_FOLDER]   (default: a new temporary folder); about 20 s
# Options: LWRLAB=.venv/bin/lwrlab   the lwrlab command (default: `lwrlab` on the PATH)
#          PYTHON=.venv/bin/python   the Python that has lwrlab and pandas (default: the one lwrlab runs on)
# Tracking goes into OUTPUT_FOLDER/mlflow.db, never into the repository's outputs/.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
source "$HERE/../environment.sh" lwrlab_plugin "${1:-}"  # LWRLAB, PYTHON, OUT, absolute
cd "$OUT"  # nothing lands in the folder the script was started from

export PYTHONPATH="$HERE${PYTHONPATH:+:$PYTHONPATH}"  # `_target_: my_friction.QuadraticDrag` imports
PLUGIN=("hydra.searchpath=[file://$HERE/conf]" friction=quadratic_drag)

# 1. The option is found: the composed friction node.
"$LWRLAB" "${PLUGIN[@]}" --cfg job --package friction

# 2. One identification with it.
"$LWRLAB" "${PLUGIN[@]}" task=identification validation.duration=10 plant.show_progress=false \
  "tracking.uri=sqlite:///$OUT/mlflow.db" "tracking.artifact_location=$OUT/mlartifacts" \
  "hydra.run.dir=$OUT/identification" >"$OUT/identification.log" 2>&1 \
  || { tail -n 40 "$OUT/identification.log"; exit 1; }

"$PYTHON" - "$OUT/identification" <<'PY'
import json
import sys
from pathlib import Path

import pandas as pd

run = Path(sys.argv[1])
parameters = pd.read_csv(run / "base_parameters.csv")
drag = parameters[parameters["parameter"].str.startswith("FD")]
print("\nthe law's own parameters (truth: no drag), from base_parameters.csv:\n")
print(drag.to_markdown(index=False, floatfmt=".4g"))
metrics = json.loads((run / "metrics.json").read_text())
print(
    f"\nvalidation RMS {metrics['rms_mean']:.4f} N·m (sensor noise 0.1 N·m), "
    f"base-parameter error {metrics['base_parameter_error']:.2%}; run folder {run}"
)
PY
