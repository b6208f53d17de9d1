"""Figures of value objects and run tables (matplotlib, files only): no MLflow, no Hydra, no pipeline.

Below the pipeline and tracking, which call them; matplotlib is imported on the first drawing
(:func:`lwrlab.figures.backend.subplots`), not when a module is imported.
"""
