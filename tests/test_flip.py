"""LDR-FLIP (native/evaluation/flip.py) against FLIP's colour pipeline written out from the paper and the
reference source, not against the package's own output.

For a constant-colour image FLIP's feature pipeline sees no edges or points (its derivative
filters' weights sum to zero), its colour filters are normalised and it pads by clamping to the
edge, so the spatial filtering leaves the colour as it is at every pixel, borders included. The
error is then FLIP's colour difference alone (Andersson et al., "FLIP: A Difference Evaluator
for Alternating Images", HPG 2020, section 3): sRGB -> linear RGB -> XYZ -> L*a*b* (D65), the
Hunt adjustment, HyAB distance, raised to q_c and compressed by p_c, p_t against cmax.
Constants are those of github.com/NVlabs/flip, flip_evaluator/cpp/FLIP.h (class color3 and
FLIPConstants).
"""
import numpy as np
import pytest

from native.evaluation.flip import FlipDifference, flip_ldr, pixels_per_degree

SIZE = 64
PPD = SIZE / 37.0
# FLIP computes in float32: its error map agrees with the formula to ~1e-7; its mean, summed in
# float32, to ~5e-5 at this size.
TOLERANCE = 1e-5
MEAN_TOLERANCE = 5e-4

# Linear sRGB -> XYZ (D65), the exact fractions FLIP takes from image-engineering.de.
RGB_TO_XYZ = np.array([[10135552 / 24577794, 8788810 / 24577794, 4435075 / 24577794],
                       [2613072 / 12288897, 8788810 / 12288897, 887015 / 12288897],
                       [1425312 / 73733382, 8788810 / 73733382, 70074185 / 73733382]])
# FLIP's reference white: what linear RGB white maps to (its DEFAULT_ILLUMINANT,
# 0.950428545, 1, 1.088900371).
WHITE = RGB_TO_XYZ.sum(axis=1)
Q_C, P_C, P_T = 0.7, 0.4, 0.95

# The first and last colours of matplotlib's magma map, which FLIP's heat map uses.
MAGMA_ZERO = (0.001462, 0.000466, 0.013866)
MAGMA_ONE = (0.987053, 0.991438, 0.749504)


def srgb_to_linear(encoded):
    encoded = np.asarray(encoded, dtype=np.float64)
    return np.where(encoded <= 0.04045, encoded / 12.92, ((encoded + 0.055) / 1.055) ** 2.4)


def hunt_lab(linear):
    """Linear RGB -> CIE L*a*b* (D65) with FLIP's Hunt adjustment: a*, b* scaled by L*/100."""
    t = RGB_TO_XYZ @ np.asarray(linear, dtype=np.float64) / WHITE
    delta = 6.0 / 29.0
    f = np.where(t > delta ** 3, np.cbrt(t), t / (3.0 * delta ** 2) + 4.0 / 29.0)
    lightness = 116.0 * f[1] - 16.0
    a_star, b_star = 500.0 * (f[0] - f[1]), 200.0 * (f[1] - f[2])
    return np.array([lightness, 0.01 * lightness * a_star, 0.01 * lightness * b_star])


def hyab(lab_1, lab_2):
    """HyAB: city-block distance in L*, Euclidean in a*b*."""
    return abs(lab_1[0] - lab_2[0]) + np.hypot(lab_1[1] - lab_2[1], lab_1[2] - lab_2[2])


def colour_error_from_linear(linear_1, linear_2):
    """FLIP's colour difference of two linear RGB colours in [0, 1]."""
    # cmax: the largest difference, between pure green and pure blue.
    cmax = hyab(hunt_lab([0.0, 1.0, 0.0]), hunt_lab([0.0, 0.0, 1.0])) ** Q_C
    difference = hyab(hunt_lab(linear_1), hunt_lab(linear_2)) ** Q_C
    # Differences below p_c cmax take [0, p_t]; the rest are compressed into (p_t, 1].
    if difference < P_C * cmax:
        return difference * P_T / (P_C * cmax)
    return P_T + (difference - P_C * cmax) / (cmax - P_C * cmax) * (1.0 - P_T)


def colour_error(srgb_1, srgb_2):
    """FLIP's error between two constant sRGB-encoded display colours."""
    return colour_error_from_linear(srgb_to_linear(srgb_1), srgb_to_linear(srgb_2))


def uniform(colour):
    return np.broadcast_to(np.asarray(colour, dtype=np.float64), (SIZE, SIZE, 3))


def test_identical_images_have_no_error():
    rng = np.random.default_rng(3)
    image = rng.random((48, 80, 3))
    result = flip_ldr(image, image.copy(), PPD)
    assert isinstance(result, FlipDifference)
    assert result.mean == 0.0
    assert result.error.shape == (48, 80) and result.error.dtype == np.float32
    assert np.all(result.error == 0.0)
    assert result.heatmap.shape == (48, 80, 3) and result.heatmap.dtype == np.float32
    np.testing.assert_allclose(result.heatmap, np.broadcast_to(MAGMA_ZERO, (48, 80, 3)),
                               atol=1e-6)


def test_green_against_blue_is_the_maximum_error():
    result = flip_ldr(uniform([0, 1, 0]), uniform([0, 0, 1]), PPD)
    np.testing.assert_allclose(result.error, 1.0, atol=TOLERANCE)
    np.testing.assert_allclose(result.heatmap, np.broadcast_to(MAGMA_ONE, (SIZE, SIZE, 3)),
                               atol=1e-6)


def test_black_against_white_is_below_the_maximum():
    # HyAB(black, white) = 100, less than green-blue's cmax, so the error lies in (p_t, 1).
    expected = colour_error([0, 0, 0], [1, 1, 1])
    assert P_T < expected < 1.0 - 0.02
    result = flip_ldr(uniform([0, 0, 0]), uniform([1, 1, 1]), PPD)
    np.testing.assert_allclose(result.error, expected, atol=TOLERANCE)
    assert result.mean == pytest.approx(expected, abs=MEAN_TOLERANCE)


PAIRS = [
    ([0.05, 0.05, 0.05], [0.10, 0.10, 0.10]),  # dark greys, where sRGB's curve matters most
    ([0.02, 0.03, 0.05], [0.06, 0.04, 0.03]),  # dark blue-grey against dark brown
    ([0.90, 0.10, 0.10], [0.95, 0.55, 0.10]),  # red against orange
    ([0.50, 0.50, 0.50], [0.55, 0.55, 0.55]),  # mid grey against slightly lighter
]


@pytest.mark.parametrize("reference, test", PAIRS)
def test_uniform_images_match_the_colour_pipeline(reference, test):
    """FLIP is wired to the right inputs: sRGB-encoded display values, the given ppd."""
    expected = colour_error(reference, test)
    result = flip_ldr(uniform(reference), uniform(test), PPD)
    # Clamp-to-edge padding keeps constant images constant to the border.
    np.testing.assert_allclose(result.error, expected, atol=TOLERANCE)
    assert result.mean == pytest.approx(expected, abs=MEAN_TOLERANCE)
    # Symmetric in its arguments.
    assert flip_ldr(uniform(test), uniform(reference), PPD).mean == pytest.approx(
        result.mean, abs=MEAN_TOLERANCE)


def test_the_transfer_curve_matters_for_the_dark_pairs():
    """The pairs are chosen so that mistaking the encoding would fail the test above: taking
    the sRGB values as linear (inputsRGB off), or passing linear values as sRGB."""
    for reference, test in PAIRS[:2]:
        right = colour_error(reference, test)
        values_taken_as_linear = colour_error_from_linear(reference, test)
        linear_passed_as_srgb = colour_error(srgb_to_linear(reference), srgb_to_linear(test))
        assert abs(values_taken_as_linear - right) > 0.04
        assert abs(linear_passed_as_srgb - right) > 0.04


def test_rejects_mismatched_or_non_rgb_images():
    with pytest.raises(ValueError, match="shape"):
        flip_ldr(np.zeros((8, 8, 3)), np.zeros((8, 9, 3)), PPD)
    with pytest.raises(ValueError, match="RGB"):
        flip_ldr(np.zeros((8, 8, 4)), np.zeros((8, 8, 4)), PPD)
    with pytest.raises(ValueError, match="pixels per degree"):
        flip_ldr(np.zeros((8, 8, 3)), np.zeros((8, 8, 3)), 0.0)


def test_pixels_per_degree():
    # 37 degrees span 2 tan(18.5 degrees) = 0.6692 radians = 38.34 degrees of tangent.
    assert pixels_per_degree(512, 37.0) == pytest.approx(512 / 38.3418, rel=1e-5)
    with pytest.raises(ValueError):
        pixels_per_degree(512, 0.0)
    with pytest.raises(ValueError):
        pixels_per_degree(0, 37.0)
