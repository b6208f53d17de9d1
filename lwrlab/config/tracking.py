"""Schema of the ``tracking`` group's settings (``conf/tracking/sqlite.yaml``, ``server.yaml``)."""

from __future__ import annotations

from lwrlab.config.schema import schema


@schema
class TrackingStoreSettings:
    """Where MLflow runs go (``tracking=none`` has no such settings)."""

    uri: str
    """MLflow tracking URI: ``sqlite:///…``, ``http://host:5000``, …"""
    artifact_location: str | None
    """Where new experiments keep their artifacts; null: the server decides."""
    register_model: str | None
    """Register each identified model as a new version of this registered model (``robot`` or
    ``true``: the robot's name, ``<robot>_payload`` for a payload run's); null: logged with its run
    only."""
