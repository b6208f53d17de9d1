"""Stages that wire the core from configured objects and write their artifacts."""
