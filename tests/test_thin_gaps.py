"""The thin gaps' plane geometry (native/plane_polygons.py) and edge band
(native/thin_gap_edges.py) against independent truths: areas and lengths in closed form,
Lambert's form factor, and the band solved by a different method (analytic.gap_edge_deficit:
uniform cells, bounce after bounce)."""
import math

import pytest

import analytic
import numpy as np

from native.plane_polygons import (area, chord_lengths, clipped, clipped_segment, outlines_of,
                                   share_under, signed_area, square)
from native.thin_gap_edges import band_cells, edge_band, edge_deficit, edge_escape

UNIT_SQUARE = square(0.5 + 0.5j, 0.5, 0.5j)


def test_a_triangle_over_half_a_square_covers_half():
    assert share_under(UNIT_SQUARE, outlines_of([[0j, 1 + 0j, 1 + 1j]])) == pytest.approx(0.5)
    # Wound the other way, and reaching past the square.
    assert share_under(UNIT_SQUARE,
                       outlines_of([[-1 - 1j, 2 + 2j, 2 - 1j]])) == pytest.approx(0.5)
    assert share_under(UNIT_SQUARE, outlines_of([[2 + 0j, 3 + 0j, 3 + 1j]])) == 0.0
    # Many triangles tiling a strip over the square's left half: each counts once.
    columns = np.arange(-5.0, 0.5, 0.25)
    strip = ([[complex(x, -1), complex(x + 0.25, -1), complex(x + 0.25, 2)] for x in columns]
             + [[complex(x, -1), complex(x + 0.25, 2), complex(x, 2)] for x in columns])
    assert share_under(UNIT_SQUARE, outlines_of(strip)) == pytest.approx(0.5)


def test_the_signed_area_tells_the_winding():
    assert signed_area(UNIT_SQUARE) == pytest.approx(1.0)
    assert signed_area(UNIT_SQUARE[::-1]) == pytest.approx(-1.0)


def test_clipping_keeps_the_overlap_of_two_squares():
    overlap = clipped(UNIT_SQUARE, square(1 + 1j, 0.5, 0.5j))
    assert area(overlap) == pytest.approx(0.25)


def test_segments_are_cut_at_the_outline():
    a, b = clipped_segment(-1 + 0.5j, 2 + 0.5j, UNIT_SQUARE)
    assert abs(b - a) == pytest.approx(1.0)
    assert clipped_segment(-1 + 2j, 2 + 2j, UNIT_SQUARE) is None


def test_chords_of_a_square_along_a_diagonal_segment():
    """Chords parallel to the diagonal from (0, 0) to (1, 1), at d to its left: the square's
    chord there is sqrt(2) - 2 |d|, within the segment's strip all of it."""
    offsets = np.array([-0.8, -0.5, -0.25, 0.0, 0.3, 0.7])
    expected = np.clip(math.sqrt(2) - 2 * np.abs(offsets), 0, None)
    np.testing.assert_allclose(chord_lengths(UNIT_SQUARE, 0j, 1 + 1j, offsets), expected,
                               atol=1e-12)
    # A segment along the bottom edge's first half: the strip cuts the chords to 0.5.
    np.testing.assert_allclose(chord_lengths(UNIT_SQUARE, 0j, 0.5 + 0j, offsets),
                               np.where((offsets >= 0) & (offsets <= 1), 0.5, 0.0), atol=1e-12)


def test_the_strip_form_factor_is_the_long_rectangles():
    long_rectangle = analytic.parallel_rectangle_form_factor(0, 0, -1e4, 1e4, 0.3, 0.9, 1.0)
    assert analytic.strip_form_factor(0.3, 0.9) == pytest.approx(long_rectangle, rel=1e-9)


def test_without_bounces_an_edge_loses_no_light():
    """Lambert's law: what the half-plane's direct light misses inside its edge, 1/2 (1 -
    s / sqrt(s^2 + 1)) integrated, is 1/2 gap height, and just as much falls outside."""
    assert abs(edge_deficit(0.0)) < 2e-3


@pytest.mark.parametrize("p", [0.3, 0.5655, 0.8])
def test_the_edge_band_matches_the_bounce_after_bounce_solution(p):
    """Measured 0.7-1.2 % apart (the light beyond the other's 60 gap heights)."""
    assert edge_deficit(p) == pytest.approx(analytic.gap_edge_deficit(p), rel=0.02)


def test_the_edge_band_across_the_edge_matches_the_bounce_after_bounce_profile():
    x, lit = analytic.gap_edge_profile(0.5655)
    centres, _ = band_cells()
    for at in (-2.0, -0.5, 0.25, 1.0, 3.0):
        expected = (at > 0) - np.interp(at, x, lit)
        assert np.interp(at, centres, edge_band(0.5655)) == pytest.approx(expected, abs=0.01)


def test_without_bounces_the_light_leaving_an_edge_is_a_quarter_pi_gap_heights():
    """The receiver's plane beside a half-plane emitting 1 gets 1/2 + seen(x) and reflects
    1/2 - seen(x) of it past the half-plane: (1/4 - seen^2) = 1/4 / (1 + x^2) integrated
    across the edge is pi / 4 gap heights."""
    centres, widths = band_cells()
    assert (edge_escape(0.0) * widths).sum() == pytest.approx(math.pi / 4, rel=5e-3)


@pytest.mark.parametrize("p", [0.3, 0.624])
def test_the_light_leaving_an_edge_matches_the_bounce_after_bounce_solution(p):
    """What leaves past the edge, from the receiver's light bounce after bounce: lit(x)
    (1/2 - seen(x)) summed across the edge, over 120 gap heights each way (at 60, 1.1-1.3 %
    was left beyond them)."""
    x, lit = analytic.gap_edge_profile(p, reach=120.0)
    expected = (lit * (0.5 - 0.5 * x / np.sqrt(x * x + 1.0))).sum() * (x[1] - x[0])
    centres, widths = band_cells()
    assert (edge_escape(p) * widths).sum() == pytest.approx(expected, rel=0.01)
