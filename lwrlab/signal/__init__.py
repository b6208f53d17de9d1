"""Measurement processing: zero-phase filtering, differentiation, trimming, decimation."""

from lwrlab.signal.processing import ProcessedData, central_difference, lowpass, process

__all__ = ["ProcessedData", "central_difference", "lowpass", "process"]
