"""Charting: one mesh's lightmap layout, on a page of its own. xatlas charts its triangles at
the texel density (in pieces where the mesh is large), or the mesh's own lightmap UV map is
taken as it is, which must not overlap (overlapping_faces). build_atlas (atlas.py) places
the layouts on pages."""
from dataclasses import dataclass
import math
import time

import numpy as np
import xatlas

from .errors import SettingsError
from .geometry import texel_span, unique_rows

OVERLAP_RESOLUTION = 1024   # grid overlapping_faces tests a UV map's [0, 1] square on
OVERLAP_MARGIN = 1e-3       # of a cell: closer to a triangle's edge is on the edge
OVERLAP_BATCH = 1 << 22     # grid centres overlapping_faces tests at once (memory)
SNAP_TEXELS = 1e-3       # a UV corner this close to a texel edge lies on it
MIN_XATLAS_AREA = 1e-3   # smallest triangle area handed to xatlas, in its units
MAX_XATLAS_EXTENT = 1e6  # largest scene size handed to xatlas, in its units
XATLAS_ORIGIN_STEP = 1024.0  # meshes go to xatlas moved by whole steps of this, in its units
XATLAS_PIECE_TRIANGLES = 8192   # most triangles xatlas charts as one mesh (_pieces)
# xatlas can deadlock when an atlas is destroyed right after generate(): its destructor wakes
# the worker threads without taking their lock, so a worker still on its way back to sleep
# misses the wake-up and the destructor joins it forever (seen here as a test run hanging
# with every thread waiting, about once in a few hundred atlases). So atlases are destroyed
# only at the next build, and no sooner than this after their generate() returned.
XATLAS_SETTLE_SECONDS = 0.1
_generated = []   # (xatlas.Atlas, when its generate() returned)


@dataclass
class Layout:
    """One mesh's charts on a page of their own: texels (N, 3, 2) of its charted triangles
    from the layout's corner, their chart (numbered in the layout), which xatlas packed."""
    texels: np.ndarray
    chart: np.ndarray
    packed: np.ndarray
    size: np.ndarray        # (2,) width and height in texels
    chart_count: int
    shrunk: bool            # charted coarser than the density, to fit one page


def units_per_metre(scene, chosen, density):
    """The scale meshes are handed to xatlas in: texels, or finer where a triangle would be
    below xatlas's fixed smallest face area (1.2e-7 units^2), which it drops however many
    texels it would cover (a 0.1 mm triangle at 0.5 texels per metre). At most so fine that
    the scene spans MAX_XATLAS_EXTENT units, where single floats still resolve 1/16 of one;
    a triangle still too small is left out and listed in Atlas.unpacked."""
    scales = np.asarray(scene.object_texel_scale, dtype=np.float64)[scene.object_index[chosen]]
    smallest = float(np.min(scene.triangle_area[chosen] * scales ** 2))
    corners = scene.vertices[scene.triangles[chosen]].reshape(-1, 3)
    extent = float(np.max(corners.max(axis=0) - corners.min(axis=0)) * scales.max())
    finest = MAX_XATLAS_EXTENT / max(extent, 1e-30)
    return max(float(density), min(math.sqrt(MIN_XATLAS_AREA / smallest), finest))


def chart_layout(scene, members, units, density, max_size, padding):
    """xatlas charts one object's triangles and packs them on one page of at most
    ``max_size`` (less the padding after it); a mesh too large for it is charted coarser
    until it fits. Back-face copies are a mesh of their own: on their originals' surface,
    xatlas would join the two sheets at their shared corners into one tangle of an edge
    between four faces, cut into hundreds of charts packed for seconds. Large meshes go to
    xatlas in pieces (_pieces)."""
    chart_options = xatlas.ChartOptions()
    pack_options = xatlas.PackOptions()
    pack_options.padding = int(padding)
    pack_options.bilinear = True
    pack_options.max_chart_size = int(max_size - 2 * padding - 2)
    fits = max_size - padding
    texels_per_unit = float(density) / units
    back = (np.zeros(len(members), bool) if scene.back_of is None
            else scene.back_of[members] >= 0)
    meshes = [piece for rows in (np.nonzero(~back)[0], np.nonzero(back)[0]) if len(rows)
              for piece in _pieces(scene, members, rows)]
    for _ in range(8):
        pack_options.texels_per_unit = texels_per_unit
        atlas = _atlas_of(scene, [members[rows] for rows in meshes], units)
        _generate(atlas, chart_options, pack_options)
        if max(atlas.width, atlas.height) <= fits and atlas.atlas_count <= 1:
            break
        texels_per_unit *= 0.97 * fits / max(atlas.width, atlas.height, fits + 1)
    else:
        raise SettingsError(f"object '{scene.object_name(members[0])}' does not fit one "
                            f"{max_size}-texel lightmap page: lower the texel density")
    width, height = int(atlas.width), int(atlas.height)
    texels = np.zeros((len(members), 3, 2))
    page = np.zeros(len(members), dtype=np.int64)
    chart = np.full(len(members), -1, dtype=np.int64)
    chart_count = 0
    for mesh, rows in enumerate(meshes):
        _, indices, uvs = atlas[mesh]
        corners = indices.reshape(-1, 3)
        pages, _ = atlas.get_mesh_vertex_assignment(mesh)
        # xatlas puts texel centres on integer + 0.5 coordinates of its charts; shifting by
        # half a texel makes a chart of whole texels cover whole texels.
        texels[rows] = uvs[corners].astype(np.float64) * [width, height] - 0.5
        page[rows] = pages[corners[:, 0]]
        for index in range(atlas.get_mesh_chart_count(mesh)):
            chart[rows[atlas.get_mesh_chart(mesh, index).faces.astype(np.int64)]] = (
                chart_count + index)
        chart_count += atlas.get_mesh_chart_count(mesh)
    _keep_faces_in_one_chart(scene, members, texels, page, chart, (width, height), 1)
    # ... up to the rounding of xatlas's single-float UVs: snapped, so that a chart's edge
    # claims no sliver of the next texel (a texel of its own, of 1e-6 of its area).
    nearest = np.round(texels)
    texels = np.clip(np.where(np.abs(texels - nearest) < SNAP_TEXELS, nearest, texels),
                     0.0, [width, height])
    packed = page == 0      # xatlas marks a face it dropped 2^32 - 1
    if not packed.any():
        width = height = 0
    # Numbers only for the charts that hold packed triangles: the moves above can empty a
    # chart, and tight_packing places a box for every number.
    numbers, chart[packed] = np.unique(chart[packed], return_inverse=True)
    chart[~packed] = -1
    return Layout(texels, chart, packed, np.array([width, height], dtype=np.int64),
                  len(numbers), texels_per_unit < float(density) / units)


def _pieces(scene, members, rows):
    """``rows`` (of ``members``) cut into pieces of at most XATLAS_PIECE_TRIANGLES, each
    a mesh of its own for xatlas: halves by the median along the longest side of their
    centres, recursively, a face's triangles (Scene.polygon) always in one piece. xatlas
    checks a growing chart's whole boundary at each face it adds, a time that grows faster
    than the chart's faces (a smooth, finely subdivided sofa: a few huge charts); pieces
    bound it, and xatlas charts them on all cores, at the cost of a few more charts."""
    if len(rows) <= XATLAS_PIECE_TRIANGLES:
        return [rows]
    triangles = members[rows]
    polygon = scene.polygon[triangles]
    face = np.where(polygon >= 0, polygon, -1 - np.arange(len(rows)))  # loose triangles alone
    _, group = np.unique(face, return_inverse=True)
    centre = scene.vertices[scene.triangles[triangles]].mean(axis=1)
    face_centre = np.zeros((group.max() + 1, 3))
    np.add.at(face_centre, group, centre)
    centre = face_centre[group] / np.bincount(group)[group, None]
    pieces, pending = [], [np.arange(len(rows))]
    while pending:
        part = pending.pop()
        if len(part) <= XATLAS_PIECE_TRIANGLES:
            pieces.append(np.sort(rows[part]))
            continue
        axis = int(np.argmax(np.ptp(centre[part], axis=0)))
        part = part[np.lexsort((group[part], centre[part, axis]))]
        cut = len(part) // 2
        while cut < len(part) and group[part[cut]] == group[part[cut - 1]]:
            cut += 1
        pending += [part[:cut], part[cut:]] if cut < len(part) else [part[:len(part) // 2],
                                                                   part[len(part) // 2:]]
    return pieces


def given_layout(scene, members, units, density, max_size, padding):
    """One object's own lightmap UVs (Scene.lightmap_uv) as they are: the box around them
    scaled to the texel density on average (surface area over UV area, times the object's
    texel scale), back faces in a second box beside the first. Shrinks to fit one page."""
    name = scene.object_name(members[0])
    uv = scene.lightmap_uv[members]
    back = (np.zeros(len(members), bool) if scene.back_of is None
            else scene.back_of[members] >= 0)
    front = uv[~back]
    uv_area = 0.5 * np.abs(_cross2(front[:, 1] - front[:, 0], front[:, 2] - front[:, 0])).sum()
    if uv_area <= 0.0:
        raise SettingsError(f"object '{name}': its lightmap UV map has no area (every face "
                            "collapsed to a line or a point): unwrap it, or let Luxel chart it")
    texel_scale = float(scene.object_texel_scale[int(scene.object_index[members[0]])])
    per_uv = density * texel_scale * math.sqrt(scene.triangle_area[members[~back]].sum()
                                               / uv_area)
    low, high = front.reshape(-1, 2).min(axis=0), front.reshape(-1, 2).max(axis=0)
    span = np.maximum(high - low, 1e-12)
    boxes = 2 if back.any() else 1
    # Texels per UV unit at which the boxes fit one page, their padding (and the texel
    # each box's size rounds up by) included.
    fits = float(max_size - (padding + 1) * boxes) / max(span[0] * boxes, span[1])
    shrunk = per_uv > fits
    per_uv = min(per_uv, fits)
    box = np.ceil(span * per_uv - SNAP_TEXELS).astype(np.int64)
    texels = (uv - low) * per_uv
    texels[back] += [box[0] + padding, 0]
    size = np.array([box[0] * boxes + padding * (boxes - 1), box[1]], dtype=np.int64)
    texels = np.clip(texels, 0.0, size)
    return Layout(texels, back.astype(np.int64), np.ones(len(members), bool), size,
                  boxes, bool(shrunk))


def _keep_faces_in_one_chart(scene, order, texels, page, chart, size, page_count):
    """xatlas charts triangles, and may cut a chart through a face (a quad of a fluted
    column, between its two triangles): Blender keeps one UV per face corner, so such a face
    would show two charts' texels at once. Each such face's triangles are mapped into the
    chart of its largest one, by that triangle's affine map (world to texels), where the
    texels they come to hold belong to no other chart (the chart's padding); a face whose
    move would overlap another chart keeps its cut. ``texels``, ``page`` and ``chart``
    (rows of ``order``) change in place; faces xatlas dropped (on no page) are left out."""
    polygon = scene.polygon[order]
    packed = (page >= 0) & (page < page_count)
    faces = (polygon >= 0) & packed
    rows = np.nonzero(faces)[0][np.argsort(polygon[faces], kind="stable")]
    if not len(rows):
        return
    starts = np.nonzero(np.r_[True, np.diff(polygon[rows]) != 0])[0]
    ends = np.r_[starts[1:], len(rows)]
    cut = np.nonzero(np.minimum.reduceat(chart[rows], starts)
                     != np.maximum.reduceat(chart[rows], starts))[0]
    split = [rows[starts[face]:ends[face]] for face in cut]
    if not split:
        return
    owner = _chart_owners(texels, page, chart, packed, size, page_count)
    for group in split:
        edges = texels[group, 1:] - texels[group, :1]                  # (N, 2, 2)
        uv_area = np.abs(edges[:, 0, 0] * edges[:, 1, 1] - edges[:, 0, 1] * edges[:, 1, 0])
        for anchor in group[np.argsort(uv_area)[::-1]]:   # the largest triangle's chart first
            moved = _moved_into_chart(scene, order, texels, page, chart, group, anchor, owner,
                                      size)
            if moved is not None:
                break
        for r, corners in (moved or {}).items():
            texels[r], page[r], chart[r] = corners, page[anchor], chart[anchor]
            x0, y0, x1, y1 = _texel_box(corners)
            owner[page[r], y0:y1, x0:x1] = chart[r]


def _chart_owners(texels, page, chart, packed, size, page_count):
    """Which chart holds each texel (page_count, height, width), -1 none: the chart of the
    last of the ``packed`` triangles whose texel box covers it."""
    width, height = size
    rows = np.nonzero(packed)[0]
    start, end = texel_span(texels[rows].min(axis=1), texels[rows].max(axis=1))
    start = np.clip(start, 0, [width, height])
    extent = np.maximum(np.minimum(end, [width, height]) - start, 0)
    counts = extent.prod(axis=1)
    covering = np.repeat(rows, counts)
    within = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    box_width = np.repeat(extent[:, 0], counts)
    x = np.repeat(start[:, 0], counts) + within % np.maximum(box_width, 1)
    y = np.repeat(start[:, 1], counts) + within // np.maximum(box_width, 1)
    last = np.full(page_count * height * width, -1, dtype=np.int64)
    np.maximum.at(last, (page[covering] * height + y) * width + x, covering)
    owner = np.where(last >= 0, chart[np.maximum(last, 0)], -1)
    return owner.reshape(page_count, height, width).astype(np.int32)


def _moved_into_chart(scene, order, texels, page, chart, group, anchor, owner, size):
    """{row: texel corners} of a face's triangles outside the anchor triangle's chart, mapped
    into it, or None where one would leave the page or cover another chart's texels."""
    to_texels = _world_to_texels(scene.vertices[scene.triangles[order[anchor]]], texels[anchor])
    moved = {}
    for r in group:
        if chart[r] == chart[anchor]:
            continue
        corners = to_texels(scene.vertices[scene.triangles[order[r]]])
        x0, y0, x1, y1 = _texel_box(corners)
        if corners.min() < 0 or (corners.max(axis=0) > size).any():
            return None
        held = owner[page[anchor], y0:y1, x0:x1]
        if np.isin(held, [-1, chart[anchor], chart[r]], invert=True).any():
            return None
        moved[r] = corners
    return moved


def _texel_box(corners):
    """x0, y0, x1, y1: the texels a triangle's corners (3, 2) span."""
    start, end = texel_span(corners.min(axis=0), corners.max(axis=0))
    return start[0], start[1], end[0], end[1]


def _world_to_texels(world, corners):
    """The affine map of a triangle (world corners (3, 3), texel corners (3, 2)), for points
    on its plane (others are projected onto it)."""
    edges = np.stack([world[1] - world[0], world[2] - world[0]], axis=1)     # (3, 2)
    texel_edges = np.stack([corners[1] - corners[0], corners[2] - corners[0]], axis=1)
    inverse = np.linalg.pinv(edges)                                           # (2, 3)
    return lambda points: corners[0] + ((points - world[0]) @ inverse.T) @ texel_edges.T


def _atlas_of(scene, mesh_triangles, units):
    atlas = xatlas.Atlas()
    for members in mesh_triangles:
        used, local = np.unique(scene.triangles[members], return_inverse=True)
        # xatlas sizes charts by surface area: scaling an object's copy scales its texels.
        scale = units * scene.object_texel_scale[int(scene.object_index[members[0]])]
        # Moved near the origin by whole XATLAS_ORIGIN_STEPs: xatlas works in single floats,
        # which 100 km from the origin step by 8 mm, and there it charted a 1 m cube into
        # nothing. A mesh within a step of the origin stays where it is, to the bit.
        units_at = scene.vertices[used] * scale
        shift = np.trunc(units_at.min(axis=0) / XATLAS_ORIGIN_STEP) * XATLAS_ORIGIN_STEP
        atlas.add_mesh((units_at - shift).astype(np.float32),
                       local.reshape(-1, 3).astype(np.uint32))
    return atlas


def _generate(atlas, chart_options, pack_options):
    atlas.generate(chart_options, pack_options)
    _generated.append((atlas, time.monotonic()))


def destroy_settled_atlases():
    """Destroy the atlases of earlier builds whose workers have long been asleep; younger
    ones wait for a later build (a bake charts twice within a fraction of a second: for its
    materials, then for the solver, which finds the layouts cached)."""
    settled = time.monotonic() - XATLAS_SETTLE_SECONDS
    _generated[:] = [(atlas, when) for atlas, when in _generated if when > settled]


def overlapping_faces(uv, face, resolution=OVERLAP_RESOLUTION):
    """Which triangles of a UV map (T, 3, 2) share area with another face's (``face`` (T,):
    the face each triangle belongs to): (T,) bool. Tested at the centres of a
    ``resolution``-square grid; a centre counts only inside a triangle by more than
    OVERLAP_MARGIN of a cell, so faces that meet along an edge do not overlap."""
    uv = np.asarray(uv, dtype=np.float64)
    face = np.asarray(face, dtype=np.int64)
    points = uv * resolution - 0.5      # cell centres at whole numbers
    low = np.ceil(points.min(axis=1)).astype(np.int64)
    high = np.floor(points.max(axis=1)).astype(np.int64)
    extent = np.maximum(high - low + 1, 0)
    counts = extent.prod(axis=1)
    edges = np.roll(points, -1, axis=1) - points          # edge i from corner i to i + 1
    doubled_area = _cross2(edges[:, 0], -edges[:, 2])
    orientation = np.sign(doubled_area)
    lengths = np.maximum(np.linalg.norm(edges, axis=2), 1e-30)
    covered = []
    total = np.cumsum(counts)
    start = 0
    while start < len(uv):      # triangles in runs of about OVERLAP_BATCH tested centres
        end = max(start + 1, int(np.searchsorted(total, total[start] - counts[start]
                                                 + OVERLAP_BATCH, side="right")))
        chosen = np.arange(start, min(end, len(uv)))
        start = end
        chosen = chosen[(counts[chosen] > 0) & (orientation[chosen] != 0)]
        owner = np.repeat(chosen, counts[chosen])
        local = np.arange(len(owner)) - np.repeat(np.cumsum(counts[chosen]) - counts[chosen],
                                                  counts[chosen])
        width = extent[owner, 0]
        centre = np.stack([low[owner, 0] + local % width, low[owner, 1] + local // width], 1)
        inside = np.ones(len(owner), bool)
        for corner in range(3):
            signed = _cross2(edges[owner, corner], centre - points[owner, corner])
            inside &= signed * orientation[owner] / lengths[owner, corner] > OVERLAP_MARGIN
        centre = centre[inside]
        covered.append(np.stack([centre[:, 1] * resolution + centre[:, 0],
                                 face[owner[inside]]], axis=1))
    if not covered:
        return np.zeros(len(uv), bool)
    pairs = unique_rows(np.concatenate(covered))
    _, faces_in_cell = np.unique(pairs[:, 0], return_counts=True)
    shared = np.repeat(faces_in_cell > 1, faces_in_cell)
    return np.isin(face, pairs[shared, 1])


def _cross2(a, b):
    """The z of the cross product of 2D vectors (numpy 2 deprecates np.cross on them)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
