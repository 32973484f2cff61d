"""The error a renderer shows: a lightmap looked up where a renderer looks it up, at points on
the surfaces through bilinear filtering, against a reference's values at the same points (a
reference baked into the same UVs, or a closed form). The texel-by-texel measure
(texel_error.py) counts every occupied texel alike, a chart's border texels that a sliver of
surface touches among them, and none of what filtering mixes in across a border; this one
weighs surface, as a camera sees it."""
from dataclasses import dataclass

import numpy as np

from ..geometry import unique_rows


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


# A corner's texel position this close (in texels) to the same corner's in the triangle
# across an edge: the edge lies inside one chart (float32 UV maps round at about 1e-4).
SAME_TEXEL = 1e-3
# Candidates drawn per point wanted, per round of surface_points' rejection sampling.
DRAWS_PER_POINT = 2


def surface_points(corners, texels, pages, *, count, inset, seed=0):
    """``count`` random points over the triangles (``corners`` (T, 3, 3) in the scene,
    ``texels`` (T, 3, 2) their lightmap corners in texels, ``pages`` (T,)), evenly by area
    over the surface at least ``inset`` from the charts' borders, where filtering mixes in a
    chart's padding. A border is an edge that not exactly two triangles share with the same
    page and texels at its ends (chart_borders); the edges inside a chart are no border, so
    a curved surface of facets narrower than 2 x inset (a cable, a column) holds points."""
    corners = np.asarray(corners, dtype=np.float64)
    texels = np.asarray(texels, dtype=np.float64)
    pages = np.asarray(pages)
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                         corners[:, 2] - corners[:, 0]), axis=1)
    if area.sum() <= 0:
        raise ValueError("no triangle has area to hold surface points")
    borders = BorderGrid(corners, chart_borders(corners, texels, pages), inset)
    rng = np.random.default_rng(seed)
    kept = []
    found, drawn = 0, 0
    while found < count:
        draws = DRAWS_PER_POINT * count
        triangle = rng.choice(len(corners), size=draws, p=area / area.sum())
        s, t = rng.random(draws), rng.random(draws)
        flip = s + t > 1.0
        s[flip], t[flip] = 1.0 - s[flip], 1.0 - t[flip]
        weights = np.stack([1.0 - s - t, s, t], axis=1)
        position = np.einsum("nk,nkc->nc", weights, corners[triangle])
        clear = borders.distance(position) >= inset
        kept.append((triangle[clear], weights[clear]))
        found += int(clear.sum())
        drawn += draws
        if found == 0 and drawn >= 32 * DRAWS_PER_POINT * count:
            raise ValueError(f"no surface lies more than the inset ({inset}) inside the "
                             f"charts' borders")
    triangle = np.concatenate([rows for rows, _ in kept])[:count]
    weights = np.concatenate([values for _, values in kept])[:count]
    return SurfacePoints(page=pages[triangle],
                         texel=np.einsum("nk,nkc->nc", weights, texels[triangle]),
                         position=np.einsum("nk,nkc->nc", weights, corners[triangle]),
                         triangle=triangle)


def chart_borders(corners, texels, pages):
    """Which edges of each triangle are a chart's border, (T, 3) bool (edge k from corner k
    to corner k + 1): an edge is inside a chart where exactly two triangles share its ends
    (equal coordinates) on the same page at the same texels."""
    count = len(corners)
    _, vertex = unique_rows(corners.reshape(-1, 3), return_inverse=True)
    vertex = vertex.reshape(count, 3)
    start, end = vertex, np.roll(vertex, -1, axis=1)
    low, high = np.minimum(start, end).ravel(), np.maximum(start, end).ravel()
    # Each edge's texels at its lower-numbered end first, so that both sides compare alike.
    texel_start, texel_end = texels, np.roll(texels, -1, axis=1)
    swapped = (start > end)[..., None]
    ends = np.concatenate([np.where(swapped, texel_end, texel_start),
                           np.where(swapped, texel_start, texel_end)], axis=2).reshape(-1, 4)
    _, edge, shared_by = unique_rows(np.stack([low, high], axis=1), return_inverse=True,
                                     return_counts=True)
    order = np.argsort(edge, kind="stable")
    first = np.cumsum(shared_by) - shared_by
    pairs = np.nonzero(shared_by == 2)[0]
    one, other = order[first[pairs]], order[first[pairs] + 1]
    page = np.repeat(pages, 3)
    matched = ((page[one] == page[other])
               & (np.abs(ends[one] - ends[other]).max(axis=1) <= SAME_TEXEL))
    inside = np.zeros(count * 3, dtype=bool)
    inside[one[matched]] = inside[other[matched]] = True
    return ~inside.reshape(count, 3)


class BorderGrid:
    """The charts' border edges cut into pieces no longer than ``reach``, filed by the
    cell of a grid their middles lie in, for the distance of points to the nearest border
    within ``reach`` (a piece within reach of a point has its middle within 1.5 x reach,
    one cell of that size, of it)."""

    def __init__(self, corners, border_edge, reach):
        starts = corners[border_edge]
        ends = np.roll(corners, -1, axis=1)[border_edge]
        pieces = np.maximum(np.ceil(np.linalg.norm(ends - starts, axis=1) / reach), 1)
        pieces = pieces.astype(np.int64)
        edge = np.repeat(np.arange(len(starts)), pieces)
        at = np.arange(len(edge)) - np.repeat(np.cumsum(pieces) - pieces, pieces)
        step = (ends - starts)[edge] / pieces[edge, None]
        self.starts = starts[edge] + at[:, None] * step
        self.steps = step
        self.cell = 1.5 * reach
        self.origin = corners.reshape(-1, 3).min(axis=0) - 2 * self.cell
        self.shape = np.floor((corners.reshape(-1, 3).max(axis=0) - self.origin)
                              / self.cell).astype(np.int64) + 3
        keys = self._keys(self._cells(self.starts + 0.5 * self.steps))
        self.order = np.argsort(keys, kind="stable")
        self.sorted_keys = keys[self.order]

    def _cells(self, points):
        return np.floor((points - self.origin) / self.cell).astype(np.int64)

    def _keys(self, cells):
        return (cells[:, 0] * self.shape[1] + cells[:, 1]) * self.shape[2] + cells[:, 2]

    def distance(self, points):
        """Each point's distance to the nearest border piece whose middle lies in its cell
        or one next to it (inf where none does): exact up to ``reach``."""
        nearest = np.full(len(points), np.inf)
        cells = self._cells(points)
        for offset in np.stack(np.meshgrid(*[(-1, 0, 1)] * 3), axis=-1).reshape(-1, 3):
            keys = self._keys(cells + offset)
            low = np.searchsorted(self.sorted_keys, keys, side="left")
            found = np.searchsorted(self.sorted_keys, keys, side="right") - low
            if not found.any():
                continue
            point = np.repeat(np.arange(len(points)), found)
            piece = self.order[np.repeat(low, found) + np.arange(len(point))
                               - np.repeat(np.cumsum(found) - found, found)]
            start, step = self.starts[piece], self.steps[piece]
            along = np.clip(np.einsum("nc,nc->n", points[point] - start, step)
                            / np.maximum(np.einsum("nc,nc->n", step, step), 1e-300), 0.0, 1.0)
            gap = np.linalg.norm(points[point] - (start + along[:, None] * step), axis=1)
            np.minimum.at(nearest, point, gap)
        return nearest


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
