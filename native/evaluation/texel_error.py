"""Lightmap error measures against a reference (the paper's eq. 1 and its relatives) and
false-colour error maps. Pages are (H, W, 4) float arrays, RGB plus a mask in alpha."""
from dataclasses import dataclass

import numpy as np

NORMAL_MEDIAN_ABSOLUTE = 0.6744897501960817  # median of |x| for a standard normal x


@dataclass
class LightmapError:
    rms: float        # eq. 1: root mean square length of the RGB difference
    relative_rms: float  # rms divided by reference_rms
    max_error: float  # largest RGB difference length
    texels: int       # texels compared
    reference_rms: float  # the reference's root mean square RGB length over those texels


def lightmap_error(pages, reference_pages):
    """Compare over the texels both masks hold (alpha > 0.5 in a page and its reference)."""
    squares = reference_squares = 0.0
    largest = 0.0
    count = 0
    for page, reference in zip(pages, reference_pages, strict=True):
        if page.shape != reference.shape:
            raise ValueError(f"a lightmap is {page.shape[:2]} but its reference "
                             f"{reference.shape[:2]}")
        both = (page[..., 3] > 0.5) & (reference[..., 3] > 0.5)
        rgb = reference[..., :3][both].astype(np.float64)
        lengths = np.linalg.norm(page[..., :3][both].astype(np.float64) - rgb, axis=1)
        squares += float((lengths ** 2).sum())
        reference_squares += float((rgb ** 2).sum())
        largest = max(largest, float(lengths.max(initial=0.0)))
        count += int(both.sum())
    if count == 0:
        raise ValueError("the lightmaps and their reference share no texel")
    rms = (squares / count) ** 0.5
    reference_rms = (reference_squares / count) ** 0.5
    return LightmapError(rms, rms / reference_rms if reference_rms > 0 else float("inf"),
                         largest, count, reference_rms)


def error_map(page, reference, scale):
    """False colour of the RGB difference length per texel: black at 0 through blue, green
    and yellow to white at ``scale`` and above; texels outside either mask are grey."""
    both = (page[..., 3] > 0.5) & (reference[..., 3] > 0.5)
    length = np.linalg.norm(page[..., :3].astype(np.float64) - reference[..., :3], axis=2)
    t = np.clip(length / scale, 0.0, 1.0)[..., None]
    stops = np.array([[0, 0, 0], [0, 0, 1], [0, 1, 0], [1, 1, 0], [1, 1, 1]], dtype=np.float64)
    position = t * (len(stops) - 1)
    lower = np.minimum(position.astype(int), len(stops) - 2)[..., 0]
    blend = position[..., 0] - lower
    colour = stops[lower] * (1 - blend)[..., None] + stops[lower + 1] * blend[..., None]
    colour[~both] = 0.5
    return np.concatenate([colour, np.ones(colour.shape[:2] + (1,))], axis=2).astype(np.float32)


def texel_noise(page, mask):
    """Estimated per-channel standard deviation (3,) of independent per-texel noise over the
    texels in ``mask``, from second differences d = a - 2b + c of three masked texels in a row
    or column: lighting that is linear across three texels cancels, and independent noise of
    deviation s gives d a deviation of s sqrt(6). The median of |d| (0.6745 deviations for
    normal noise) keeps the shadow edges and light borders, a small share of the triples, from
    counting as noise. NaN without any such triple. What a Monte Carlo reference's own noise
    adds to an error measured against it."""
    rgb = np.asarray(page, dtype=np.float64)[..., :3]
    differences = []
    for axis in (0, 1):
        length = rgb.shape[axis]
        if length < 3:
            continue
        a, b, c = (np.take(rgb, range(k, length - 2 + k), axis=axis) for k in range(3))
        all_three = (np.take(mask, range(0, length - 2), axis=axis)
                     & np.take(mask, range(1, length - 1), axis=axis)
                     & np.take(mask, range(2, length), axis=axis))
        differences.append((a - 2.0 * b + c)[all_three])
    differences = np.concatenate(differences) if differences else np.zeros((0, 3))
    if len(differences) == 0:
        return np.full(3, np.nan)
    return np.median(np.abs(differences), axis=0) / (NORMAL_MEDIAN_ABSOLUTE * np.sqrt(6.0))
