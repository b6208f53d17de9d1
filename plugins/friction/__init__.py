"""Friction laws (config group ``friction``).

The protocol: :class:`lwrlab.model.friction_laws.FrictionLaw`.
"""
