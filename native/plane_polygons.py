"""Convex polygons in one plane, their corners complex numbers: clipping (Sutherland-Hodgman,
Cyrus-Beck), areas, chords, a texel's square and the share of it under other polygons. The
thin gaps spread a shooter's light over the receivers' texel squares with them: a few dozen
operations per texel, where numpy's per-call cost would dominate."""
from dataclasses import dataclass

import numpy as np

from .geometry import tangents_of


def square(centre, half_t, half_b):
    """A texel's square around ``centre`` with half edges ``half_t`` and ``half_b``, as
    complex corners."""
    return [centre - half_t - half_b, centre + half_t - half_b,
            centre + half_t + half_b, centre - half_t + half_b]


def square_halves(normal, side, t, b):
    """Half of each texel's square edges (N,) x 2, along the shaders' tangent_of() of its
    ``normal`` and the bitangent, as complex coordinates along t and b."""
    tangent = tangents_of(normal)
    bitangent = np.cross(normal, tangent)
    return tuple(0.5 * side * (edge @ t + 1j * (edge @ b)) for edge in (tangent, bitangent))


def clipped(polygon, outline):
    """The part of a polygon inside the convex ``outline``, both complex corners in one plane
    (Sutherland-Hodgman)."""
    turn = _turn(outline)
    for a, b in zip(outline, outline[1:] + outline[:1]):
        if not polygon:
            break
        direction, kept = b - a, []
        for p, q in zip(polygon, polygon[1:] + polygon[:1]):
            dp, dq = turn * _cross(direction, p - a), turn * _cross(direction, q - a)
            if dp >= 0.0:
                kept.append(p)
            if (dp >= 0.0) != (dq >= 0.0):
                kept.append(p + (q - p) * (dp / (dp - dq)))
        polygon = kept
    return polygon


def clipped_segment(a, b, outline):
    """The part (a, b) of the segment from a to b inside the convex ``outline``, or None
    (Cyrus-Beck)."""
    turn = _turn(outline)
    low, high = 0.0, 1.0
    for c, d in zip(outline, outline[1:] + outline[:1]):
        direction = d - c
        at_a, along = turn * _cross(direction, a - c), turn * _cross(direction, b - a)
        if along == 0.0:
            if at_a < 0.0:
                return None
        elif along > 0.0:
            low = max(low, -at_a / along)
        else:
            high = min(high, -at_a / along)
        if low >= high:
            return None
    return a + (b - a) * low, a + (b - a) * high


def signed_area(polygon):
    """Its area, positive when its corners run counter-clockwise."""
    return 0.5 * sum(_cross(p, q) for p, q in zip(polygon, polygon[1:] + polygon[:1]))


def area(polygon):
    return abs(signed_area(polygon))


@dataclass
class Outlines:
    """Convex polygons (complex corners in one plane) that do not overlap, and their bounding
    boxes, which spare share_under clipping a square against those far from it (a finely
    tessellated ceiling's shooter covers hundreds of triangles)."""
    polygons: list
    low: np.ndarray    # (P, 2) least real and imaginary parts
    high: np.ndarray   # (P, 2) greatest


def outlines_of(polygons):
    corners = [np.array([[p.real, p.imag] for p in polygon]) for polygon in polygons]
    return Outlines(polygons, np.array([c.min(axis=0) for c in corners]).reshape(-1, 2),
                    np.array([c.max(axis=0) for c in corners]).reshape(-1, 2))


def share_under(texel_square, outlines):
    """The share of a texel's square under the Outlines."""
    low = (min(p.real for p in texel_square), min(p.imag for p in texel_square))
    high = (max(p.real for p in texel_square), max(p.imag for p in texel_square))
    overlapping = np.nonzero((outlines.high[:, 0] >= low[0]) & (outlines.low[:, 0] <= high[0])
                             & (outlines.high[:, 1] >= low[1])
                             & (outlines.low[:, 1] <= high[1]))[0]
    covered = sum(area(clipped(texel_square, outlines.polygons[i])) for i in overlapping)
    return min(covered / max(area(texel_square), 1e-30), 1.0)


def chord_lengths(polygon, start, end, offsets):
    """The lengths of the chords of a convex polygon parallel to the segment from ``start``
    to ``end``, at ``offsets`` (an array) to its left, within the strip across the segment."""
    length = abs(end - start)
    turn = (end - start) / length
    # Along the segment and across it, to its left: x + iy.
    local = clipped([(corner - start) / turn for corner in polygon],
                    [complex(0.0, -1e30), complex(length, -1e30), complex(length, 1e30),
                     complex(0.0, 1e30)])
    low, high = np.full(len(offsets), np.inf), np.full(len(offsets), -np.inf)
    for p, q in zip(local, local[1:] + local[:1]):
        if p.imag == q.imag:
            continue
        at = (offsets - p.imag) / (q.imag - p.imag)
        crossing = (at >= 0.0) & (at <= 1.0)
        x = p.real + at * (q.real - p.real)
        low = np.where(crossing, np.minimum(low, x), low)
        high = np.where(crossing, np.maximum(high, x), high)
    return np.where(high > low, high - low, 0.0)


def _turn(outline):
    return 1.0 if signed_area(outline) >= 0.0 else -1.0


def _cross(a, b):
    """Twice the signed area two complex numbers span as plane vectors."""
    return a.real * b.imag - a.imag * b.real
