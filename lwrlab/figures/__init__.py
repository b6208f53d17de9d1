"""Figures of value objects (matplotlib, files only): no MLflow, no Hydra."""
