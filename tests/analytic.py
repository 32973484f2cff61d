"""Closed-form form factors (../shared/reference/truths.md), in double precision, written
independently of the solver's GLSL."""
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
    planar polygon. Elements in the polygon's plane get 0 (a surface does not see itself)."""
    polygon = np.asarray(polygon, float)
    plane = np.cross(polygon[1] - polygon[0], polygon[2] - polygon[0])
    plane /= np.linalg.norm(plane)
    total = np.zeros(len(points))
    for i in range(len(polygon)):
        a = polygon[i] - points
        b = polygon[(i + 1) % len(polygon)] - points
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        b /= np.linalg.norm(b, axis=1, keepdims=True)
        g = np.cross(a, b)
        s = np.linalg.norm(g, axis=1)
        total += np.arctan2(s, (a * b).sum(axis=1)) * (normals * g).sum(axis=1) / np.maximum(s, 1e-300)
    coplanar = np.abs((points - polygon[0]) @ plane) < 1e-6
    return np.where(coplanar, 0.0, np.abs(total) / (2 * math.pi))
