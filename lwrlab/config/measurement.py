"""Schema of the ``measurement`` group (``conf/measurement/default.yaml``, read by ``lwrlab.signal``)."""

from __future__ import annotations

from typing import Any

from lwrlab.config.schema import schema


@schema
class ProcessingSettings:
    """Filter, differences, trimming and decimation of every measurement (keywords of ``process``)."""

    cutoff_hz: Any
    """The rows' low-pass cut-off (on τ and W): a number (Hz), ``auto`` or null (a union OmegaConf
    cannot type: see the rules)."""
    state_cutoff_hz: Any
    """The states' low-pass cut-off (on q before differentiating): a number (Hz), ``auto`` or null (the
    rows' cut-off)."""
    order: int
    """Butterworth order."""
    difference_accuracy: int
    """Centred differences: 2 (three-point) or 4 (five-point)."""
    trim_s: float | None
    """s dropped at each end; null = 2 / cut-off."""
    rate_hz: float | None
    """Hz, rate of the identification rows after the filter; null = 5 × the cut-off."""
    velocity: str
    """Velocity source: ``auto``, ``logged`` or ``differentiated``."""
    rest_sigmas: float | None
    """A joint whose processed speed is below this many σ of its positions' speed noise stands (its
    velocity is zero); null: every speed is kept."""
    block_s: float | None
    """s of log processed at a time (memory independent of the log's length); null = the whole log."""


@schema
class MeasurementSettings:
    """Sampling and processing of measurements."""

    rate_hz: float
    """Hz, sampling rate of a simulated robot's sensors (a log brings its own)."""
    processing: ProcessingSettings
    """How every measurement is processed before identification."""
