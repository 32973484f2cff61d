"""Geometry the stages share, on numpy arrays: triangles' planes and bounds, smooth
surfaces, frames and tangents, texel spans and texel-to-world maps of charts, and shooter
quads."""
from dataclasses import dataclass
import math

import numpy as np

# Edges bending less than this join triangles into one smooth surface (see smooth_surfaces).
SMOOTH_SURFACE_DEGREES = 40.0


class TrianglePlanes:
    """Planes and bounds of triangles ((T, 3, 3) corners), and which of them meet a box."""

    def __init__(self, corners):
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        self.normals = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-30)
        self.offsets = (self.normals * corners[:, 0]).sum(axis=1)
        self.corners = corners
        self.low, self.high = corners.min(axis=1), corners.max(axis=1)
        self.centres = corners.mean(axis=1)
        self.radii = np.linalg.norm(corners - self.centres[:, None], axis=2).max(axis=1)
        # Looked up among the smaller 95 % sorted by x, plus the largest 5 % always: a lookup
        # then tests hundreds of triangles, not the whole scene.
        self._reach = float(np.quantile(self.radii, 0.95)) if len(self.radii) else 0.0
        small = self.radii <= self._reach
        self._small = np.nonzero(small)[0][np.argsort(self.centres[small, 0])]
        self._small_x = self.centres[self._small, 0]
        self._large = np.nonzero(~small)[0]

    def within(self, low, high):
        """The triangles whose bounds meet the box from ``low`` to ``high``."""
        first, last = np.searchsorted(self._small_x, [low[0] - self._reach,
                                                      high[0] + self._reach])
        candidates = np.concatenate([self._small[first:last], self._large])
        return candidates[(self.low[candidates] <= high).all(axis=1)
                          & (self.high[candidates] >= low).all(axis=1)]


def unique_rows(rows, *, return_index=False, return_inverse=False, return_counts=False):
    """np.unique(rows, axis=0, ...) (the distinct rows in lexicographic order, and the first
    index, inverse and counts asked for), by a stable lexsort of the columns: numpy's sorts
    each row as one opaque item, several times slower over a big mesh's corners."""
    rows = np.asarray(rows)
    order = np.lexsort(rows.T[::-1])
    ordered = rows[order]
    starts = np.ones(len(rows), dtype=bool)
    starts[1:] = (ordered[1:] != ordered[:-1]).any(axis=1)
    found = [ordered[starts]]
    if return_index:
        found.append(order[starts])
    if return_inverse:
        inverse = np.empty(len(rows), dtype=np.int64)
        inverse[order] = np.cumsum(starts) - 1
        found.append(inverse)
    if return_counts:
        found.append(np.diff(np.append(np.flatnonzero(starts), len(rows))))
    return found[0] if len(found) == 1 else tuple(found)


def smooth_surfaces(scene):
    """A number per triangle for the smooth surface it belongs to: triangles joined across
    shared edges that bend by less than SMOOTH_SURFACE_DEGREES (a curved mesh's facets are
    one surface; a box's faces, or a wall and the floor it stands on, are several), and the
    triangles of one object in one plane (pieces meeting at T-junctions). An edge is shared
    where an object's triangles meet at the same corners, whether or not they share the
    vertices: a flat-shaded mesh comes with its corners split per face. The visibility test
    forgives a receiver small depth differences against its own surface only."""
    corners = scene.vertices[scene.triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    count = len(scene.triangles)
    welded = unique_rows(np.column_stack([np.repeat(scene.object_index, 3),
                                          corners.reshape(-1, 3)]),
                         return_inverse=True)[1].reshape(-1, 3)
    edges = np.sort(welded[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    owners = np.repeat(np.arange(count), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, owners = edges[order], owners[order]
    shared = np.nonzero((edges[1:] == edges[:-1]).all(axis=1))[0]
    a, b = owners[shared], owners[shared + 1]
    smooth = (normals[a] * normals[b]).sum(axis=1) > math.cos(math.radians(SMOOTH_SURFACE_DEGREES))
    a, b = a[smooth], b[smooth]
    lo, hi = scene.bounds()
    step = 1e-5 * max(float(np.linalg.norm(hi - lo)), 1e-9)
    plane = np.column_stack([scene.object_index, np.round(normals * 1e4),
                             np.round((normals * corners[:, 0]).sum(axis=1) / step)])
    _, first, group = unique_rows(plane, return_index=True, return_inverse=True)
    a, b = np.concatenate([a, np.arange(count)]), np.concatenate([b, first[group]])
    return connected_components(count, a, b)


def connected_components(count, a, b):
    """Per item of ``count`` the number of its connected component, items ``a[i]`` and
    ``b[i]`` joined, numbered 0, 1, ... by their least item."""
    label = np.arange(count)
    while True:   # pull both ends to the smaller label, then jump
        joined = np.minimum(label[a], label[b])
        previous = label.copy()
        np.minimum.at(label, a, joined)
        np.minimum.at(label, b, joined)
        label = label[label]
        if np.array_equal(label, previous):
            return np.unique(label, return_inverse=True)[1]


def tangents_of(normals):
    """tangent_of() (texel_maps.glsl) of each row of ``normals``."""
    axes = np.eye(3)[np.argmin(np.abs(normals), axis=1)]
    t = axes - normals * (axes * normals).sum(axis=1, keepdims=True)
    return t / np.linalg.norm(t, axis=1, keepdims=True)


def texel_span(low, high):
    """The first texel and one past the last that points from ``low`` to ``high`` cover
    (integers: texel i spans [i, i + 1); a float's width over an edge does not count)."""
    return (np.floor(low + 1e-6).astype(np.int64), np.ceil(high - 1e-6).astype(np.int64))


def texels_to_world(texel_points, uv, corners):
    """Complex texel-space points of a triangle (its corners ``uv`` in texels, ``corners`` in
    the world) in the world, by its affine map. Plain arithmetic: numpy's small solves and
    products wait on its threads, which contend with llvmpipe's."""
    (u0, v0), (u1, v1), (u2, v2) = uv
    det = (u1 - u0) * (v2 - v0) - (u2 - u0) * (v1 - v0)
    offsets = [(point.real - u0, point.imag - v0) for point in texel_points]
    first = np.array([(du * (v2 - v0) - dv * (u2 - u0)) / det for du, dv in offsets])
    second = np.array([(dv * (u1 - u0) - du * (v1 - v0)) / det for du, dv in offsets])
    return (corners[0] + first[:, None] * (corners[1] - corners[0])
            + second[:, None] * (corners[2] - corners[0]))


def lightmap_tangent(texels, positions, n):
    """The world direction of +x in the lightmap over a shooter's texels (so that its quad
    lines up with them), by least squares of their positions on their texel coordinates;
    along +y turned a quarter when they span one column, tangent_of(n) for one texel."""
    spans = [texels[:, axis].min() < texels[:, axis].max() for axis in (0, 1)]
    if not any(spans):
        return tangents_of(n[None])[0]
    # Least squares on the centred coordinates: the normal equations, solved by hand (one
    # or two unknowns per world axis).
    along = texels[:, [i for i in (0, 1) if spans[i]]].astype(np.float64)
    along -= along.mean(axis=0)
    moments = along.T @ along
    covariances = along.T @ (positions - positions.mean(axis=0))
    if len(moments) == 1:
        slope = covariances[0] / moments[0, 0]
    else:
        (a, b), (_, d) = moments
        slope = (d * covariances[0] - b * covariances[1]) / (a * d - b * b)
    direction = slope if spans[0] else vector_cross(slope, n)
    direction = direction - n * (direction @ n)
    size = vector_length(direction)
    return direction / size if size > 1e-12 else tangents_of(n[None])[0]


def vector_cross(a, b):
    """np.cross of two 3-vectors, without its per-call cost (shooters are built one by one,
    thousands per bake)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def vector_length(v):
    """The length of a 3-vector (np.linalg.norm without its per-call cost)."""
    return math.sqrt(float(v @ v))


def rectangle_around(members, strongest, width, height):
    """The members in a rectangle of texels grown around the strongest while whole rows and
    columns of members border it: a shooter's quad must lie where its texels are, or the
    receivers next to it (a ceiling 0.1 mm over a lamp) get the light of the wrong place.
    The members left out stay unshot for a later shot."""
    columns, rows = members % width, members // width
    if len(members) == (np.ptp(columns) + 1) * (np.ptp(rows) + 1):
        return members   # a rectangle already (and so around the strongest)
    mask = np.zeros((height, width), dtype=bool)
    mask.flat[members] = True
    x0 = x1 = strongest % width
    y0 = y1 = strongest // width
    grown = True
    while grown:
        grown = False
        if x0 > 0 and mask[y0:y1 + 1, x0 - 1].all():
            x0, grown = x0 - 1, True
        if x1 < width - 1 and mask[y0:y1 + 1, x1 + 1].all():
            x1, grown = x1 + 1, True
        if y0 > 0 and mask[y0 - 1, x0:x1 + 1].all():
            y0, grown = y0 - 1, True
        if y1 < height - 1 and mask[y1 + 1, x0:x1 + 1].all():
            y1, grown = y1 + 1, True
    rows, columns = np.mgrid[y0:y1 + 1, x0:x1 + 1]
    return (rows * width + columns).ravel()


# Slices of a (rows, columns) grid: each texel and its neighbour along x, then along y.
_NEIGHBOURS = (((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
               ((slice(1, None), slice(None)), (slice(None, -1), slice(None))))


@dataclass
class Chart:
    """How a chart maps the lightmap to the world: world = anchor + (texel - anchor_texel) @
    basis.T, basis's columns the world steps along the lightmap's x and y."""
    anchor: np.ndarray
    anchor_texel: np.ndarray
    basis: np.ndarray
    inverse: np.ndarray


@dataclass
class RegionCharts:
    """The charts of a read region: a label per texel and each label's Chart (labels of
    charts without whole neighbouring texels along both axes have none)."""
    labels: np.ndarray
    by_label: dict


def region_charts(position, texel_size, width, origin):
    """The charts in a read region and how each maps the lightmap to the world. Texels are
    joined through occupied neighbours (xatlas pads charts apart). Per chart with whole
    texels next to each other along both lightmap axes: (anchor, its texel, step x, step y,
    inverse), world = anchor + (texel - its texel) @ (step x, step y), the steps being the
    mean world step between neighbouring whole texels (xatlas may scale a chart's axes
    differently: the Cornell light's texels are 16.25 x 15 mm). Returns (label per texel,
    {label: its Chart})."""
    height = len(position) // width
    points = position[:, :3].reshape(height, width, 3)
    occupied = (position[:, 3] > 0.0).reshape(height, width)
    whole = (position[:, 3] >= 0.999 * texel_size ** 2).reshape(height, width) & occupied
    labels = np.where(occupied, np.arange(height * width).reshape(height, width), -1)
    while True:   # each texel takes the least label among its occupied neighbours
        before = labels.copy()
        for a, b in _NEIGHBOURS:
            joined = occupied[a] & occupied[b]
            labels[a] = np.where(joined, np.minimum(labels[a], before[b]), labels[a])
            labels[b] = np.where(joined, np.minimum(labels[b], before[a]), labels[b])
        if np.array_equal(before, labels):
            break
    steps = []
    for a, b in _NEIGHBOURS:   # along the lightmap's x (columns), then y (rows)
        pairs = whole[a] & whole[b] & (labels[a] == labels[b])
        steps.append((labels[b][pairs], (points[a] - points[b])[pairs]))
    charts = {}
    for label in np.unique(labels[whole]):
        along = [differences[owners == label] for owners, differences in steps]
        if len(along[0]) == 0 or len(along[1]) == 0:
            continue
        step_x, step_y = along[0].mean(axis=0), along[1].mean(axis=0)
        row, column = np.argwhere(whole & (labels == label))[0]
        basis = np.stack([step_x, step_y], axis=1)
        charts[int(label)] = Chart(points[row, column],
                                   np.array([origin[0] + column, origin[1] + row],
                                            dtype=np.float64),
                                   basis, np.linalg.pinv(basis))
    return RegionCharts(labels.ravel(), charts)


def chart_quad(texels, points, chart, area, normal):
    """A shooter's quad from its texels' rectangle (page texel coordinates) mapped to the
    world by their chart: neighbouring shooters' quads tile the surface as the texels do.
    A part-covered texel at the rectangle's side covers the side of its texel away from the
    chart's edge, its sample point in the middle of what it covers: the quad's side is moved
    in to match. Scaled to the texels' exact area about its middle, and wound
    counter-clockwise about the shooter's ``normal`` as shooter_quad's (a chart may run
    either way round on the page)."""
    anchor, anchor_texel, basis = chart.anchor, chart.anchor_texel, chart.basis
    inverse = chart.inverse
    at = (points - anchor) @ inverse.T + anchor_texel   # sample points, in texels
    sides = []
    for axis in (0, 1):
        low, high = texels[:, axis].min(), texels[:, axis].max()
        first, last = texels[:, axis] == low, texels[:, axis] == high
        shift = at[:, axis] - texels[:, axis]
        # Toward the chart's inside a side stays on the texel's edge.
        sides.append((np.max(np.where(shift[first] > 0.0, 2.0 * at[first, axis] - low - 0.5,
                                      low - 0.5)),
                      np.min(np.where(shift[last] < 0.0, 2.0 * at[last, axis] - high + 0.5,
                                      high + 0.5))))
    (x0, x1), (y0, y1) = sides
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) - anchor_texel
    world = anchor + corners @ basis.T
    middle = world.mean(axis=0)
    spanning = vector_cross(world[1] - world[0], world[3] - world[0])
    scale = math.sqrt(area / max(vector_length(spanning), 1e-30))
    quad = list(middle + (world - middle) * scale)
    if spanning @ normal < 0.0:
        quad.reverse()
    return quad


def quad_in_plane(quad, point, normal, area):
    """A planar quad projected onto the plane through ``point`` with unit ``normal``, scaled
    back to ``area`` about its middle (a projection onto a tilted plane shrinks it)."""
    corners = np.asarray(quad)
    projected = corners - normal * ((corners - point) @ normal)[:, None]
    middle = projected.mean(axis=0)
    spanned = vector_length(vector_cross(projected[1] - projected[0], projected[3] - projected[0]))
    scale = math.sqrt(area / max(spanned, 1e-30))
    return list(middle + (projected - middle) * scale)


def shooter_quad(offsets, texel_sizes, t, b, area, centre):
    """Rectangle in the shooter's plane spanning its texels, scaled to their exact area."""
    u, v = offsets @ t, offsets @ b
    half = 0.5 * texel_sizes
    u0, u1 = (u - half).min(), (u + half).max()
    v0, v1 = (v - half).min(), (v + half).max()
    scale = math.sqrt(area / max((u1 - u0) * (v1 - v0), 1e-30))
    hu, hv = 0.5 * (u1 - u0) * scale, 0.5 * (v1 - v0) * scale
    return [centre + sx * hu * t + sy * hv * b
            for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]


def frame_around(n):
    """Orthonormal columns (t, b, n) with n the given unit vector."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = np.cross(helper, n)
    t /= np.linalg.norm(t)
    return np.stack([t, np.cross(n, t), n], axis=1)


def runs(slots):
    """(first, count) of each run of consecutive integers in sorted ``slots``."""
    breaks = np.nonzero(np.diff(slots) != 1)[0] + 1
    return [(int(run[0]), len(run)) for run in np.split(slots, breaks)]
