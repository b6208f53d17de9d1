"""Schema of the primary config's own settings (``conf/config.yaml``)."""

from __future__ import annotations

from lwrlab.config.schema import schema


@schema
class RootSettings:
    """``seed`` and ``experiment_name``, linked *last* in ``conf/config.yaml``'s defaults list.

    Last, so that it types these two keys and leaves every other top-level key (the groups, a
    preset's ``objective``, a user's own) as the options and presets composed them.
    """

    seed: int
    """Seed of everything random in the run (plant truth, noise, motions that draw phases)."""
    experiment_name: str | None
    """MLflow experiment the run is logged to; null: the task's name."""
