"""Closed-form form factors (../shared/reference/truths.md), in double precision, written
independently of the solver's GLSL."""
import functools
import math

import numpy as np


def corner_form_factor(a, b, c):
    """Differential element under a corner of a parallel a x b rectangle at height c."""
    A, B = a / c, b / c
    return (A / math.sqrt(1 + A * A) * math.atan(B / math.sqrt(1 + A * A))
            + B / math.sqrt(1 + B * B) * math.atan(A / math.sqrt(1 + B * B))) / (2 * math.pi)


def parallel_rectangle_form_factor(x, y, x0, x1, y0, y1, c):
    """Element at (x, y) facing a parallel rectangle [x0, x1] x [y0, y1] at height c, by
    superposing the four corner rectangles (signed, so points outside work too)."""
    def corner(dx, dy):
        return math.copysign(1, dx) * math.copysign(1, dy) * corner_form_factor(abs(dx), abs(dy), c) \
            if dx and dy else 0.0
    return (corner(x1 - x, y1 - y) - corner(x0 - x, y1 - y)
            - corner(x1 - x, y0 - y) + corner(x0 - x, y0 - y))


def polygon_form_factor(point, normal, polygon):
    """Lambert's formula: element at point with unit normal to an unoccluded planar polygon
    lying entirely above the element's tangent plane."""
    total = 0.0
    count = len(polygon)
    for i in range(count):
        a = np.asarray(polygon[i], float) - point
        b = np.asarray(polygon[(i + 1) % count], float) - point
        a /= np.linalg.norm(a)
        b /= np.linalg.norm(b)
        g = np.cross(a, b)
        s = np.linalg.norm(g)
        total += math.atan2(s, a @ b) * (normal @ g) / s
    return abs(total) / (2 * math.pi)


def parallel_squares_form_factor(X, Y):
    """Area-to-area: identical directly opposed rectangles, X = a/c, Y = b/c."""
    return 2 / (math.pi * X * Y) * (
        math.log(math.sqrt((1 + X * X) * (1 + Y * Y) / (1 + X * X + Y * Y)))
        + X * math.sqrt(1 + Y * Y) * math.atan(X / math.sqrt(1 + Y * Y))
        + Y * math.sqrt(1 + X * X) * math.atan(Y / math.sqrt(1 + X * X))
        - X * math.atan(X) - Y * math.atan(Y))


def perpendicular_form_factor(W, H):
    """Area-to-area: perpendicular rectangles with a common edge, from width W to height H
    (both divided by the common edge length)."""
    sq = W * W + H * H
    log_term = 0.25 * math.log(
        (1 + W * W) * (1 + H * H) / (1 + sq)
        * (W * W * (1 + sq) / ((1 + W * W) * sq)) ** (W * W)
        * (H * H * (1 + sq) / ((1 + H * H) * sq)) ** (H * H))
    return (W * math.atan(1 / W) + H * math.atan(1 / H)
            - math.sqrt(sq) * math.atan(1 / math.sqrt(sq)) + log_term) / (math.pi * W)


def polygon_form_factors(points, normals, polygon):
    """Lambert's formula for many elements at once: (N, 3) points with unit normals to one
    planar polygon, (K, 3), or to a polygon of their own each, (N, K, 3). Elements in the
    polygon's plane get 0 (a surface does not see itself)."""
    polygon = np.broadcast_to(np.asarray(polygon, float), (len(points),) + np.shape(polygon)[-2:])
    plane = np.cross(polygon[:, 1] - polygon[:, 0], polygon[:, 2] - polygon[:, 0])
    plane /= np.linalg.norm(plane, axis=1, keepdims=True)
    total = np.zeros(len(points))
    for i in range(polygon.shape[1]):
        a = polygon[:, i] - points
        b = polygon[:, (i + 1) % polygon.shape[1]] - points
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        b /= np.linalg.norm(b, axis=1, keepdims=True)
        g = np.cross(a, b)
        s = np.linalg.norm(g, axis=1)
        total += np.arctan2(s, (a * b).sum(axis=1)) * (normals * g).sum(axis=1) / np.maximum(s, 1e-300)
    coplanar = np.abs(((points - polygon[:, 0]) * plane).sum(axis=1)) < 1e-6
    return np.where(coplanar, 0.0, np.abs(total) / (2 * math.pi))


def strip_form_factor(s0, s1):
    """Differential element under an infinite strip of a parallel plane at unit height, from
    s0 to s1 across it (the limit of parallel_rectangle_form_factor along the strip)."""
    return 0.5 * (s1 / np.sqrt(s1 * s1 + 1) - s0 / np.sqrt(s0 * s0 + 1))


@functools.lru_cache(maxsize=None)
def gap_edge_profile(p, cell=0.1, reach=60.0):
    """The light on a plane across the open edge of a facing half-plane at unit height that
    emits 1 (albedo product p: the plane reflects, the half-plane reflects it back), relative
    to the infinite plates' 1 / (1 - p): (x, share) at cell centres, x > 0 under the
    half-plane. Uniform cells over +-reach, Neumann series (bounce after bounce) until it
    settles; beyond reach the plates' values."""
    edges = np.arange(-reach, reach + cell / 2, cell)
    x = 0.5 * (edges[1:] + edges[:-1])
    shooter = x > 0
    to_shooter = strip_form_factor(edges[None, :-1] - x[:, None], edges[None, 1:] - x[:, None])
    plates = 1 / (1 - p)
    beyond = reach - x
    outer = 0.5 * (1 - beyond / np.sqrt(beyond * beyond + 1))   # beyond reach, seen from x
    radiosity = np.ones(shooter.sum())
    irradiance = np.zeros_like(x)
    for _ in range(10000):
        previous = irradiance
        irradiance = to_shooter[:, shooter] @ radiosity + outer * plates
        radiosity = 1 + p * (to_shooter[shooter] @ irradiance + outer[shooter] * plates)
        if np.abs(irradiance - previous).max() < 1e-10:
            break
    return x, irradiance / plates


def gap_edge_deficit(p, cell=0.1, reach=60.0):
    """gap_edge_profile's light missing inside the edge, less what leaks out beside it, in
    gap heights."""
    x, lit = gap_edge_profile(p, cell, reach)
    return float((1 - lit[x > 0]).sum() * cell - lit[x < 0].sum() * cell)


def traced_irradiance(points, normal, quads, radiance, samples=24):
    """E / pi at ``points`` (N, 3) with unit ``normal`` from planar ``quads`` glowing with
    ``radiance`` on both sides, each occluding the others' light: a midpoint quadrature of
    samples x samples points per quad, each ray traced against every quad's two triangles."""
    triangles = [(np.asarray(q[0], float), np.asarray(q[i], float), np.asarray(q[i + 1], float))
                 for q in quads for i in (1, 2)]
    origin = np.array([t[0] for t in triangles])
    edge1 = np.array([t[1] - t[0] for t in triangles])
    edge2 = np.array([t[2] - t[0] for t in triangles])
    u, v = np.meshgrid((np.arange(samples) + 0.5) / samples, (np.arange(samples) + 0.5) / samples)
    u, v = u.reshape(-1, 1), v.reshape(-1, 1)
    values = []
    for point in np.asarray(points, float):
        total = 0.0
        for quad in np.asarray(quads, float):
            at = ((1 - u) * (1 - v) * quad[0] + u * (1 - v) * quad[1] + u * v * quad[2]
                  + (1 - u) * v * quad[3])
            along_u = (1 - v) * (quad[1] - quad[0]) + v * (quad[2] - quad[3])
            along_v = (1 - u) * (quad[3] - quad[0]) + u * (quad[2] - quad[1])
            area_normal = np.cross(along_u, along_v) / samples ** 2
            offset = at - point
            distance = np.linalg.norm(offset, axis=1)
            direction = offset / distance[:, None]
            weight = (np.maximum(direction @ normal, 0.0)
                      * np.abs((direction * area_normal).sum(axis=1)) / distance ** 2)
            # Moller-Trumbore against every triangle; the sample's own one is hit at its end.
            p = np.cross(direction[:, None, :], edge2[None])
            det = (p * edge1[None]).sum(axis=-1)
            safe = np.where(np.abs(det) < 1e-12, 1e-12, det)
            to_point = point - origin
            bu = (p * to_point[None]).sum(axis=-1) / safe
            q = np.cross(to_point, edge1)
            bv = (direction[:, None, :] * q[None]).sum(axis=-1) / safe
            t = (q[None] * edge2[None]).sum(axis=-1) / safe
            hit = ((np.abs(det) > 1e-12) & (bu >= 0) & (bv >= 0) & (bu + bv <= 1)
                   & (t > 0) & (t < distance[:, None] * (1 - 1e-6)))
            total += float((weight * ~hit.any(axis=1)).sum())
        values.append(radiance * total / math.pi)
    return np.array(values)
