"""Thin gaps between facing surfaces (a lamp 1 cm under a ceiling): the plane geometry that
spreads a shooter's light over the receivers' texel squares, and the band along a gap's open
edge where its light leaks out. Points in the shooter's plane are complex numbers: a few dozen
operations per texel, where numpy's per-call cost would dominate."""
import functools
import math

import numpy as np

# The band's cells (edge_band): the finest, at the edge, in gap heights, how much each next
# one grows, and how far they reach each way (the band widens like 1 / sqrt(1 - p): 200 gap
# heights hold it for p = 0, 6,325 for p = 0.999).
BAND_FINEST_CELL = 0.02
BAND_CELL_GROWTH = 1.04
BAND_REACH = 6400.0


def square(centre, half_t, half_b):
    """A texel's square around ``centre`` with half edges ``half_t`` and ``half_b``, as
    complex corners."""
    return [centre - half_t - half_b, centre + half_t - half_b,
            centre + half_t + half_b, centre - half_t + half_b]


def square_halves(normal, side, t, b):
    """Half of each texel's square edges (N,) x 2, along the shaders' tangent_of() of its
    ``normal`` and the bitangent, as complex coordinates along t and b."""
    axis = np.eye(3)[np.argmin(np.abs(normal), axis=1)]
    tangent = axis - normal * (axis * normal).sum(axis=1, keepdims=True)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
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


def share_under(texel_square, outlines):
    """The share of a texel's square under the convex ``outlines``, which do not overlap."""
    covered = sum(area(clipped(texel_square, outline)) for outline in outlines)
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


def band_cells():
    """The band's cells across an open edge, in gap heights: centres (positive inside, under
    the shooter) and widths. Wide enough for albedo products up to 0.999."""
    return _BAND_CELLS


def _band_cell_edges():
    steps, cell = [0.0], BAND_FINEST_CELL
    while steps[-1] < BAND_REACH:
        steps.append(steps[-1] + cell)
        cell *= BAND_CELL_GROWTH
    inside = np.array(steps)
    return inside, np.concatenate([-inside[:0:-1], inside])


@functools.lru_cache(maxsize=None)
def edge_band(p):
    """Across a straight open edge of a thin gap, per band cell: the share of the infinite
    plates' light the receiver's plane lacks there (1 - E / E_plates inside the edge, minus
    E / E_plates outside it: the light leaking out), for receiver and shooter albedos whose
    product is ``p``.

    Between the receiver's plane and a shooter's half-plane (s > 0) a gap height of 1 away,
    the shooter emitting 1: E(x) = int K(x - y) B(y) dy over y > 0 and B(y) = 1 + p int
    K(y - x) E(x) dx over all x, K(s) = 1/2 (s^2 + 1)^(-3/2) (Lambert's law between parallel
    planes, integrated along the edge); far inside, E = 1 / (1 - p). Solved on cells that grow
    away from the edge, each cell's kernel integrated exactly."""
    inside, receiver = _BAND_EDGES
    x, y = 0.5 * (receiver[1:] + receiver[:-1]), 0.5 * (inside[1:] + inside[:-1])
    seen = lambda s: 0.5 * s / np.sqrt(s * s + 1.0)     # int K from 0 to s
    to_shooter = seen(inside[None, 1:] - x[:, None]) - seen(inside[None, :-1] - x[:, None])
    to_receiver = seen(receiver[None, 1:] - y[:, None]) - seen(receiver[None, :-1] - y[:, None])
    plates = 1.0 / (1.0 - p)
    count_x, count_y = len(x), len(y)
    system = np.eye(count_x + count_y)
    system[:count_x, count_x:] = -to_shooter
    system[count_x:, :count_x] = -p * to_receiver
    # Beyond the cells the shooter and the receiver's inside hold the plates' values.
    known = np.concatenate([(0.5 - seen(inside[-1] - x)) * plates,
                            1.0 + p * (0.5 - seen(receiver[-1] - y)) * plates])
    lit = np.linalg.solve(system, known)[:count_x] / plates
    return np.where(x > 0.0, 1.0 - lit, -lit)


def edge_deficit(p):
    """The light a straight open edge of a thin gap loses, in gap heights: edge_band summed
    across the edge. 0 for p = 0: the direct light missing inside the edge falls just outside
    it."""
    centres, widths = band_cells()
    return float((edge_band(p) * widths).sum())


def _turn(outline):
    return 1.0 if signed_area(outline) >= 0.0 else -1.0


def _cross(a, b):
    """Twice the signed area two complex numbers span as plane vectors."""
    return a.real * b.imag - a.imag * b.real


_BAND_EDGES = _band_cell_edges()
_BAND_CELLS = (0.5 * (_BAND_EDGES[1][1:] + _BAND_EDGES[1][:-1]), np.diff(_BAND_EDGES[1]))
