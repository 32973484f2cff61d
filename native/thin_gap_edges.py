"""The band along a thin gap's open edge, where the gap's light leaks out: solved once per
albedo product on cells that grow away from the edge, what the receiver's plane lacks of the
infinite plates' light there (edge_band) and what its reflection sends out into the room
(edge_escape)."""
import functools

import numpy as np

# The band's cells (edge_band): the finest, at the edge, in gap heights, how much each next
# one grows, and how far they reach each way (the band widens like 1 / sqrt(1 - p): 200 gap
# heights hold it for p = 0, 6,325 for p = 0.999).
BAND_FINEST_CELL = 0.02
BAND_CELL_GROWTH = 1.04
BAND_REACH = 6400.0


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


@functools.lru_cache(maxsize=None)
def edge_escape(p):
    """Across a straight open edge of a thin gap, per band cell: the receiver's irradiance
    there over the infinite plates' (edge_band's lit share) times the share of its reflection
    that misses the shooter's half-plane and leaves the gap (1/2 - seen: Lambert's law between
    parallel planes, integrated along the edge). Times the receiver's albedo, it is what the
    receiver's plane reflects out into the room there."""
    centres, _ = band_cells()
    lit = np.where(centres > 0.0, 1.0, 0.0) - edge_band(p)
    return lit * (0.5 - 0.5 * centres / np.sqrt(centres * centres + 1.0))


def edge_deficit(p):
    """The light a straight open edge of a thin gap loses, in gap heights: edge_band summed
    across the edge. 0 for p = 0: the direct light missing inside the edge falls just outside
    it."""
    centres, widths = band_cells()
    return float((edge_band(p) * widths).sum())


_BAND_EDGES = _band_cell_edges()
_BAND_CELLS = (0.5 * (_BAND_EDGES[1][1:] + _BAND_EDGES[1][:-1]), np.diff(_BAND_EDGES[1]))
