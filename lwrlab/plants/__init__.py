"""Plants: what stands in for the real robot. They return a ``Measurement``, never the truth."""

from lwrlab.plants.core import Measurement, Plant, PlantTruth

__all__ = ["Measurement", "Plant", "PlantTruth"]
