"""NVIDIA's FLIP image difference evaluator (Andersson et al., "FLIP: A Difference Evaluator for
Alternating Images", HPG 2020), through the flip-evaluator package's LDR-FLIP.

FLIP models what a viewer flipping between two images on a screen notices: a colour pipeline
(spatially filtered by the eye's contrast sensitivity, compared in Hunt-adjusted L*a*b* with the
HyAB distance) and a feature pipeline (edges and points of the luminance), combined into a
per-pixel error in [0, 1]; 0 is no visible difference.

Inputs are display images: float arrays (H, W, 3) of sRGB-encoded values in [0, 1], what a
screen shows. The observer is set by pixels per degree of visual angle; pixels_per_degree()
derives it from the field of view the image spans, as perceptual.py's Yee metric is set.
"""
from dataclasses import dataclass
import math

import flip_evaluator
import numpy as np

from .perceptual import rgb_pair


@dataclass
class FlipDifference:
    mean: float  # FLIP's mean error over the image
    error: np.ndarray  # (H, W) float32 in [0, 1]
    heatmap: np.ndarray  # (H, W, 3) float32 magma colours in [0, 1]


def pixels_per_degree(width_pixels, fov_degrees):
    """Pixels per degree at the centre of an image whose width an observer sees under
    fov_degrees: width / degrees(2 tan(fov / 2)), as pdiff (our Yee metric) and FLIP's own
    viewing-condition formula compute it, so both metrics assume one viewing condition."""
    if width_pixels <= 0 or fov_degrees <= 0:
        raise ValueError(f"width ({width_pixels} px) and field of view ({fov_degrees} degrees) "
                         "must be positive")
    return width_pixels / math.degrees(2.0 * math.tan(math.radians(fov_degrees) * 0.5))


def flip_ldr(reference, test, pixels_per_degree):
    """LDR-FLIP of test against reference, both (H, W, 3) sRGB-encoded display images in [0, 1],
    for an observer at pixels_per_degree."""
    reference, test = rgb_pair(reference, test, np.float32)
    # flip-evaluator answers a bad ppd with sys.exit, which would end Blender.
    if not pixels_per_degree > 0:
        raise ValueError(f"pixels per degree must be positive, got {pixels_per_degree}")
    parameters = {"ppd": float(pixels_per_degree)}
    # The raw map comes back (H, W, 1); the magma one (H, W, 3) from a second evaluation, as
    # the package returns one or the other.
    error, mean, _ = flip_evaluator.evaluate(reference, test, "LDR", inputsRGB=True,
                                             applyMagma=False, computeMeanError=True,
                                             parameters=parameters)
    heatmap, _, _ = flip_evaluator.evaluate(reference, test, "LDR", inputsRGB=True,
                                            applyMagma=True, computeMeanError=False,
                                            parameters=parameters)
    return FlipDifference(mean=float(mean), error=np.asarray(error, dtype=np.float32)[..., 0],
                          heatmap=np.asarray(heatmap, dtype=np.float32))
