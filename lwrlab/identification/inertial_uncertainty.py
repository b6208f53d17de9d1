"""How well a fit determines a body's mass, centre of mass and inertia about it (a URDF's values).

A fit gives the 10 standard parameters ``φ`` (mass, first moment, inertia about the frame origin)
with a covariance ``Σ``; a URDF ``<inertial>`` holds other values: the mass, the centre of mass
``c = MS/M`` and the inertia about it ``I_c = I − M·(|c|²·1 − c·cᵀ)``. Their standard deviations are
propagated to first order, ``σ² = diag(J·Σ·Jᵀ)`` with ``J`` the Jacobian of that map at ``φ``
(central differences): what the logs say of each value the URDF carries.

Examples
--------
>>> from lwrlab.model.inertia import standard_parameters
>>> phi = standard_parameters(2.0, np.array([0.0, 0.0, 0.1]), np.diag([0.01, 0.01, 0.004]))
>>> std = urdf_value_std(phi, np.diag([1e-4] + [1e-10] * 9))  # only the mass is uncertain (σ 0.01 kg)
>>> round(float(std[0]), 6), round(float(std[3]), 6)  # σ of the mass, and of c_z = MSZ / M
(0.01, 0.0005)
"""

from __future__ import annotations

import numpy as np

from lwrlab.model.inertia import mass_com_inertia

URDF_VALUE_NAMES = ("mass", "com_x", "com_y", "com_z", "ixx", "iyy", "izz", "ixy", "ixz", "iyz")
"""The values of a URDF ``<inertial>``: kg, m (centre of mass), kg·m² (inertia about it)."""
URDF_VALUE_UNITS = ("kg", "m", "m", "m", "kg·m²", "kg·m²", "kg·m²", "kg·m²", "kg·m²", "kg·m²")
"""The unit of each of :data:`URDF_VALUE_NAMES`."""
WELL_DETERMINED_PCT = 10.0
"""%σ up to which the logs determine a value well."""
ROUGHLY_DETERMINED_PCT = 50.0
"""%σ up to which they determine it roughly; above, hardly (the motion barely moves it)."""


def urdf_values(phi: np.ndarray) -> np.ndarray:
    """(10,) mass, centre of mass and inertia about it (``ixx, iyy, izz, ixy, ixz, iyz``) of ``phi``."""
    mass, com, inertia = mass_com_inertia(np.asarray(phi, dtype=float))
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    return np.array([mass, *com, *(inertia[i, j] for i, j in pairs)])


def urdf_value_std(phi: np.ndarray, covariance: np.ndarray) -> np.ndarray:
    """(10,) σ of :func:`urdf_values` from the covariance (10, 10) of ``phi`` (first order)."""
    phi = np.asarray(phi, dtype=float)
    steps = 1e-6 * np.maximum(np.abs(phi), 1e-6 * max(abs(float(phi[0])), 1e-3))
    jacobian = np.column_stack(
        [
            (urdf_values(phi + h * e) - urdf_values(phi - h * e)) / (2 * h)
            for h, e in zip(steps, np.eye(10), strict=True)
        ]
    )
    return np.sqrt(np.clip(np.diag(jacobian @ np.asarray(covariance, dtype=float) @ jacobian.T), 0.0, None))


def urdf_value_relative_std(values: np.ndarray, std: np.ndarray) -> np.ndarray:
    """(10,) %σ of :func:`urdf_values`: each σ relative to its group's size — the mass's to the mass,
    a centre-of-mass coordinate's to the centre's largest coordinate, an inertia's to the largest
    principal-axis value — so a coordinate or product of inertia near zero is not 'hardly known'
    for being near zero."""
    values, std = np.asarray(values, dtype=float), np.asarray(std, dtype=float)
    scales = np.concatenate(
        [
            [abs(values[0])],
            np.full(3, np.abs(values[1:4]).max()),
            np.full(6, np.abs(values[4:7]).max()),
        ]
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(scales > 0, 100.0 * std / scales, np.inf)


def determination(relative_std_pct: float) -> str:
    """``well``, ``roughly`` or ``hardly``: how well the logs determine a value of that %σ."""
    if relative_std_pct <= WELL_DETERMINED_PCT:
        return "well"
    if relative_std_pct <= ROUGHLY_DETERMINED_PCT:
        return "roughly"
    return "hardly"


__all__ = [
    "ROUGHLY_DETERMINED_PCT",
    "URDF_VALUE_NAMES",
    "URDF_VALUE_UNITS",
    "WELL_DETERMINED_PCT",
    "determination",
    "urdf_value_relative_std",
    "urdf_value_std",
    "urdf_values",
]
