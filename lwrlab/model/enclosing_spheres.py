"""Spheres that enclose a triangle mesh: the fast, differentiable stand-in of a link's geometry.

The optimiser of an exciting motion needs distances between links, with gradients, on a thousand
samples per evaluation; exact mesh distances cost far too much there. Each link is covered instead by a
few spheres (as cuRobo does), fitted so that they provably *contain* the mesh:

1. triangles longer than a fraction of the link's thickness are bisected (same surface, finer
   pieces), then grouped by k-means on their centroids (k from the link's slenderness);
2. each group gets the smallest ball (Bădoiu–Clarkson iterations) around the vertices of its
   triangles, its radius the largest distance to them.

A ball contains a triangle when it contains its three vertices (balls are convex), so the union of the
spheres contains every triangle of the mesh: a positive distance between two links' spheres (or between
a link's spheres and the floor) proves the links themselves are apart. The exact check of the final
motion (:mod:`lwrlab.excitation.collision_check`) uses the meshes themselves.

Examples
--------
>>> import numpy as np
>>> vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
>>> faces = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])
>>> centres, radii = enclosing_spheres(vertices, faces, n_spheres=1)
>>> bool(np.all(np.linalg.norm(vertices - centres[0], axis=1) <= radii[0] + 1e-12))
True
"""

from __future__ import annotations

import numpy as np

MAX_SPHERES = 16
"""Most spheres fitted to one link."""


def smallest_ball(points: np.ndarray, iterations: int = 200) -> tuple[np.ndarray, float]:
    """Centre and radius of a ball containing ``points`` (M, 3), within about 1 % of the smallest.

    Bădoiu–Clarkson: step towards the farthest point by 1/(i+1); the radius is then the exact largest
    distance, so the ball contains every point whatever the iterations.
    """
    points = hull_vertices(points)  # the farthest point is always a vertex of the hull
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    for i in range(1, iterations + 1):
        far = points[np.argmax(np.sum((points - centre) ** 2, axis=1))]
        centre = centre + (far - centre) / (i + 1)
    return centre, float(np.sqrt(np.max(np.sum((points - centre) ** 2, axis=1))))


def bounding_sphere(centres: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre and radius of a ball containing the balls (``centres`` (M, 3), ``radii`` (M,)): centred
    amid the centres' box, its radius the largest reach ``‖c_i − c‖ + r_i`` (so it contains each ball
    exactly, whatever the centre). A lower bound of the distance between two groups of balls is then
    the gap between their bounding balls.

    >>> bounding_sphere(np.array([[0.0, 0, 0], [2, 0, 0]]), np.array([1.0, 0.5]))
    (array([1., 0., 0.]), 2.0)
    """
    centre = 0.5 * (centres.min(axis=0) + centres.max(axis=0))
    return centre, float(np.max(np.linalg.norm(centres - centre, axis=1) + radii))


def hull_vertices(points: np.ndarray) -> np.ndarray:
    """The vertices of the convex hull of ``points`` (M, 3); all of them when they are flat or few."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return points[ConvexHull(points).vertices]
    except (QhullError, ValueError):  # flat or too few points: all of them
        return points


def sphere_count(vertices: np.ndarray) -> int:
    """Spheres for a mesh: about three per thickness along its longest extent (2 … MAX_SPHERES)."""
    centred = vertices - vertices.mean(axis=0)
    axes = np.linalg.svd(centred, full_matrices=False)[2]
    extents = np.ptp(centred @ axes.T, axis=0)
    length, thickness = extents[0], max(float(np.median(extents[1:])), 1e-3)
    return int(np.clip(round(3.0 * length / thickness), 2, MAX_SPHERES))


def bisect_long_triangles(
    vertices: np.ndarray, faces: np.ndarray, max_edge: float
) -> tuple[np.ndarray, np.ndarray]:
    """The same surface with every triangle edge at most ``max_edge`` (m): triangles are cut in two
    at the middle of their longest edge until none is longer."""
    vertices, faces = np.asarray(vertices, dtype=float), np.asarray(faces, dtype=int)
    for _ in range(64):
        corners = vertices[faces]  # (F, 3, 3)
        edges = np.linalg.norm(corners[:, [1, 2, 0]] - corners, axis=2)  # edge i: corner i → i+1
        longest = np.argmax(edges, axis=1)
        long = edges[np.arange(len(faces)), longest] > max_edge
        if not long.any():
            break
        cut = faces[long]
        i = longest[long]
        a, b, c = (cut[np.arange(len(cut)), (i + k) % 3] for k in range(3))
        middles = 0.5 * (vertices[a] + vertices[b])
        m = len(vertices) + np.arange(len(cut))
        vertices = np.vstack([vertices, middles])
        faces = np.vstack([faces[~long], np.column_stack([a, m, c]), np.column_stack([m, b, c])])
    return vertices, faces


def enclosing_spheres(
    vertices: np.ndarray, faces: np.ndarray, n_spheres: int | None = None, seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Spheres (centres (k, 3), radii (k,)) whose union contains every triangle of the mesh.

    Parameters
    ----------
    vertices : (V, 3) mesh vertices (m).
    faces : (F, 3) vertex indices of the triangles.
    n_spheres : number of spheres; None: :func:`sphere_count`.
    seed : seed of the k-means initialisation (the fit is deterministic for a seed).
    """
    from scipy.cluster.vq import kmeans2

    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces, dtype=int)
    k = sphere_count(vertices) if n_spheres is None else int(n_spheres)
    extents = np.ptp(vertices, axis=0)
    vertices, faces = bisect_long_triangles(vertices, faces, max(float(np.max(extents)) / (2.0 * k), 1e-3))
    k = max(1, min(k, len(faces)))
    centroids = vertices[faces].mean(axis=1)
    if k == 1:
        labels = np.zeros(len(faces), dtype=int)
    else:
        _, labels = kmeans2(centroids, k, minit="++", seed=seed)
    centres, radii = [], []
    for cluster in np.unique(labels):
        points = vertices[np.unique(faces[labels == cluster])]
        centre, radius = smallest_ball(points)
        centres.append(centre)
        radii.append(radius)
    return np.array(centres), np.array(radii)
