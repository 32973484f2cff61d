"""The solver's thin-gap stage (close): across a gap far under a texel between facing surfaces
(a lamp 1 cm under a ceiling), the receivers facing a shooter get all the gap's bounces at
once, in closed form, and what leaves the gap along its open edges goes back to the room as
unshot light. The shooter's light is spread over the receivers' texel squares in its plane
(plane_polygons.py), less the band along the open edges where it leaks out
(thin_gap_edges.py)."""
from dataclasses import dataclass, field
import math

import moderngl
import numpy as np

from .geometry import TrianglePlanes, texels_to_world, unique_rows
from .gpu import render_state, set_uniform
from .plane_polygons import (area, chord_lengths, clipped, clipped_segment, outlines_of,
                             share_under, signed_area, square, square_halves)
from .state import NO_SURFACE, blend_points, decode_normals, read_map
from .thin_gap_edges import band_cells, edge_band, edge_escape

# A gap under this share of a texel between facing surfaces is thin: receivers across it
# get all its bounces at once (close).
THIN_GAP = 0.1
# A texel across a thin gap shows the mean light over the middle of its square, this share of
# its side across: as Cycles bakes a texel (its samples jitter over half a texel; a baked step
# of emission 0.1 of a texel left of a texel's centre measured 0.70, where the whole square
# gives 0.6) (close).
SHOWN_SQUARE = 0.5
# A receiver faces a shooter across a gap when their normals' cosine is under minus this
# (receive_patch.frag: across_thin_gap()).
FACING_COSINE = 0.99
# Receivers are looked for this many of the region's largest texels around it (near_thin_gap),
# at most this many triangle-texel pairs at once.
NEAR_REACH = 3.0
PAIRS_AT_ONCE = 1 << 22
# Two albedos of 1 would keep the light for ever: the gap keeps at most this share of it at
# each bounce (at most 1,000 times the light).
MAX_KEPT = 0.999
# An open edge is clipped this share of a texel inside its triangle (lit_by).
EDGE_INSET = 1e-3


@dataclass
class Texels:
    """A page's receiving texels as the CPU holds them, sorted by x for the lookup around a
    shooter."""
    xy: np.ndarray              # (N, 2) texel coordinates
    position: np.ndarray        # (N, 3) sample points
    normal: np.ndarray          # (N, 3)
    side: np.ndarray            # (N,) the root of the area, as the shaders take it
    area: np.ndarray            # (N,) float32, as the maps hold it
    albedo: np.ndarray          # (N, 3) float32, as the maps hold it
    largest_side: float

    def near(self, centre, reach):
        """The indices of the texels whose x lies within ``reach`` and two of their sides of
        the centre's (in_near_field())."""
        radius = reach + 2.0 * self.largest_side
        first, last = np.searchsorted(self.position[:, 0], [centre[0] - radius, centre[0] + radius])
        return np.arange(first, last)


@dataclass
class PageTriangles:
    """A page's charted triangles: texel and world corners, open edges, texel bounds and
    surface numbers."""
    texels: np.ndarray          # (T, 3, 2)
    corners: np.ndarray         # (T, 3, 3)
    open_edges: np.ndarray      # (T, 3) bool: edge from corner i to i + 1
    low: np.ndarray             # (T, 2)
    high: np.ndarray            # (T, 2)
    surfaces: np.ndarray        # (T,) state.surfaces of each


@dataclass
class ThinGaps:
    """The thin-gap stage's caches, filled as shots need them, and its ledger: what the gaps'
    receivers show (W: irradiance times area, and its part they absorb, as the maps would
    count it) and what really arrived."""
    receivers: object                               # geometry.TrianglePlanes
    near_region: dict = field(default_factory=dict)     # Region -> which texels a
                                                        # receiver faces closely
    surface_corners: dict = field(default_factory=dict)  # surface number -> (T, 3, 3)
    receiving_texels: list = None                   # per page, Texels
    page_triangles: list = None                     # per page, PageTriangles
    lit_polygons: dict = field(default_factory=dict)    # (page, x0, y0, x1, y1) -> lit_by
    shown_received: np.ndarray = field(default_factory=lambda: np.zeros(3))
    shown_absorbed: np.ndarray = field(default_factory=lambda: np.zeros(3))
    arrived: np.ndarray = field(default_factory=lambda: np.zeros(3))
    escaped: np.ndarray = field(default_factory=lambda: np.zeros(3))   # left unshot


def create(state):
    """The stage's record, with the receiving triangles' planes."""
    scene = state.scene
    return ThinGaps(receivers=TrianglePlanes(
        scene.vertices[scene.triangles[scene.receive]].astype(np.float64)))


def set_constant_uniforms(program):
    """receive_patch.frag's share of a texel under which a gap is thin."""
    set_uniform(program, "u_thin_gap", THIN_GAP)


def extent(state, gaps, region, maps, shooter):
    """The shooter's surface rectangle (surface_extent) when a receiver may face it across a
    thin gap (near_thin_gap), else None. A shooter that does not receive (the back of a lamp
    emitting from both faces) holds no surface number in its texels: its charted triangles
    tell it (charted_surface), for the ceiling over that back is as thin a gap."""
    if not near_thin_gap(state, gaps, region, maps.position, maps.normal, maps.unshot[:, 3]):
        return None
    t, b = shooter.frame[:, 0], shooter.frame[:, 1]
    surface = shooter.surface if shooter.surface > 0 else charted_surface(state, gaps, shooter)
    return surface_extent(state, gaps, surface, shooter.centre, t, b)


def surface_extent(state, gaps, surface, centre, t, b):
    """The rectangle (u min, u max, v min, v max) along t and b from ``centre`` that holds
    the surface (all triangles of its number), or an empty one for no surface (0)."""
    if surface <= 0:
        return NO_SURFACE
    offsets = surface_triangles(state, gaps, surface).reshape(-1, 3) - centre
    u, v = offsets @ t, offsets @ b
    return (float(u.min()), float(u.max()), float(v.min()), float(v.max()))


def surface_triangles(state, gaps, surface):
    """(T, 3, 3) the world corners of the triangles of a surface number."""
    corners = gaps.surface_corners.get(surface)
    if corners is None:
        corners = gaps.surface_corners[surface] = state.scene.vertices[
            state.scene.triangles[state.surfaces == surface]]
    return corners


def near_thin_gap(state, gaps, region, position, normal, texel_size):
    """Whether a receiving triangle faces some texel of the region across a gap under
    twice THIN_GAP of the largest texel (receivers' texels differ a little in size), within
    the near field's reach: a superset of the receivers that receive_patch.frag treats as
    across a thin gap."""
    return bool(_facing_across_thin_gap(state, gaps, region, position, normal,
                                        texel_size).any())


def parts_finer(state, gaps, region, maps, finer):
    """How many levels finer than the block ``region`` its parts shoot: ``finer``
    (selection.block_region), or none where every texel of it faces a receiving triangle
    across a thin gap (as near_thin_gap). Parts sharpen shadows; all the light of such a
    block lands across the gap and casts none (a lamp's back under the ceiling, emitting as
    strongly as its front)."""
    if finer and _facing_across_thin_gap(state, gaps, region, maps.position, maps.normal,
                                         maps.unshot[:, 3]).all():
        return 0
    return finer


def _facing_across_thin_gap(state, gaps, region, position, normal, texel_size):
    """(N,) per occupied texel of the region whether a receiving triangle's plane faces it
    across a thin gap (near_thin_gap). Texels do not move, so once per region."""
    faced = gaps.near_region.get(region)
    if faced is None:
        occupied = position[:, 3] > 0.0
        points, normals = position[occupied, :3], normal[occupied]
        faced = np.zeros(len(points), dtype=bool)
        largest = float(texel_size[occupied].max())   # a shooter has its strongest texel
        gap, reach = 2.0 * THIN_GAP * largest, NEAR_REACH * largest
        receivers = gaps.receivers
        near = receivers.within(points.min(axis=0) - reach, points.max(axis=0) + reach)
        # A coarse block among a finely subdivided mesh has hundreds of texels and
        # hundreds of thousands of triangles near it: a piece of them at a time.
        step = max(1, PAIRS_AT_ONCE // max(len(points), 1))
        for start in range(0, len(near), step):
            part = near[start:start + step]
            facing = receivers.normals[part] @ normals.T < -FACING_COSINE         # (part, points)
            # How far in front of each texel each plane lies: a sheet's own back face, at 0,
            # gets nothing from its front.
            heights = receivers.normals[part] @ points.T - receivers.offsets[part, None]
            faced |= (facing & (heights > state.bounds.epsilon) & (heights < gap)).any(axis=0)
        gaps.near_region[region] = faced
    return faced


def close(state, gaps, shooter, unshot_limit):
    """Light the receivers facing the shooter across a thin gap, their sample points within
    a texel of its surface's rectangle (the texels the receiver pass left out:
    receive_patch.frag, across_thin_gap(); beside the surface, the light leaking out of the gap),
    with all the gap's bounces at once. Between facing surfaces far closer than a texel,
    light shot at a point bounces between the two at that point until absorbed: a receiver
    of albedo rho_r over a shooter of albedo rho_s shows pi L / (1 - rho_r rho_s) and
    reflects none of it out but along the surface's open edges, where its reflection that
    misses the shooter leaves the gap (edge_escape) as unshot light. What arrives is pi L
    times the share of its square under what the shooter's texels cover (lit_by: the
    shooters of a surface tile it exactly, where their quads, rectangles of their texels'
    area, leave holes along a slanted edge). What it shows is the share of the middle of its
    square (SHOWN_SQUARE) under them, less the band along the surface's open edges where the
    gap's light leaks out. The light leaving the gap adds at most ``unshot_limit`` (W, RGB)
    to the unshot power; returns what it added (_leave_unshot)."""
    t, b, n = shooter.frame.T
    centre = shooter.centre
    plane = np.stack([t, b], axis=1)
    polygons, segments = lit_by(state, gaps, shooter)
    if not polygons:
        return np.zeros(3)
    lit = [(polygon - centre) @ plane for polygon in polygons]
    corners = np.concatenate(lit)
    reach = float(np.linalg.norm(corners, axis=1).max())   # in_near_field()
    low, high = corners.min(axis=0), corners.max(axis=0)
    # As complex coordinates along t and b.
    lit = outlines_of([[complex(x, y) for x, y in polygon] for polygon in lit])
    open_edges = []
    for segment in segments:   # each with the surface on its left
        start, end, inner = (complex(x, y) for x, y in (segment - centre) @ plane)
        left = ((end - start).conjugate() * (inner - start)).imag > 0.0
        open_edges.append((start, end) if left else (end, start))
    u_min, u_max, v_min, v_max = shooter.extent
    escapes = []
    for page, texels in zip(state.pages, receiving_texels(state, gaps)):
        near = texels.near(centre, reach)
        offsets = texels.position[near] - centre
        height, u, v = offsets @ n, offsets @ t, offsets @ b
        side, normal = texels.side[near], texels.normal[near]
        corner = math.sqrt(0.5) * side   # how far a texel's square reaches from its point
        inside = np.nonzero(
            (height > state.bounds.epsilon) & (height < THIN_GAP * side)
            & ((normal * offsets).sum(axis=1) < 0.0) & (normal @ n < -FACING_COSINE)
            & (np.linalg.norm(offsets, axis=1) < reach + 2.0 * side)
            & (u >= u_min - side) & (u <= u_max + side)
            & (v >= v_min - side) & (v <= v_max + side)
            & (u + corner >= low[0]) & (u - corner <= high[0])
            & (v + corner >= low[1]) & (v - corner <= high[1]))[0]
        if not len(inside):
            continue
        chosen = near[inside]
        halves = square_halves(normal[inside], side[inside], t, b)
        points = u[inside] + 1j * v[inside]
        wholes = [square(point, half_t, half_b) for point, half_t, half_b in zip(points, *halves)]
        under = np.array([share_under(whole, lit) for whole in wholes])
        middles = [square(point, SHOWN_SQUARE * half_t, SHOWN_SQUARE * half_b)
                   for point, half_t, half_b in zip(points, *halves)]
        shown_share = np.repeat([[share_under(middle, lit)] for middle in middles], 3, axis=1)
        albedo = texels.albedo[chosen].astype(np.float64)
        kept = np.minimum(albedo * shooter.albedo, MAX_KEPT)
        escaping = np.zeros_like(shown_share)
        if open_edges:
            # Along an open edge the band where the light leaks out (edge_band), summed
            # over the middle of the square chord by chord; and over the whole square, the
            # light its reflection sends out of the gap (edge_escape).
            cells, widths = band_cells()
            for row, (whole, middle, gap) in enumerate(zip(wholes, middles, height[inside])):
                chords, whole_chords = (
                    sum(chord_lengths(outline, start, end, cells * gap)
                        for start, end in open_edges) * widths * gap / area(outline)
                    for outline in (middle, whole))
                products = [round(float(kept_share), 3) for kept_share in kept[row]]
                shown_share[row] -= [(edge_band(p) * chords).sum() for p in products]
                escaping[row] = [(edge_escape(p) * whole_chords).sum() for p in products]
            shown_share = np.clip(shown_share, 0.0, 1.0)
        texel_area = texels.area[chosen, None].astype(np.float64)
        plates = math.pi * shooter.radiance / (1.0 - kept)
        shown = (plates * shown_share).astype(np.float32)
        _add_irradiance(state, page, texels.xy[chosen], shown)
        if escaping.any():
            escapes.append(Escape(page=page, texels=texels.xy[chosen], area=texel_area[:, 0],
                                  unshot=_escaping_unshot(state, gaps, shooter,
                                                          albedo * plates * escaping,
                                                          texel_area[:, 0], wholes, plane)))
        gaps.shown_received += (shown * texel_area).sum(axis=0)
        gaps.shown_absorbed += ((1.0 - albedo) * shown * texel_area).sum(axis=0)
        arrived = math.pi * shooter.radiance * under[:, None] * texel_area
        gaps.arrived += arrived.sum(axis=0)
    return _leave_unshot(state, gaps, escapes, unshot_limit)


@dataclass
class Escape:
    """The light leaving a gap on one page: its texels (N, 2), their areas (N,) and the
    unshot radiance (N, 3) it gives them."""
    page: object
    texels: np.ndarray
    area: np.ndarray
    unshot: np.ndarray


def _leave_unshot(state, gaps, escapes, unshot_limit):
    """Add the light leaving the gap (Escape each page) to its texels' unshot radiance, at
    most ``unshot_limit`` (receivers.unshot_limit): the gap's light is its shot's, and at
    coarse texels beside a small shooter the closed form gave more (with back faces on, a
    level's unshot power then grew). Returns the unshot power left (W, RGB), which the
    shot's receiver pass may not add again (receivers.update)."""
    left = np.zeros(3)
    for escape in escapes:
        left = left + math.pi * (escape.unshot * escape.area[:, None]).sum(axis=0)
    scale = np.minimum(1.0, unshot_limit / np.maximum(left, 1e-30))
    for escape in escapes:
        blend_points(state, escape.page.unshot_only, escape.texels,
                     _rgba(escape.unshot * scale), moderngl.FUNC_ADD)
    gaps.escaped += left * scale
    return left * scale


def _escaping_unshot(state, gaps, shooter, escaping, texel_area, squares, plane):
    """The unshot radiance (N, 3) that takes the light leaving the gap (``escaping``:
    irradiance times albedo, (N, 3)) on into the room. A texel shoots its unshot light from
    its sample point over all its square: over the shooter's surface it would send it back
    into the gap. So the escaping power goes to the texels by the area of their square beside
    the surface; where every texel lies over the surface, it stays where it left."""
    surface = shooter.surface if shooter.surface > 0 else charted_surface(state, gaps, shooter)
    if surface <= 0:
        return escaping / math.pi
    flat = (surface_triangles(state, gaps, surface) - shooter.centre) @ plane   # (T, 3, 2)
    every = np.array([[p.real, p.imag] for outline in squares for p in outline])
    low, high = every.min(axis=0), every.max(axis=0)
    near = np.nonzero((flat.max(axis=1) >= low).all(axis=1)
                      & (flat.min(axis=1) <= high).all(axis=1))[0]
    outlines = outlines_of([[complex(x, y) for x, y in flat[i]] for i in near])
    beside_area = texel_area * (1.0 - np.array([share_under(outline, outlines)
                                                for outline in squares]))
    if beside_area.sum() <= 1e-6 * texel_area.sum():
        return escaping / math.pi
    power = (escaping * texel_area[:, None]).sum(axis=0)
    return np.outer(beside_area / texel_area, power / beside_area.sum()) / math.pi


def lit_by(state, gaps, shooter):
    """What a shooter's texels cover: world polygons (the triangles on its page clipped to
    its texels' rectangle in the lightmap, texel i spanning [i, i + 1), each mapped back to
    the world by its own affine map) and world segments (the open edges of its surface
    among them, open_edges: their two ends and a point a texel inside). Blocks are shot
    many times: once per rectangle."""
    key = _texel_rectangle(state, shooter)
    if key in gaps.lit_polygons:
        return gaps.lit_polygons[key]
    triangles = page_triangles(state, gaps)[key[0]]
    texels, corners, edges = triangles.texels, triangles.corners, triangles.open_edges
    polygons, segments = [], []
    for triangle, piece, rectangle in _charted_pieces(triangles, key):
        uv, points = texels[triangle], corners[triangle]
        outline = [complex(x, y) for x, y in uv]
        turn = signed_area(outline)
        polygons.append(texels_to_world(piece, uv, points))
        for corner in np.nonzero(edges[triangle])[0]:
            a, b = outline[corner], outline[(corner + 1) % 3]
            # An open edge often lies on its texels' outer side (xatlas fits some charts to
            # whole texels), a rounding error to either side: it belongs to the texels of
            # its triangle, so it is clipped a thousandth of a texel inside the triangle.
            inward = (b - a) * (1j if turn > 0 else -1j)
            inward *= EDGE_INSET / abs(inward)
            part = clipped_segment(a + inward, b + inward, rectangle)
            if part is not None:
                # Its two ends and a point inside the triangle, which tells its side.
                ends = [end - inward for end in part]
                segments.append(texels_to_world(
                    ends + [0.5 * (ends[0] + ends[1]) + 1e3 * inward], uv, points))
    gaps.lit_polygons[key] = polygons, segments
    return polygons, segments


def charted_surface(state, gaps, shooter):
    """The surface number of the charted triangle that covers most of the shooter's texels'
    rectangle (0 if none does)."""
    key = _texel_rectangle(state, shooter)
    triangles = page_triangles(state, gaps)[key[0]]
    covered = {}
    for triangle, piece, _ in _charted_pieces(triangles, key):
        surface = int(triangles.surfaces[triangle])
        covered[surface] = covered.get(surface, 0.0) + area(piece)
    return max(covered, key=covered.get, default=0)


def page_triangles(state, gaps):
    """Per page its charted triangles (PageTriangles), made at the first thin gap."""
    if gaps.page_triangles is None:
        atlas = state.packed
        corners = state.scene.vertices[state.scene.triangles[atlas.triangles]]
        edges = open_edges(state)
        surfaces = state.surfaces[atlas.triangles]
        gaps.page_triangles = [
            PageTriangles(atlas.texels[on], corners[on], edges[on], atlas.texels[on].min(axis=1),
                          atlas.texels[on].max(axis=1), surfaces[on])
            for on in (atlas.page == index for index in range(atlas.page_count))]
    return gaps.page_triangles


def _texel_rectangle(state, shooter):
    """(page, x0, y0, x1, y1): the rectangle of the shooter's texels on its page, texel i
    spanning [i, i + 1)."""
    (x0, y0), (x1, y1) = shooter.texels.min(axis=0), shooter.texels.max(axis=0) + 1
    return state.pages.index(shooter.page), int(x0), int(y0), int(x1), int(y1)


def _charted_pieces(triangles, key):
    """(triangle, piece, rectangle) for each of the page's triangles (PageTriangles) that
    covers some of the texel rectangle ``key`` (_texel_rectangle): its index, the part of it
    inside, and the rectangle, as complex texel coordinates."""
    _, x0, y0, x1, y1 = key
    low, high = triangles.low, triangles.high
    meets = np.nonzero((low[:, 0] < x1) & (high[:, 0] > x0)
                       & (low[:, 1] < y1) & (high[:, 1] > y0))[0]
    rectangle = [complex(x0, y0), complex(x1, y0), complex(x1, y1), complex(x0, y1)]
    for triangle in meets:
        outline = [complex(x, y) for x, y in triangles.texels[triangle]]
        turn = signed_area(outline)
        if abs(turn) < 1e-12:
            continue
        piece = clipped(outline, rectangle)
        # A triangle touching the rectangle along a side or at a corner leaves a piece of
        # no area, whose outline would cover everything in share_under.
        if len(piece) < 3 or abs(signed_area(piece)) <= 1e-9 * abs(turn):
            continue
        yield triangle, piece, rectangle


def open_edges(state):
    """Per charted triangle, whether each edge (corner i to i + 1) is open: no other
    triangle of its surface, on the same side of the sheet, shares it. A thin gap's light
    leaks out there (edge_band)."""
    scene, atlas = state.scene, state.packed
    ends = np.round(scene.vertices[scene.triangles[atlas.triangles]] / state.bounds.epsilon)
    ends = ends.astype(np.int64)
    starts, stops = ends, np.roll(ends, -1, axis=1)                      # (C, 3, 3)
    # Each edge's two ends in one order: the lesser (lexicographically) first.
    later = np.zeros(starts.shape[:2], dtype=bool)
    for axis in (2, 1, 0):
        later = np.where(starts[..., axis] == stops[..., axis], later,
                         starts[..., axis] > stops[..., axis])
    first = np.where(later[..., None], stops, starts)
    second = np.where(later[..., None], starts, stops)
    back = (scene.back_of[atlas.triangles] >= 0 if scene.back_of is not None
            else np.zeros(len(atlas.triangles), dtype=bool))
    sheet = np.repeat((2 * state.surfaces[atlas.triangles] + back)[:, None, None], 3, axis=1)
    keys = np.concatenate([sheet, first, second], axis=2).reshape(-1, 7)
    _, inverse, counts = unique_rows(keys, return_inverse=True, return_counts=True)
    return (counts[inverse] == 1).reshape(-1, 3)


def receiving_texels(state, gaps):
    """Per page, its receiving texels (Texels), read back at the first thin gap."""
    if gaps.receiving_texels is None:
        gaps.receiving_texels = []
        for page in state.pages:
            position = read_map(page.textures["position"])
            material = read_map(page.textures["material"])
            occupied = (position[..., 3] > 0.0) & (material[..., 3] > 0.0)
            y, x = np.nonzero(occupied)
            order = np.argsort(position[y, x, 0], kind="stable")
            y, x = y[order], x[order]
            area = position[y, x, 3]
            gaps.receiving_texels.append(Texels(
                xy=np.stack([x, y], axis=1), position=position[y, x, :3].astype(np.float64),
                normal=decode_normals(read_map(page.textures["normal"])[y, x]),
                side=np.sqrt(area.astype(np.float64)), area=area, albedo=material[y, x, :3],
                largest_side=float(np.sqrt(area.max(initial=0.0)))))
    return gaps.receiving_texels


def _rgba(rgb):
    """(N, 4) float32 with alpha 0, which blending adds to nothing (a map's alpha holds the
    texel size or an area)."""
    values = np.zeros((len(rgb), 4), dtype=np.float32)
    values[:, :3] = rgb
    return values


def _add_irradiance(state, page, texels, irradiance):
    """Add (N, 3) irradiance to the texels (N, 2) of a page, leaving their unshot light."""
    with render_state(state.ctx, framebuffer=page.receivers,
                      color_mask=[(True,) * 4] + [(False,) * 4] * (
                          len(page.receivers.color_attachments) - 1)):
        blend_points(state, page.receivers, texels, _rgba(irradiance), moderngl.FUNC_ADD)
