"""A smooth Coulomb law: ``FC·tanh(v/ε) + FV·v`` (+ ``FO``).

``sign(v)`` flips on encoder noise when a joint stands still or reverses; ``tanh(v/ε)`` passes
through zero over a speed band ``ε`` (rad/s, joint side) instead. ``width`` is one ε, or several to
choose from by block cross-validation (:mod:`lwrlab.identification.friction_choice`).
"""

from __future__ import annotations

from lwrlab.model.friction_laws import TanhCoulomb


class SmoothCoulomb(TanhCoulomb):
    """``FC·tanh(v/width) + FV·v``; ``width`` (rad/s): one value, or a grid chosen by the data."""

    name = "smooth"
