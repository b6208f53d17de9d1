"""lwrlab: fast, accurate dynamic identification of robot manipulators.

The core (everything under ``lwrlab`` except ``pipeline``, ``tracking``, ``io`` and ``cli``) is pure
numpy/scipy/Pinocchio: it never touches files, MLflow or Hydra.
"""

__version__ = "0.1.0"
