"""Lightmap atlas: the receiving and emitting triangles at a texel density, each layout (an
object, or the copies of one mesh) charted on its own (charting.py, kept in a cache across
bakes), the layouts' blocks then packed onto one or more pages (packing.py). Texels follow
surface area, not triangle count."""
from dataclasses import dataclass
import hashlib

import numpy as np

from . import charting
from .charting import Layout, chart_layout, destroy_settled_atlases, given_layout, units_per_metre
from .errors import SettingsError
from .packing import place_blocks, slot_offsets


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
# Meshes whose corners (from the corner of their box) agree to this share of the box's
# size share a layout: a moved copy's corners differ in their last bits.
LAYOUT_TOLERANCE = 1e-6
_layouts = []   # _CachedLayout, the latest used last


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
    destroy_settled_atlases()
    units = units_per_metre(scene, chosen, density)
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
    offset = slot_offsets(scene, placed, sizes, max_size)
    page, origin, (width, height) = place_blocks(scene, placed, sizes, offset, max_size)

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
    layout = (given_layout if given else chart_layout)(scene, members, units, density,
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
            int(padding), charting.XATLAS_PIECE_TRIANGLES)


@dataclass
class _CachedLayout:
    key: tuple
    shape: np.ndarray       # (N, 3, 3) corners from the corner of their box, single floats
    layout: Layout
