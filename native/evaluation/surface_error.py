"""The error a renderer shows: a lightmap looked up where a renderer looks it up, at points on
the surfaces through bilinear filtering, against a reference's values at the same points (a
reference baked into the same UVs, or a closed form). The texel-by-texel measure
(texel_error.py) counts every occupied texel alike, a chart's border texels that a sliver of
surface touches among them, and none of what filtering mixes in across a border; this one
weighs surface, as a camera sees it."""
from dataclasses import dataclass

import numpy as np


@dataclass
class SurfacePoints:
    """Points on the charted surface, spread evenly over its area."""
    page: np.ndarray      # (N,) the page each lies on
    texel: np.ndarray     # (N, 2) where on its page, in texels (texel i spans [i, i + 1))
    position: np.ndarray  # (N, 3) where in the scene
    triangle: np.ndarray  # (N,) the index of its triangle in the arrays it was drawn from


@dataclass
class SurfaceError:
    rms: float            # root mean square length of the RGB difference over the points
    relative_rms: float   # rms divided by reference_rms
    reference_rms: float  # the reference's root mean square RGB length over the points
    points: int


def surface_points(corners, texels, pages, *, count, inset, seed=0):
    """``count`` random points over the triangles (``corners`` (T, 3, 3) in the scene,
    ``texels`` (T, 3, 2) their lightmap corners in texels, ``pages`` (T,)), evenly by area
    over the part of each triangle at least ``inset`` from its edges: off chart borders,
    where filtering mixes in a chart's padding. That part is the triangle shrunk about its
    incentre; triangles narrower than 2 x inset hold none."""
    corners = np.asarray(corners, dtype=np.float64)
    texels = np.asarray(texels, dtype=np.float64)
    # Edge k is opposite corner k; its length weighs corner k in the incentre.
    edges = np.linalg.norm(np.roll(corners, -1, axis=1) - np.roll(corners, 1, axis=1), axis=2)
    perimeter = edges.sum(axis=1)
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                         corners[:, 2] - corners[:, 0]), axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        inradius = np.where(perimeter > 0, 2.0 * area / perimeter, 0.0)
        scale = np.where(inradius > inset, 1.0 - inset / inradius, 0.0)
    kept_area = area * scale ** 2
    if kept_area.sum() <= 0:
        raise ValueError(f"no triangle is wider than twice the inset ({inset})")
    rng = np.random.default_rng(seed)
    triangle = rng.choice(len(corners), size=count, p=kept_area / kept_area.sum())
    # Uniform barycentrics in the shrunk triangle, taken back to the whole triangle's.
    s, t = rng.random(count), rng.random(count)
    flip = s + t > 1.0
    s[flip], t[flip] = 1.0 - s[flip], 1.0 - t[flip]
    shrunk = np.stack([1.0 - s - t, s, t], axis=1)
    incentre = edges[triangle] / perimeter[triangle, None]
    weights = incentre + scale[triangle, None] * (shrunk - incentre)
    return SurfacePoints(page=np.asarray(pages)[triangle],
                         texel=np.einsum("nk,nkc->nc", weights, texels[triangle]),
                         position=np.einsum("nk,nkc->nc", weights, corners[triangle]),
                         triangle=triangle)


def look_up(pages, points):
    """Each point's RGB from its page (H, W, 3 or 4), filtered bilinearly between the four
    nearest texel centres with the edge clamped, as a GPU samples a lightmap."""
    values = np.zeros((len(points.page), 3))
    for page_index in np.unique(points.page):
        page = np.asarray(pages[page_index], dtype=np.float64)[..., :3]
        height, width = page.shape[:2]
        chosen = points.page == page_index
        x = points.texel[chosen, 0] - 0.5
        y = points.texel[chosen, 1] - 0.5
        x0, y0 = np.floor(x), np.floor(y)
        fx, fy = (x - x0)[:, None], (y - y0)[:, None]
        x0, y0 = x0.astype(int), y0.astype(int)
        left, right = np.clip(x0, 0, width - 1), np.clip(x0 + 1, 0, width - 1)
        low, high = np.clip(y0, 0, height - 1), np.clip(y0 + 1, 0, height - 1)
        values[chosen] = ((page[low, left] * (1 - fx) + page[low, right] * fx) * (1 - fy)
                          + (page[high, left] * (1 - fx) + page[high, right] * fx) * fy)
    return values


def surface_error(values, reference_values):
    """The RMS of the RGB difference over the points, and relative to the reference's RMS."""
    values = np.asarray(values, dtype=np.float64)
    reference_values = np.asarray(reference_values, dtype=np.float64)
    if len(values) == 0:
        raise ValueError("no surface points to compare")
    rms = float(np.sqrt(np.mean(np.sum((values - reference_values) ** 2, axis=1))))
    reference_rms = float(np.sqrt(np.mean(np.sum(reference_values ** 2, axis=1))))
    return SurfaceError(rms=rms, relative_rms=rms / reference_rms if reference_rms > 0
                        else float("inf"), reference_rms=reference_rms, points=len(values))
