"""Lightmap atlas: xatlas charts the receiving and emitting triangles at a texel density and
packs them onto one or more pages. Texels follow surface area, not triangle count."""
from dataclasses import dataclass, replace
import hashlib
import math
import time

import numpy as np
import xatlas

from .errors import SettingsError


@dataclass
class Atlas:
    width: int
    height: int
    page_count: int
    triangles: np.ndarray   # (C,) scene triangle indices that have lightmap texels
    page: np.ndarray        # (C,) page of each charted triangle
    texels: np.ndarray      # (C, 3, 2) corner positions in texels, texel i spans [i, i+1)
    density: float
    unpacked: np.ndarray = None  # scene triangles xatlas left out (too small): no texels
    chart: np.ndarray = None     # (C,) the chart of each charted triangle, numbered per atlas
    # Per object: its page (-1 without texels), where its layout's corner sits on the page and
    # within its block (whole texels), as Scene.object_layout/slot/block ask.
    object_page: np.ndarray = None
    object_origin: np.ndarray = None
    object_offset: np.ndarray = None
    shrunk: list = None     # objects charted coarser than the density to fit one page

    def uv(self):
        """Corner coordinates normalised to [0, 1] on their page (v up, as Blender's UVs)."""
        return self.texels / np.array([self.width, self.height], dtype=np.float64)


# Re-bakes reuse the layout of each mesh whose geometry did not change (new lights,
# materials, settings, another object moved), and objects of one shape (linked duplicates
# with their own modifiers, moved copies) share one: xatlas takes seconds per ten thousand
# triangles. The cache forgets its oldest layouts past this many triangles in all.
CACHED_LAYOUT_TRIANGLES = 3_000_000
# tight_packing keeps the atlas's layout unless its pages would shrink to this share or less.
TIGHT_PACKING_GAIN = 0.75
OVERLAP_RESOLUTION = 1024   # grid overlapping_faces tests a UV map's [0, 1] square on
OVERLAP_MARGIN = 1e-3       # of a cell: closer to a triangle's edge is on the edge
OVERLAP_BATCH = 1 << 22     # grid centres overlapping_faces tests at once (memory)
SNAP_TEXELS = 1e-3       # a UV corner this close to a texel edge lies on it
MIN_XATLAS_AREA = 1e-3   # smallest triangle area handed to xatlas, in its units
MAX_XATLAS_EXTENT = 1e6  # largest scene size handed to xatlas, in its units
XATLAS_ORIGIN_STEP = 1024.0  # meshes go to xatlas moved by whole steps of this, in its units
XATLAS_PIECE_TRIANGLES = 8192   # most triangles xatlas charts as one mesh (_pieces)
# Meshes whose corners (from the corner of their box) agree to this share of the box's
# size share a layout: a moved copy's corners differ in their last bits.
LAYOUT_TOLERANCE = 1e-6
_layouts = []   # _CachedLayout, the latest used last
# xatlas can deadlock when an atlas is destroyed right after generate(): its destructor wakes
# the worker threads without taking their lock, so a worker still on its way back to sleep
# misses the wake-up and the destructor joins it forever (seen here as a test run hanging
# with every thread waiting, about once in a few hundred atlases). So atlases are destroyed
# only at the next build, and no sooner than this after their generate() returned.
XATLAS_SETTLE_SECONDS = 0.1
_generated = []   # (xatlas.Atlas, when its generate() returned)


def build_atlas(scene, density, max_size=4096, padding=2, charted=None, align=1):
    """Chart and pack the triangles flagged in ``charted`` (receivers and emitters by default).

    Each layout (an object, or the copies of one mesh) is charted by xatlas on its own, at
    the texel density times the scene's object_texel_scale, so that charts never join across
    objects and each object is whole on one page; the blocks of objects are then packed on
    pages of at most ``max_size`` texels a side (see Scene.object_layout), each layout's
    corner at a multiple of ``align`` texels (the solver's shooting blocks).
    """
    if not np.isfinite(density) or density <= 0.0:
        raise SettingsError(f"texel density must be a positive number of texels per metre, "
                            f"got {density}")
    if charted is None:
        charted = charted_triangles(scene)
    chosen = np.nonzero(charted)[0]
    if len(chosen) == 0:
        raise SettingsError("no triangle receives a lightmap: enable 'receive' on an object")

    return _build(scene, chosen, density, max_size, padding, align)


def charted_triangles(scene):
    """The triangles that get texels by default: receivers and emitters (which shoot)."""
    return scene.receive | (scene.emission.max(axis=1) > 0.0)


def clear_cache():
    """Forget the cached layouts (benchmarks time xatlas every time)."""
    _layouts.clear()


def _build(scene, chosen, density, max_size, padding, align):
    _destroy_settled_atlases()
    units = _units_per_metre(scene, chosen, density)
    of_object = {int(obj): chosen[scene.object_index[chosen] == obj]
                 for obj in np.unique(scene.object_index[chosen])}
    copies = {}
    for obj in of_object:
        copies.setdefault(int(scene.object_layout[obj]), []).append(obj)
    layouts = {}
    for layout, objects in copies.items():
        scale = np.asarray(scene.object_texel_scale)[objects] ** 2
        largest = objects[int(np.argmax([scene.triangle_area[of_object[obj]].sum() * s
                                         for obj, s in zip(objects, scale)]))]
        for obj in objects:
            if len(of_object[obj]) != len(of_object[largest]):
                raise SettingsError(
                    f"objects '{scene.object_names[obj]}' and "
                    f"'{scene.object_names[largest]}' share a layout but chart "
                    f"{len(of_object[obj])} and {len(of_object[largest])} triangles")
        layouts[layout] = _layout_of(scene, of_object[largest], units, density,
                                     max_size - align, padding)

    placed = [obj for obj in of_object if layouts[int(scene.object_layout[obj])].size.min() > 0]
    sizes = {obj: -(-(layouts[int(scene.object_layout[obj])].size + padding) // align) * align
             for obj in placed}
    offset = _slot_offsets(scene, placed, sizes, max_size)
    page, origin, (width, height) = _place_blocks(scene, placed, sizes, offset, max_size)

    objects = len(scene.object_names)
    object_page = np.full(objects, -1, dtype=np.int64)
    object_origin = np.zeros((objects, 2), dtype=np.int64)
    object_offset = np.zeros((objects, 2), dtype=np.int64)
    rows = {"triangles": [], "page": [], "texels": [], "chart": [], "unpacked": []}
    charts = 0
    for obj in of_object:
        layout = layouts[int(scene.object_layout[obj])]
        members = of_object[obj]
        rows["unpacked"].append(members[~layout.packed])
        if obj not in page:
            continue
        object_page[obj], object_origin[obj], object_offset[obj] = page[obj], origin[obj], offset[obj]
        rows["triangles"].append(members[layout.packed])
        rows["page"].append(np.full(int(layout.packed.sum()), page[obj]))
        rows["texels"].append(layout.texels[layout.packed] + origin[obj])
        rows["chart"].append(layout.chart[layout.packed] + charts)
        charts += layout.chart_count
    joined = {name: np.concatenate(values) if values else np.zeros(0, dtype=np.int64)
              for name, values in rows.items()}
    texels = joined["texels"].reshape(-1, 3, 2).astype(np.float64)
    return Atlas(width, height, max(int(joined["page"].max(initial=0)) + 1, 1),
                 joined["triangles"].astype(np.int64), joined["page"].astype(np.int64),
                 texels, float(density), unpacked=joined["unpacked"].astype(np.int64),
                 chart=joined["chart"].astype(np.int64), object_page=object_page,
                 object_origin=object_origin, object_offset=object_offset,
                 shrunk=sorted(obj for obj in of_object
                               if layouts[int(scene.object_layout[obj])].shrunk))


def _layout_of(scene, members, units, density, max_size, padding):
    """One mesh's layout: its own lightmap UVs or xatlas's charts, from the cache where a
    mesh of the same shape (up to where it stands) was laid out at the same settings."""
    given = scene.lightmap_uv is not None and np.isfinite(scene.lightmap_uv[members]).all()
    key = _layout_key(scene, members, units, density, max_size, padding)
    corners = scene.vertices[scene.triangles[members]].astype(np.float32)
    shape = corners - corners.reshape(-1, 3).min(axis=0)
    tolerance = LAYOUT_TOLERANCE * max(float(shape.max()), 1e-30)
    for index, cached in enumerate(_layouts):
        if cached.key == key and np.allclose(cached.shape, shape, rtol=0.0, atol=tolerance):
            _layouts.append(_layouts.pop(index))
            return cached.layout
    layout = (_given_layout if given else _chart_layout)(scene, members, units, density,
                                                         max_size, padding)
    _layouts.append(_CachedLayout(key, shape, layout))
    while sum(len(cached.shape) for cached in _layouts) > CACHED_LAYOUT_TRIANGLES:
        _layouts.pop(0)
    return layout


def _layout_key(scene, members, units, density, max_size, padding):
    """What a mesh's layout depends on besides its shape: which corners its triangles
    share, their faces and back-face copies, given lightmap UVs, the object's texel scale
    and the settings."""
    _, shared = np.unique(scene.triangles[members], return_inverse=True)
    polygon = scene.polygon[members]
    first_face = int(polygon[polygon >= 0].min()) if (polygon >= 0).any() else 0
    back = (np.zeros(0) if scene.back_of is None else scene.back_of[members] >= 0)
    lightmap_uv = np.zeros(0) if scene.lightmap_uv is None else scene.lightmap_uv[members]
    texel_scale = float(scene.object_texel_scale[int(scene.object_index[members[0]])])
    digest = hashlib.blake2b(digest_size=20)
    for array in (shared, np.where(polygon >= 0, polygon - first_face, -1), back,
                  lightmap_uv):
        array = np.ascontiguousarray(array)
        digest.update(str((array.dtype, array.shape)).encode())
        digest.update(array.tobytes())
    return (digest.hexdigest(), texel_scale, float(units), float(density), int(max_size),
            int(padding), XATLAS_PIECE_TRIANGLES)


@dataclass
class _CachedLayout:
    key: tuple
    shape: np.ndarray       # (N, 3, 3) corners from the corner of their box, single floats
    layout: "_Layout"


@dataclass
class _Layout:
    """One mesh's charts on a page of their own: texels (N, 3, 2) of its charted triangles
    from the layout's corner, their chart (numbered in the layout), which xatlas packed."""
    texels: np.ndarray
    chart: np.ndarray
    packed: np.ndarray
    size: np.ndarray        # (2,) width and height in texels
    chart_count: int
    shrunk: bool            # charted coarser than the density, to fit one page


def _chart_layout(scene, members, units, density, max_size, padding):
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
    return _Layout(texels, chart, packed, np.array([width, height], dtype=np.int64),
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


def _given_layout(scene, members, units, density, max_size, padding):
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
    return _Layout(texels, back.astype(np.int64), np.ones(len(members), bool), size,
                   boxes, bool(shrunk))


def _slot_offsets(scene, placed, sizes, max_size):
    """Each slot's offset (whole texels) within the blocks it is in. Slots that share a block,
    directly or through a chain of blocks, are laid out side by side in one frame, so that
    every block finds its slots apart wherever they also appear."""
    slot = {obj: int(scene.object_slot[obj]) for obj in placed}
    parent = {s: s for s in slot.values()}

    def root(s):
        while parent[s] != s:
            parent[s] = parent[parent[s]]
            s = parent[s]
        return s
    first_of_block = {}
    for obj in placed:
        block = int(scene.object_block[obj])
        other = first_of_block.setdefault(block, slot[obj])
        parent[root(slot[obj])] = root(other)
    size_of_slot = {slot[obj]: sizes[obj] for obj in placed}
    frames = {}
    for s in size_of_slot:
        frames.setdefault(root(s), []).append(s)
    offset_of_slot = {}
    for members in frames.values():
        boxes = np.array([size_of_slot[s] for s in members])
        origins, _ = _pack(boxes, max_size, pages=False)
        offset_of_slot.update(zip(members, origins))
    return {obj: np.asarray(offset_of_slot[slot[obj]], dtype=np.int64) for obj in placed}


def _place_blocks(scene, placed, sizes, offset, max_size):
    """Pages and origins of each object: its block's box (around its slots) packed on
    pages of at most ``max_size``. Returns ({obj: page}, {obj: origin}, (width, height))."""
    members = {}
    for obj in placed:
        members.setdefault(int(scene.object_block[obj]), []).append(obj)
    blocks = list(members)
    low = np.array([np.min([offset[o] for o in members[b]], axis=0) for b in blocks])
    high = np.array([np.max([offset[o] + sizes[o] for o in members[b]], axis=0)
                     for b in blocks])
    if not blocks:
        return {}, {}, (1, 1)
    if (high - low).max() > max_size:
        big = blocks[int(np.argmax((high - low).max(axis=1)))]
        raise SettingsError(f"the objects shown with '{scene.object_names[members[big][0]]}' "
                            f"do not fit one {max_size}-texel lightmap page together: lower "
                            "the texel density or raise the largest image size")
    origins, pages = _pack(high - low, max_size, pages=True)
    page, origin = {}, {}
    for index, block in enumerate(blocks):
        for obj in members[block]:
            page[obj] = int(pages[index])
            origin[obj] = origins[index] - low[index] + offset[obj]
    extent = np.max(origins + (high - low), axis=0)
    return page, origin, (int(extent[0]), int(extent[1]))


def _pack(boxes, max_size, pages):
    """Shelves of boxes (N, 2), tallest first, in a width near the root of their area (at most
    ``max_size``); with ``pages``, a box that would pass ``max_size`` in height starts the
    next page. Returns the origins (N, 2) and each box's page."""
    boxes = np.asarray(boxes, dtype=np.int64).reshape(-1, 2)
    width = int(min(max_size, max(boxes[:, 0].max(initial=1),
                                  math.ceil(math.sqrt(boxes.prod(axis=1).sum()) * 1.05))))
    origins = np.zeros_like(boxes)
    page = np.zeros(len(boxes), dtype=np.int64)
    x = y = shelf = current = 0
    for box in np.lexsort((-boxes[:, 0], -boxes[:, 1])):
        box_width, box_height = boxes[box]
        if x + box_width > width:
            x, y, shelf = 0, y + shelf, 0
        if pages and y + box_height > max_size:
            x, y, shelf, current = 0, 0, 0, current + 1
        origins[box], page[box] = (x, y), current
        x += box_width
        shelf = max(shelf, box_height)
    return origins, page


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
    start, end = _texel_span(texels[rows].min(axis=1), texels[rows].max(axis=1))
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
    start, end = _texel_span(corners.min(axis=0), corners.max(axis=0))
    return start[0], start[1], end[0], end[1]


def _texel_span(low, high):
    """The first texel and one past the last that points from ``low`` to ``high`` cover
    (integers: texel i spans [i, i + 1); a float's width over an edge does not count)."""
    return (np.floor(low + 1e-6).astype(np.int64), np.ceil(high - 1e-6).astype(np.int64))


def _world_to_texels(world, corners):
    """The affine map of a triangle (world corners (3, 3), texel corners (3, 2)), for points
    on its plane (others are projected onto it)."""
    edges = np.stack([world[1] - world[0], world[2] - world[0]], axis=1)     # (3, 2)
    texel_edges = np.stack([corners[1] - corners[0], corners[2] - corners[0]], axis=1)
    inverse = np.linalg.pinv(edges)                                           # (2, 3)
    return lambda points: corners[0] + ((points - world[0]) @ inverse.T) @ texel_edges.T


@dataclass
class TexelMap:
    """Where each chart moved between an atlas and its tight packing (tight_packing): per
    page, texel (x, y) of the tight page is texel (x, y) - offset of the atlas page, for the
    chart's offset."""
    offsets: np.ndarray     # (charts, 2) whole texels, tight minus atlas
    chart_page: np.ndarray  # (charts,) page of each chart
    boxes: np.ndarray       # (charts, 4) x0, y0, x1, y1 of each chart on its tight page


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
    pairs = np.unique(np.concatenate(covered), axis=0)
    _, faces_in_cell = np.unique(pairs[:, 0], return_counts=True)
    shared = np.repeat(faces_in_cell > 1, faces_in_cell)
    return np.isin(face, pairs[shared, 1])


def _cross2(a, b):
    """The z of the cross product of 2D vectors (numpy 2 deprecates np.cross on them)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def tight_packing(atlas, align=1):
    """The atlas with its charts moved by whole texels so that their bounding boxes all but
    abut (one empty texel between), page by page: every triangle covers the same texels,
    shifted. The solver works on this: its GPU passes run over whole pages, and the gutters
    bilinear filtering needs in the lightmaps Blender shows are most of an atlas of small
    charts (95 % of the office's). Results go back to the atlas's layout through the
    TexelMap. Charts of ``align`` texels or more across start at multiples of it. Returns
    (tight atlas, TexelMap), or (atlas, None) where the pages would not shrink to
    TIGHT_PACKING_GAIN of theirs or would grow a longer side."""
    if atlas.chart is None or (atlas.chart < 0).any() or not len(atlas.chart):
        return atlas, None
    charts = int(atlas.chart.max()) + 1
    low = np.full((charts, 2), np.inf)
    high = np.full((charts, 2), -np.inf)
    np.minimum.at(low, atlas.chart, atlas.texels.min(axis=1))
    np.maximum.at(high, atlas.chart, atlas.texels.max(axis=1))
    chart_page = np.zeros(charts, dtype=np.int64)
    chart_page[atlas.chart] = atlas.page
    # The texels a chart's triangles overlap, [floor(low), ceil(high)), and one empty column
    # and row after them: a corner rounded a float's width past its texel claims a sliver
    # of the next texel, which must not be another chart's.
    start, end = _texel_span(low, high)
    size = end + 1 - start
    origins, extent = _shelf_pack(size, chart_page, atlas.page_count, align)
    width, height = extent
    if (width * height > TIGHT_PACKING_GAIN * atlas.width * atlas.height
            or max(width, height) > max(atlas.width, atlas.height)):
        return atlas, None
    offsets = origins - start
    texels = atlas.texels + offsets[atlas.chart][:, None, :]
    tight = replace(_copy(atlas), width=int(width), height=int(height), texels=texels)
    boxes = np.concatenate([origins, origins + size], axis=1)
    return tight, TexelMap(offsets, chart_page, boxes)


def _shelf_pack(size, page, page_count, align):
    """Places boxes of ``size`` (N, 2) on shelves, tallest first, page by page, all pages the
    same size: a width near the root of the largest page's box area. Boxes of ``align``
    texels or more across go first, at multiples of ``align`` (a chart keeps whole shooting
    blocks); the small ones fill shelves after them. Returns the boxes' origins (N, 2) and
    the page size (width, height)."""
    big = size.max(axis=1) >= align
    footprint = np.where(big[:, None], -(-size // align) * align, size)
    areas = np.bincount(page, weights=footprint.prod(axis=1), minlength=page_count)
    width = int(max(footprint[:, 0].max(), math.ceil(math.sqrt(areas.max()) * 1.05)))
    width = -(-width // align) * align
    origins = np.zeros_like(size)
    height = 0
    for index in range(page_count):
        x = y = shelf = 0
        for group in (big, ~big):
            members = np.nonzero((page == index) & group)[0]
            members = members[np.lexsort((-footprint[members, 0], -footprint[members, 1]))]
            for box in members:
                box_width, box_height = footprint[box]
                if x + box_width > width:
                    x, y, shelf = 0, y + shelf, 0
                origins[box] = x, y
                x += box_width
                shelf = max(shelf, box_height)
            # The small boxes start on a shelf of their own.
            x, y, shelf = 0, -(-(y + shelf) // align) * align, 0
        height = max(height, y)
    return origins, (width, int(height))


def _generate(atlas, chart_options, pack_options):
    atlas.generate(chart_options, pack_options)
    _generated.append((atlas, time.monotonic()))


def _destroy_settled_atlases():
    """Destroy the atlases of earlier builds once their workers have long been asleep."""
    if _generated:
        time.sleep(max(0.0, _generated[-1][1] + XATLAS_SETTLE_SECONDS - time.monotonic()))
        _generated.clear()


def _copy(atlas):
    return replace(atlas, triangles=atlas.triangles.copy(), page=atlas.page.copy(),
                   texels=atlas.texels.copy(), unpacked=atlas.unpacked.copy(),
                   chart=atlas.chart.copy())


def _units_per_metre(scene, chosen, density):
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
