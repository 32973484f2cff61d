"""Yee's perceptual image difference metric (H. Yee, "A Perceptual Metric for Production
Testing", Journal of Graphics Tools 9(4), 2004), following the open-source pdiff
(perceptualdiff) program's Metric.cpp and LPyramid.cpp closely, in pure numpy.

Inputs are display images: float arrays (H, W, 3) of gamma-encoded values in [0, 1], what
pdiff reads as 8-bit RGB divided by 255. Like pdiff they are linearised with a plain power
`gamma` and taken as Adobe RGB (1998), D65, to XYZ; Y times `luminance` gives cd/m^2.

A pixel fails if its luminance difference exceeds the threshold-versus-intensity of its
adaptation luminance, raised by a frequency/masking factor, or if its squared a*b* distance
exceeds that factor (the colour test).
"""
from dataclasses import dataclass
import math

import numpy as np

# pdiff's pyramid: 8 levels, each the previous one blurred by a separable 5-tap filter.
MAX_PYRAMID_LEVELS = 8
PYRAMID_KERNEL = np.array([0.05, 0.25, 0.4, 0.25, 0.05])

# Adobe RGB (1998) -> XYZ, reference white D65 (pdiff's matrix, from brucelindbloom.com).
ADOBE_RGB_TO_XYZ = np.array([[0.576700, 0.185556, 0.188212],
                             [0.297361, 0.627355, 0.0752847],
                             [0.0270328, 0.0706879, 0.991248]])
WHITE_XYZ = ADOBE_RGB_TO_XYZ.sum(axis=1)

# pdiff normalises its frequency weights by the CSF at its peak, 3.248 cycles/degree.
CSF_PEAK_CPD = 3.248


@dataclass
class PerceptualDifference:
    failed_pixels: int
    fraction: float
    failed: np.ndarray  # (H, W) bool: the pixels that fail either test
    different: bool  # fraction > pixel_threshold


def tvi(adaptation_luminance):
    """Threshold-versus-intensity in cd/m^2 (Ward Larson et al., SIGGRAPH 1997, as in pdiff):
    the smallest visible luminance step at the given adaptation luminance."""
    log_a = np.log10(np.asarray(adaptation_luminance, dtype=np.float64))
    # np.select evaluates every branch; clip keeps the fractional powers' bases positive
    # where a branch is not the one chosen.
    log_r = np.select(
        [log_a < -3.94, log_a < -1.44, log_a < -0.0184, log_a < 1.9],
        [np.full_like(log_a, -2.86),
         np.clip(0.405 * log_a + 1.6, 0.0, None) ** 2.18 - 2.86,
         log_a - 0.395,
         np.clip(0.249 * log_a + 0.65, 0.0, None) ** 2.7 - 0.72],
        log_a - 1.255)
    return 10.0 ** log_r


def csf(cycles_per_degree, luminance):
    """Contrast sensitivity (Barten, SPIE 1989, as in pdiff) at a spatial frequency in
    cycles/degree and an adaptation luminance in cd/m^2."""
    a = 440.0 * (1.0 + 0.7 / luminance) ** -0.2
    b = 0.3 * (1.0 + 100.0 / luminance) ** 0.15
    return a * cycles_per_degree * np.exp(-b * cycles_per_degree) \
        * np.sqrt(1.0 + 0.06 * np.exp(b * cycles_per_degree))


def mask(contrast):
    """Visual masking (Daly 1993, as in pdiff): how much a contrast, in units of the
    detection threshold, raises the threshold for seeing a change on top of it."""
    a = (392.498 * contrast) ** 0.7
    return (1.0 + (0.0153 * a) ** 4) ** 0.25


def _blur(image):
    """One pdiff pyramid step: the 5x5 separable filter at full resolution. pdiff reflects
    without repeating the edge pixel at the low edge (-1 -> 1) but repeats it at the high
    edge (W -> W-1); the index arrays reproduce both."""
    result = image
    for axis in (0, 1):
        size = image.shape[axis]
        index = np.abs(np.arange(-2, size + 2))
        index = np.where(index >= size, 2 * size - index - 1, index)
        index = np.clip(index, 0, size - 1)  # only images narrower than 3 px need this
        padded = np.take(result, index, axis=axis)
        result = sum(weight * np.take(padded, np.arange(tap, tap + size), axis=axis)
                     for tap, weight in enumerate(PYRAMID_KERNEL))
    return result


def _pyramid(luminance):
    levels = [luminance]
    for _ in range(MAX_PYRAMID_LEVELS - 1):
        levels.append(_blur(levels[-1]))
    return np.stack(levels)


def _adaptation_level(one_degree_pixels):
    """pdiff's adaptation(): the first pyramid level whose 2**level exceeds the number pdiff
    calls 'one degree pixels', capped at the last level."""
    pixels = 1.0
    for level in range(MAX_PYRAMID_LEVELS):
        if pixels > one_degree_pixels:
            return level
        pixels *= 2.0
    return MAX_PYRAMID_LEVELS - 1


def _down_sample(image):
    """pdiff's down_sample(): 2x2 box average, dropping an odd last row or column."""
    height, width = image.shape[0] // 2 * 2, image.shape[1] // 2 * 2
    image = image[:height, :width]
    return 0.25 * (image[0::2, 0::2] + image[1::2, 0::2] + image[0::2, 1::2] + image[1::2, 1::2])


def _luminance_and_ab(image, gamma, luminance):
    """Luminance in cd/m^2 and CIE L*a*b*'s a*, b* of a display image (pdiff's conversion)."""
    linear = np.clip(image, 0.0, None) ** gamma
    xyz = linear @ ADOBE_RGB_TO_XYZ.T
    ratio = xyz / WHITE_XYZ
    epsilon, kappa = 216.0 / 24389.0, 24389.0 / 27.0
    f = np.where(ratio > epsilon, np.cbrt(ratio), (kappa * ratio + 16.0) / 116.0)
    a_star = 500.0 * (f[..., 0] - f[..., 1])
    b_star = 200.0 * (f[..., 1] - f[..., 2])
    return xyz[..., 1] * luminance, a_star, b_star


def rgb_pair(image_a, image_b, dtype):
    """Two images as C-contiguous ``dtype`` arrays, checked to be (H, W, 3) of one shape."""
    image_a = np.ascontiguousarray(image_a, dtype=dtype)
    image_b = np.ascontiguousarray(image_b, dtype=dtype)
    if image_a.shape != image_b.shape:
        raise ValueError(f"images differ in shape: {image_a.shape} and {image_b.shape}")
    if image_a.ndim != 3 or image_a.shape[2] != 3:
        raise ValueError(f"images must be (H, W, 3) RGB, got shape {image_a.shape}")
    return image_a, image_b


def compare(image_a, image_b, fov_degrees=37.0, gamma=2.2, luminance=100.0, color_factor=1.0,
            downsample=0, pixel_threshold=0.012):
    """Yee's metric between two display images (H, W, 3), gamma-encoded in [0, 1].

    fov_degrees: the horizontal field of view the image spans (pdiff's default is 45; 37 is
    the evaluation's setting, a 17" display seen from 0.5 m). gamma, luminance (cd/m^2 of
    display white), color_factor (0 turns the colour test off) and downsample (halvings before
    comparing) are pdiff's options with pdiff's defaults. pixel_threshold replaces pdiff's
    absolute pixel count: the images are `different` when more than this fraction fails.
    """
    image_a, image_b = rgb_pair(image_a, image_b, np.float64)
    for _ in range(downsample):
        image_a, image_b = _down_sample(image_a), _down_sample(image_b)
    width = image_a.shape[1]

    luminance_a, a_star_a, b_star_a = _luminance_and_ab(image_a, gamma, luminance)
    luminance_b, a_star_b, b_star_b = _luminance_and_ab(image_b, gamma, luminance)
    pyramid_a, pyramid_b = _pyramid(luminance_a), _pyramid(luminance_b)

    # pdiff's viewing geometry, kept as written: the screen's width in degrees-of-tangent
    # (2 tan(fov/2) in radians, converted to degrees) and the pixels it makes per degree.
    one_degree_pixels = math.degrees(2.0 * math.tan(math.radians(fov_degrees) * 0.5))
    pixels_per_degree = width / one_degree_pixels
    level = _adaptation_level(one_degree_pixels)
    # Local adaptation luminance: the mean of both images at a coarse pyramid level.
    adaptation = np.maximum(0.5 * (pyramid_a[level] + pyramid_b[level]), 1e-5)

    # Band i (difference of levels i and i+1) holds frequencies around cpd[i]; the finest
    # band is at the Nyquist frequency and each level halves it.
    bands = MAX_PYRAMID_LEVELS - 2
    cycles_per_degree = 0.5 * pixels_per_degree * 0.5 ** np.arange(bands)
    # F_freq: 1 at the CSF's peak, larger where the eye is less sensitive.
    frequency_weight = csf(CSF_PEAK_CPD, 100.0) / csf(cycles_per_degree, 100.0)

    factor = np.zeros_like(adaptation)
    sum_contrast = np.zeros_like(adaptation)
    for band in range(bands):
        # Band contrast: the stronger of the two images' band amplitude over the local mean.
        numerator = np.maximum(np.abs(pyramid_a[band] - pyramid_a[band + 1]),
                               np.abs(pyramid_b[band] - pyramid_b[band + 1]))
        denominator = np.maximum(np.maximum(np.abs(pyramid_a[band + 2]),
                                            np.abs(pyramid_b[band + 2])), 1e-5)
        contrast = numerator / denominator
        masking = mask(contrast * csf(cycles_per_degree[band], adaptation))
        factor += contrast * frequency_weight[band] * masking
        sum_contrast += contrast
    # Contrast-weighted mean of F_freq * F_mask over the bands, clamped to [1, 10] as pdiff.
    factor = np.clip(factor / np.maximum(sum_contrast, 1e-5), 1.0, 10.0)

    luminance_failed = np.abs(pyramid_a[0] - pyramid_b[0]) > factor * tvi(adaptation)
    # Colour test: squared a*b* distance against the same factor; pdiff drops it entirely
    # where adaptation is below 10 cd/m^2 (scotopic vision sees no colour).
    color_scale = np.where(adaptation < 10.0, 0.0, color_factor)
    delta_e = ((a_star_a - a_star_b) ** 2 + (b_star_a - b_star_b) ** 2) * color_scale
    failed = luminance_failed | (delta_e > factor)

    failed_pixels = int(failed.sum())
    fraction = failed_pixels / failed.size
    return PerceptualDifference(failed_pixels=failed_pixels, fraction=fraction, failed=failed,
                                different=fraction > pixel_threshold)
