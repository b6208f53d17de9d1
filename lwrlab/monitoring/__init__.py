"""Monitoring a robot with its model: external joint torques, contact forces and collision detection.

From joint positions and link-side torques (a log, or a real-time loop) and a dynamic model
(identified or CAD):

- :mod:`~lwrlab.monitoring.observer`: De Luca's generalized-momentum observer, discrete-time, as a
  pure step function and vectorised over a log;
- :mod:`~lwrlab.monitoring.observer_inputs`: what the observer reads from a log, q, q̇ and τ at one
  instant through one causal filter (the velocity filter's delay leaves its balance);
- :mod:`~lwrlab.monitoring.direct_residual`: the direct residual τ − τ̂(q, q̇, q̈), for comparison;
- :mod:`~lwrlab.monitoring.contact_force`: the Cartesian wrench or force from external torques
  (eq. (14): (Jᵀ)⁺·τ_ext);
- :mod:`~lwrlab.monitoring.calibration`: detection thresholds per joint from contact-free data,
  for a stated false-alarm rate;
- :mod:`~lwrlab.monitoring.detection`: contacts detected with hysteresis and a minimum duration;
- :mod:`~lwrlab.monitoring.scoring`: detections scored against known contacts (simulation).

Sign convention (that of eq. (14) and :mod:`lwrlab.control.force_estimation`): the external joint
torque is τ − τ̂, the torque the drives spend against the environment, ``Jᵀ·w`` with ``w`` the wrench
the robot exerts on it; a push ``F`` on the arm gives ``w = −F``.
"""
