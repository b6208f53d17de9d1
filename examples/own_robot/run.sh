#!/usr/bin/env bash
# Your own robot: a safe exciting motion from a URDF, exported for ROS 2, with its preview picture.
#
# What it shows (README, "Your own robot: a safe exciting motion"):
#   1. describe the robot: a URDF with <collision> meshes, MoveIt's SRDF (pairs never checked) and a
#      MoveIt joint_limits.yaml (a URDF has no acceleration limits: ur5_joint_limits.yaml beside this
#      script gives them), plus an obstacle in the workspace (a pillar) besides the table it stands on;
#   2. optimise the exciting motion (task=excitation) under every limit and 1 cm clear of itself, the
#      table and the pillar, checked at 1 kHz against the exact meshes (a motion that fails is written
#      as rejected_exciting_motion.* and the run exits with status 1);
#   3. what comes out: exciting_motion_goal.yaml (a control_msgs/action/FollowJointTrajectory goal),
#      exciting_motion_bag/ (a ROS 2 bag of one trajectory_msgs/msg/JointTrajectory),
#      exciting_motion.csv (any other controller), exciting_motion_preview.png (the robot at its closest
#      approaches) and excitation_report.md (every slack and distance).
#
# The arm is Universal Robots' UR5 as example-robot-data describes it (installed with
# `pip install 'lwrlab[robots]'`), read as any URDF would be (robot=urdf). The motion lasts 4 s instead
# of the paper's 10 s so that the example runs in under a minute (2-15 s of optimisation).
# `robot=example_robot robot.robot_name=ur5 robot.acceleration_limits=3` loads the same arm by name
# (one acceleration limit for every joint instead of the joint_limits.yaml).
#
# Run:     examples/own_robot/run.sh [OUTPUT_FOLDER]        (default: a new temporary folder)
# Options: LWRLAB=.venv/bin/lwrlab   the lwrlab command (default: `lwrlab` on the PATH)
#          PYTHON=.venv/bin/python   the Python that has lwrlab (default: the one beside $LWRLAB)
#          URDF=my_arm.urdf SRDF=my_arm.srdf JOINT_LIMITS=joint_limits.yaml   your own arm instead
#          (meshes named package://NAME/... are found through ROS_PACKAGE_PATH)
# Tracking goes into OUTPUT_FOLDER/mlflow.db, never into the repository's outputs/.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
source "$HERE/../environment.sh" lwrlab_own_robot "${1:-}"  # LWRLAB, PYTHON, OUT, absolute

# 1. The robot's description: your files, or example-robot-data's UR5.
if [[ -n "${URDF:-}" ]]; then
  URDF="$(absolute "$URDF")"
  if [[ -n "${SRDF:-}" ]]; then SRDF="$(absolute "$SRDF")"; fi
  if [[ -n "${JOINT_LIMITS:-}" ]]; then JOINT_LIMITS="$(absolute "$JOINT_LIMITS")"; fi
else
  FILES="$("$PYTHON" -c '
from plugins.robots.example_robot import ROBOTS, example_robot_file
ur5 = ROBOTS["ur5"]
print(example_robot_file(ur5.urdf))
print(example_robot_file(ur5.srdf))')"
  URDF="$(sed -n 1p <<<"$FILES")"
  SRDF="$(sed -n 2p <<<"$FILES")"
  JOINT_LIMITS="${JOINT_LIMITS:-$HERE/ur5_joint_limits.yaml}"
fi
ROBOT=(robot=urdf "robot.path=$URDF")
if [[ -n "${SRDF:-}" ]]; then ROBOT+=("robot.srdf=$SRDF"); fi
if [[ -n "${JOINT_LIMITS:-}" ]]; then ROBOT+=("robot.joint_limits=$JOINT_LIMITS"); fi
cd "$OUT"  # nothing lands in the folder the script was started from
echo "robot: $URDF"

# 2. Optimise and check the motion: 4 s, clear of itself, the table (the base frame's z = 0 plane) and
#    a pillar 10 cm in radius standing 0.5 m in front and 0.4 m to the left of the base.
"$LWRLAB" task=excitation "${ROBOT[@]}" \
  trajectory.duration=4 \
  'trajectory.constraints.world.obstacles=[{name: pillar, shape: cylinder, radius: 0.1, length: 1.5, xyz: [0.5, 0.4, 0.75]}]' \
  optimizer.show_progress=false \
  "tracking.uri=sqlite:///$OUT/mlflow.db" "tracking.artifact_location=$OUT/mlartifacts" \
  "hydra.run.dir=$OUT/excitation"

# 3. What to take to the robot.
RUN="$OUT/excitation"
"$PYTHON" - "$RUN" <<'EOF'
import json
import sys
from pathlib import Path

run = Path(sys.argv[1])
metrics = json.loads((run / "metrics.json").read_text())
print(
    f"\naccepted: {bool(metrics['accepted'])}; cond(W_b) {metrics['cond_W_b']:.1f}; "
    f"closest to itself {1000 * metrics['closest_self_m']:.1f} mm, "
    f"to the world {1000 * metrics['closest_world_m']:.1f} mm (clearance 10 mm)"
)
for name in (
    "exciting_motion_goal.yaml",
    "exciting_motion_bag",
    "exciting_motion.csv",
    "exciting_motion_preview.png",
    "excitation_report.md",
):
    print(f"  {run / name}")
EOF
cat <<EOF

Bring the arm to the start pose at rest (the goal file's header gives it and the command), then:
  ros2 action send_goal /joint_trajectory_controller/follow_joint_trajectory \\
    control_msgs/action/FollowJointTrajectory "\$(cat $RUN/exciting_motion_goal.yaml)"
record /joint_states while it plays, and identify from that log (examples/logs/run.sh).
EOF
