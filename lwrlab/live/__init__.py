"""ROS 2 on the wire without a ROS install: the live edge (sources and sinks of samples on topics).

Cyclone DDS from PyPI (the optional extra ``[ros2]``) speaks ROS 2's wire protocol: topics
``rt/<name>``, types ``<pkg>::msg::dds_::<Type>_``, CDR bytes equal to a ROS 2 node's. The modules,
bottom up:

- :mod:`~lwrlab.live.messages`: the messages as plain typed records with ROS 2's wire names;
- :mod:`~lwrlab.live.dds`: a node (a DDS participant on ROS 2's domain, loopback-only on request),
  its publishers and subscriptions with ROS 2's QoS profiles;
- :mod:`~lwrlab.live.joint_states`: a ``sensor_msgs/JointState`` read into the robot's joint order,
  checked (the samples a monitor must refuse, each with its reason);
- :mod:`~lwrlab.live.recorder`: a rosbag2 (MCAP) written behind the loop, from a queue, by
  :mod:`~lwrlab.live.bag_writer`, a process of its own;
- :mod:`~lwrlab.live.monitor_loop` and :mod:`~lwrlab.live.painting_loop`: the sample paths of the
  live monitor and of the live painting controller.

Thin on purpose: the computation they feed is the core's: the monitor's streaming form
(:mod:`lwrlab.monitoring.stream`), the same that runs on a log, and the painting task's estimator,
controller plugins and command guards (:mod:`lwrlab.control`).
"""
