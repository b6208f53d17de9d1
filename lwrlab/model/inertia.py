"""Inertial parameters of one rigid segment, in the paper's standard order.

A segment's 10 standard parameters are expressed in its own (joint) frame, about the frame origin,
in the order of Katsumata et al. eq. (3)::

    phi = [M, MSX, MSY, MSZ, XX, YY, ZZ, XY, XZ, YZ]

with M the mass (kg), MS = M·c the first moment (kg·m) and the inertia tensor about the frame origin
(kg·m²). Pinocchio orders the same quantities as ``[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]``;
:data:`PIN_TO_STANDARD` converts.

Physical consistency is checked on the 4×4 pseudo-inertia ``J = [[Σ, h], [hᵀ, m]]`` with
``Σ = ½ tr(I)·1 − I`` (Wensing, Kim & Slotine 2017): ``J ⪰ 0`` is equivalent to a positive mass,
a positive semi-definite rotational inertia and the triangle inequalities, for a body of any shape.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

LINK_PARAMETER_NAMES: tuple[str, ...] = ("M", "MSX", "MSY", "MSZ", "XX", "YY", "ZZ", "XY", "XZ", "YZ")
"""Names of the 10 standard parameters of a segment, in the standard order."""

PIN_TO_STANDARD = np.array([0, 1, 2, 3, 4, 6, 9, 5, 7, 8])
"""``phi_standard = phi_pinocchio[PIN_TO_STANDARD]``."""

STANDARD_TO_PIN = np.argsort(PIN_TO_STANDARD)
"""``phi_pinocchio = phi_standard[STANDARD_TO_PIN]``."""


def inertia_matrix(phi: np.ndarray) -> np.ndarray:
    """Symmetric 3×3 inertia tensor about the frame origin (kg·m²) from standard parameters."""
    xx, yy, zz, xy, xz, yz = phi[4:10]
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def packed_parameters(mass: float, first_moment: np.ndarray, inertia_origin: np.ndarray) -> np.ndarray:
    """Standard parameters from mass (kg), first moment m·c (kg·m) and the 3×3 inertia about the frame
    origin (kg·m²): the inverse of reading ``phi[0]``, ``phi[1:4]`` and :func:`inertia_matrix`."""
    return np.array(
        [
            mass,
            *first_moment,
            inertia_origin[0, 0],
            inertia_origin[1, 1],
            inertia_origin[2, 2],
            inertia_origin[0, 1],
            inertia_origin[0, 2],
            inertia_origin[1, 2],
        ]
    )


def standard_parameters(mass: float, com: np.ndarray, inertia_com: np.ndarray) -> np.ndarray:
    """Standard parameters from mass (kg), centre of mass (m) and inertia about the CoM (kg·m², 3×3).

    The inertia is moved to the frame origin with the parallel-axis theorem.

    Examples
    --------
    >>> phi = standard_parameters(2.0, np.array([0.0, 0.0, 0.1]), np.eye(3) * 1e-2)
    >>> round(float(phi[4]), 6)  # XX = 0.01 + 2 · 0.1²
    0.03
    """
    com = np.asarray(com, dtype=float)
    inertia_com = np.asarray(inertia_com, dtype=float)
    inertia_origin = inertia_com + mass * (com @ com * np.eye(3) - np.outer(com, com))
    return packed_parameters(mass, mass * com, inertia_origin)


def mass_com_inertia(phi: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Inverse of :func:`standard_parameters`: mass, CoM and inertia about the CoM."""
    mass = float(phi[0])
    com = phi[1:4] / mass if mass > 0 else np.zeros(3)
    inertia_com = inertia_matrix(phi) - mass * (com @ com * np.eye(3) - np.outer(com, com))
    return mass, com, inertia_com


def to_pin_inertia(phi: np.ndarray) -> pin.Inertia:
    """Pinocchio spatial inertia from standard parameters."""
    return pin.Inertia.FromDynamicParameters(np.asarray(phi, dtype=float)[STANDARD_TO_PIN])


def from_pin_inertia(inertia: pin.Inertia) -> np.ndarray:
    """Standard parameters of a Pinocchio spatial inertia."""
    return np.asarray(inertia.toDynamicParameters())[PIN_TO_STANDARD]


def pseudo_inertia(phi: np.ndarray) -> np.ndarray:
    """4×4 pseudo-inertia matrix ``[[Σ, h], [hᵀ, m]]`` (linear in phi)."""
    inertia = inertia_matrix(phi)
    sigma = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    j = np.empty((4, 4))
    j[:3, :3] = sigma
    j[:3, 3] = j[3, :3] = phi[1:4]
    j[3, 3] = phi[0]
    return j


def from_pseudo_inertia(j: np.ndarray) -> np.ndarray:
    """Standard parameters from a pseudo-inertia matrix (inverse of :func:`pseudo_inertia`)."""
    sigma = j[:3, :3]
    inertia = np.trace(sigma) * np.eye(3) - sigma
    return packed_parameters(j[3, 3], j[:3, 3], inertia)


def min_pseudo_inertia_eigenvalue(phi: np.ndarray) -> float:
    """Smallest eigenvalue of the pseudo-inertia: ≥ 0 iff the segment is physically consistent."""
    return float(np.linalg.eigvalsh(pseudo_inertia(phi))[0])


def is_physically_consistent(phi: np.ndarray, tol: float = 1e-12) -> bool:
    """Whether ``J(phi) ⪰ 0`` (up to ``tol`` relative to the mass)."""
    return min_pseudo_inertia_eigenvalue(phi) >= -tol * max(1.0, abs(float(phi[0])))


RIGID_BODY_FLOOR = 1e-9
"""Smallest eigenvalue :func:`nearest_rigid_body` leaves the pseudo-inertia, relative to its largest:
strictly positive, so the body has a positive mass and an inertia about its centre of mass that is
positive definite and meets the triangle inequalities strictly."""


def nearest_rigid_body(phi: np.ndarray, relative_floor: float = RIGID_BODY_FLOOR) -> np.ndarray:
    """The rigid body nearest ``phi``: its pseudo-inertia ``J`` with every eigenvalue raised to at least
    ``relative_floor`` × the largest (the nearest such matrix in the Frobenius norm of ``J``, units
    kg, kg·m, kg·m² as they come). ``phi`` itself where it already is one.

    Examples
    --------
    >>> impossible = standard_parameters(2.0, np.zeros(3), np.diag([-0.03, -0.04, -0.007]))
    >>> body = nearest_rigid_body(impossible)
    >>> bool(is_physically_consistent(impossible)), bool(is_physically_consistent(body))
    (False, True)
    """
    phi = np.asarray(phi, dtype=float)
    values, vectors = np.linalg.eigh(pseudo_inertia(phi))
    floor = relative_floor * max(float(values[-1]), 0.0)
    if floor > 0 and values[0] >= floor:
        return phi
    if values[-1] <= 0:
        raise ValueError(
            "no rigid body is near these inertial parameters: their pseudo-inertia has no positive "
            f"eigenvalue (mass {phi[0]:.3g} kg)"
        )
    clipped = (vectors * np.maximum(values, floor)) @ vectors.T
    return from_pseudo_inertia(0.5 * (clipped + clipped.T))


def random_consistent_parameters(
    rng: np.random.Generator, scale_m: float = 0.2, mass_kg: float = 2.0
) -> np.ndarray:
    """Random strictly physically consistent parameters via a log-Cholesky factor of J.

    ``J = U Uᵀ`` with ``U`` upper triangular and a positive (exponentiated) diagonal is positive
    definite by construction (Rucker & Wensing 2022), so every draw is a possible rigid body.
    ``scale_m`` sets the body's size and ``mass_kg`` its typical mass.
    """
    u = np.triu(rng.normal(scale=0.5, size=(4, 4)), k=1)
    u[np.diag_indices(4)] = np.exp(rng.normal(scale=0.3, size=4))
    u[:3, :] *= scale_m
    j = u @ u.T * mass_kg / (u[3, 3] ** 2)
    return from_pseudo_inertia(j)


def perturb_consistent(phi: np.ndarray, relative_spread: float, rng: np.random.Generator) -> np.ndarray:
    """Perturb a consistent segment by about ``relative_spread`` while keeping it consistent.

    The Cholesky factor ``L`` of the pseudo-inertia (``J = L Lᵀ``, after a tiny regularisation so a
    point mass can be factored) moves by ``s·ε_ij·sqrt(L_ii·L_jj)``, ε ~ N(0, 1): entries that are
    zero in the nominal model (products of inertia of a CAD part aligned with its frame) move too,
    every entry of J changes by about ``s`` relative to the segment's own scale, and ``L' L'ᵀ`` is
    positive semi-definite whatever ε. A massless segment stays massless.
    """
    if phi[0] <= 0.0 or relative_spread == 0.0:
        return np.array(phi, dtype=float)
    j = pseudo_inertia(phi)
    j_reg = j + 1e-12 * max(1.0, phi[0]) * np.eye(4)
    factor = np.linalg.cholesky(j_reg)
    diagonal = np.sqrt(np.abs(np.diag(factor)))
    scale = np.tril(np.outer(diagonal, diagonal))
    perturbed = factor + relative_spread * rng.normal(size=factor.shape) * scale
    return from_pseudo_inertia(perturbed @ perturbed.T)
