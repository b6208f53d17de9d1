"""Measurement processing: zero-phase filtering, differentiation, trimming, decimation."""

from lwrlab.signal.filters import central_difference, lowpass
from lwrlab.signal.processed_data import ProcessedData
from lwrlab.signal.processing import process

__all__ = ["ProcessedData", "central_difference", "lowpass", "process"]
