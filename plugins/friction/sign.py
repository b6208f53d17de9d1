"""The paper's friction law (eq. 5): ``FC·sign(v) + FV·v`` (+ ``FO``), the default on simulated robots.

The law itself lives in the core (:class:`lwrlab.model.friction_laws.SignCoulomb`), as every robot's
default; this module is its entry in the config group.
"""

from __future__ import annotations

from lwrlab.model.friction_laws import SignCoulomb

__all__ = ["SignCoulomb"]
