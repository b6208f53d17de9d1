"""Tasks that run beside a robot over ROS 2: ``live_monitor`` and the robot they can run beside.

The modules:

- :mod:`~lwrlab.pipeline.live.monitor`: ``task=live_monitor``, the monitor of ``task=monitor`` (its
  model, its calibration) on a robot's joint states as they are published, the estimates published
  back and the run kept as ``task=monitor`` keeps one, with the bag of the run;
- :mod:`~lwrlab.pipeline.live.sim_robot`: ``task=sim_robot``, the simulated arm (MuJoCo, pushed at
  known times) publishing its joint states like a ``ros2_control`` robot, and its truth;
- :mod:`~lwrlab.pipeline.live.painting`: ``task=live_painting``, the painting controller of
  ``task=painting`` commanding a robot's joint positions from its joint states;
- :mod:`~lwrlab.pipeline.live.sim_painting_robot`: ``task=sim_painting_robot``, the painting task's
  arm, wall and roller stepped live on those commands.

Both wire the live edge (:mod:`lwrlab.live`) to the core; the monitor reads models and calibrations
through :mod:`lwrlab.pipeline.monitor`.
"""

from lwrlab.pipeline.live.monitor import run_live_monitor
from lwrlab.pipeline.live.painting import run_live_painting
from lwrlab.pipeline.live.sim_painting_robot import run_sim_painting_robot
from lwrlab.pipeline.live.sim_robot import run_sim_robot

__all__ = ["run_live_monitor", "run_live_painting", "run_sim_painting_robot", "run_sim_robot"]
