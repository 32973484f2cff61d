"""Packing: the blocks of objects' layouts placed on pages (build_atlas), and an atlas's charts
packed tight for the GPU (tight_packing), both on shelves, tallest first."""
from dataclasses import dataclass, replace
import math

import numpy as np

from .errors import SettingsError
from .geometry import texel_span

# tight_packing keeps the atlas's layout unless its pages would shrink to this share or less.
TIGHT_PACKING_GAIN = 0.75


def slot_offsets(scene, placed, sizes, max_size):
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


def place_blocks(scene, placed, sizes, offset, max_size):
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


@dataclass
class TexelMap:
    """Where each chart moved between an atlas and its tight packing (tight_packing): per
    page, texel (x, y) of the tight page is texel (x, y) - offset of the atlas page, for the
    chart's offset."""
    offsets: np.ndarray     # (charts, 2) whole texels, tight minus atlas
    chart_page: np.ndarray  # (charts,) page of each chart
    boxes: np.ndarray       # (charts, 4) x0, y0, x1, y1 of each chart on its tight page


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
    start, end = texel_span(low, high)
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


def _copy(atlas):
    return replace(atlas, triangles=atlas.triangles.copy(), page=atlas.page.copy(),
                   texels=atlas.texels.copy(), unpacked=atlas.unpacked.copy(),
                   chart=atlas.chart.copy())
