"""Two renders of one view compared the way an observer sees them: both tone-mapped with one
exposure taken from the reference, then Yee's perceptual metric and LDR-FLIP on the 8-bit
display images, with images of where they differ."""
from dataclasses import dataclass
import math

import numpy as np

from .flip import FlipDifference, flip_ldr, pixels_per_degree
from ..output import tone_map
from .perceptual import PerceptualDifference, compare

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
MIDDLE_GREY = 0.18        # the log-average luminance of the reference is shown as this
FAILED_COLOUR = np.array([255, 0, 0], dtype=np.uint8)


@dataclass
class ViewComparison:
    reference_display: np.ndarray   # (H, W, 3) uint8 sRGB, top row first
    test_display: np.ndarray
    yee: PerceptualDifference
    flip: FlipDifference
    exposure: float


def exposure_for(reference):
    """Exposure that shows the log-average luminance of the lit pixels as middle grey (a
    black image gets 1)."""
    luminance = np.asarray(reference, dtype=np.float64)[..., :3] @ LUMINANCE
    lit = luminance[luminance > 1e-6]
    if lit.size == 0:
        return 1.0
    return MIDDLE_GREY / math.exp(float(np.log(lit).mean()))


def compare_views(reference, test, fov_degrees=37.0, pixel_threshold=0.012):
    """``reference`` and ``test``: linear radiance (H, W, 3+), top row first."""
    reference = np.asarray(reference, dtype=np.float64)[..., :3]
    test = np.asarray(test, dtype=np.float64)[..., :3]
    if reference.shape != test.shape:
        raise ValueError(f"views differ in size: {reference.shape[:2]} and {test.shape[:2]}")
    exposure = exposure_for(reference)
    reference_display = tone_map(reference, exposure)
    test_display = tone_map(test, exposure)
    a, b = reference_display / 255.0, test_display / 255.0
    yee = compare(a, b, fov_degrees=fov_degrees, pixel_threshold=pixel_threshold)
    flip = flip_ldr(a, b, pixels_per_degree(a.shape[1], fov_degrees))
    return ViewComparison(reference_display, test_display, yee, flip, exposure)


def failure_image(display, failed):
    """The display image in dimmed grey with the failing pixels red."""
    grey = (np.asarray(display, dtype=np.float64) @ LUMINANCE * 0.6).astype(np.uint8)
    image = np.repeat(grey[..., None], 3, axis=2)
    image[failed] = FAILED_COLOUR
    return image
