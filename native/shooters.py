"""Shooter construction: the selected regions' maps read back in one wait for the GPU, and
from each region (or its finer parts) a shooter: the coplanar texels around the strongest
with similar unshot radiance, that no occluder standing in the block hides from it, in a
rectangle, and the quad they shoot from."""
from dataclasses import dataclass, field
import math
from typing import NamedTuple

import numpy as np

from . import lobes
from .geometry import (chart_quad, lightmap_tangent, quad_in_plane, rectangle_around,
                       region_charts, shooter_quad, vector_cross, vector_length)
from .state import Region, Shooter, decode_normals, decode_surface_normals

# A shooter takes the texels of its block whose unshot radiance is at least this share of the
# strongest one's; the rest wait for a later shot. Lumping a bright corner with dim texels
# would shoot the bright energy from the wrong place (across a shadow boundary, say).
SIMILAR_RADIANCE = 0.25
# A shooter's texels face within this cosine of its strongest texel's normal, and lie within
# this share of the block's side (in the strongest texel's size) of its plane.
COPLANAR_COSINE = 0.95
COPLANAR_DEPTH = 0.25
# A chart's texel-to-world map shapes a shooter's quad where its steps lie within this sine
# of the shooter's plane; on a curved chart (steps averaged around a bend) the quad is the
# rectangle around the shooter's texels in its own plane.
FLAT_CHART_SINE = 0.1
# A plane crosses a shooting block when texels lie this share of a texel beyond it each way.
CROSSING_MARGIN = 1e-3
# A texel's way to a shooter's strongest texel is blocked where it passes this share of a
# texel or less from an occluder crossing the block (unblocked_members): the shot's centre
# lies off the strongest texel.
BLOCKING_REACH = 0.25
# A shooter's quad shoots as SHOOTER_CELLS x SHOOTER_CELLS cells, each at the radiance of the
# texels in it and with its own glossy lobe (receive_patch.frag gathers them one by one near
# the shooter): a hot spot a lamp makes on a wall beside it, shot at the block's mean
# radiance, lit the lamp facing the spot's bright middle as much as the block's dim edge.
# Every shooter, even or not: shots gathered by cells only where their light varied split
# the transport in two by the light itself, which then no longer held a closed room's light
# (its corners too bright).
SHOOTER_CELLS = 2
# What a shooter reads of its block: (attachment of state.Page.blocks, components); the last,
# the incoming directions, where the scene needs lobes (BakeState.glossy_lobes).
BLOCK_MAPS = ((0, 4), (1, 4), (2, 4), (3, 4), (4, 4))


@dataclass
class BlockMaps:
    """A region's maps read back, as float64 rows (row-major within the region)."""
    position: np.ndarray    # (N, 4): xyz, area
    normal: np.ndarray      # (N, 3) at the sample point
    surface_normal: np.ndarray  # (N, 4): the mean of the covered surface's normals, and its
    #                             length (state.decode_surface_normals)
    unshot: np.ndarray      # (N, 4): radiance, texel size
    surface: np.ndarray     # (N,) surface numbers
    reflectance: np.ndarray  # (N, 3)
    incoming: np.ndarray    # (N, 4): where the unshot light came from (lobes.py); None
    #                         in scenes that keep none (BakeState.glossy_lobes)

    def rows(self, rows):
        return BlockMaps(*(None if values is None else values[rows] for values in (
            self.position, self.normal, self.surface_normal, self.unshot, self.surface,
            self.reflectance, self.incoming)))


class CrossingOccluders(NamedTuple):
    """The occluders near a block whose planes have some of its texels on each side."""
    normals: np.ndarray     # (P, 3)
    offsets: np.ndarray     # (P,)
    corners: np.ndarray     # (P, 3, 3)


@dataclass
class ShooterCaches:
    """What shooter construction keeps: the read-back buffer, and per region (texels do not
    move, and blocks are shot many times) the occluders' planes crossing it and its charts."""
    occluders: object                               # geometry.TrianglePlanes
    staging: object                                 # buffer: BLOCK_MAPS of a selection
    crossing_occluders: dict = field(default_factory=dict)   # Region: CrossingOccluders
    region_charts: dict = field(default_factory=dict)


def staging_bytes(settings, block):
    """The staging buffer's size: the BLOCK_MAPS of every block of a selection."""
    return (settings.shooters_per_selection * block * block * 4
            * sum(components for _, components in BLOCK_MAPS))


def read_blocks(state, caches, regions):
    """Per Region its BlockMaps, queued into one staging buffer and read back once."""
    offset, views = 0, []
    maps = len(BLOCK_MAPS) - (0 if state.glossy_lobes else 1)
    for region in regions:
        page = state.pages[region.page]
        width, height = region.width_on(state.packed), region.height_on(state.packed)
        count = width * height
        for attachment, components in BLOCK_MAPS[:maps]:
            page.blocks.read_into(caches.staging, viewport=(region.x0, region.y0, width, height),
                                  components=components, attachment=attachment, dtype="f4",
                                  write_offset=offset)
            views.append((offset // 4, count, components))
            offset += count * components * 4
    data = np.frombuffer(caches.staging.read(size=offset), dtype="f4").astype(np.float64)
    rows = [data[start:start + components * count].reshape(count, components)
            for start, count, components in views]
    per_region = [rows[i::maps] for i in range(maps)]
    if not state.glossy_lobes:
        per_region.append([None] * len(regions))
    blocks = []
    for position, normal, unshot, material, incoming in zip(*per_region):
        sample_normals = decode_normals(normal)
        blocks.append(BlockMaps(position, sample_normals,
                                decode_surface_normals(sample_normals, normal), unshot,
                                np.floor(material[:, 3] * 65535.0 + 0.5),  # decode_surface()
                                material[:, :3], incoming))
    return blocks


def parts(state, region, maps, finer):
    """The region, or its sub-blocks ``finer`` levels down, each with its rows of the maps
    (row-major within the sub-block, as make_shooter reads them) and their indices in the
    region's."""
    if finer == 0:
        yield region, maps, np.arange(len(maps.position))
        return
    width, height = region.width_on(state.packed), region.height_on(state.packed)
    part = region.size >> finer
    index = np.arange(width * height)
    column, row = index % width, index // width
    for y in range(0, height, part):
        for x in range(0, width, part):
            rows = index[(column >= x) & (column < x + part) & (row >= y) & (row < y + part)]
            yield (Region(region.page, region.x0 + x, region.y0 + y, part),
                   maps.rows(rows), rows)


def charts_of(state, caches, region, maps, rows):
    """For a part of ``region`` (its ``rows`` of the region's maps): the chart label of each
    of its texels and the charts (geometry.region_charts). Once per region."""
    charts = caches.region_charts.get(region)
    if charts is None:
        charts = caches.region_charts[region] = region_charts(
            maps.position, maps.unshot[:, 3], region.width_on(state.packed),
            (region.x0, region.y0))
    return charts.labels[rows], charts.by_label


def make_shooter(state, caches, region, maps, charts):
    """The shooter of a block from its maps: the coplanar part of the block around its
    strongest texel with similar unshot radiance (blocks at coarse levels may also hold
    texels of other charts, which keep their energy). None when it holds no unshot power."""
    page = state.pages[region.page]
    width = region.width_on(state.packed)
    position, normal, unshot, reflectance = (maps.position, maps.normal, maps.unshot,
                                             maps.reflectance)
    area, radiance, texel_size = position[:, 3], unshot[:, :3], unshot[:, 3]
    power = radiance.mean(axis=1) * area
    strongest = int(np.argmax(power))
    if power[strongest] <= 0.0:
        return None
    n0, p0 = normal[strongest], position[strongest, :3]
    density = power / np.maximum(area, 1e-30)
    coplanar = ((power > 0.0) & (normal @ n0 > COPLANAR_COSINE)
                & (np.abs((position[:, :3] - p0) @ n0)
                   <= COPLANAR_DEPTH * region.size * texel_size[strongest]))
    members = np.nonzero(coplanar & (density >= SIMILAR_RADIANCE * density[strongest]))[0]
    members = unblocked_members(caches, region, strongest, members, position,
                                texel_size[strongest])
    members = rectangle_around(members, strongest, width, len(area) // width)
    weights = area[members, None]
    total_area = float(weights.sum())
    centre = (position[members, :3] * weights).sum(axis=0) / total_area
    # Facing as the surface the texels cover does: a texel's sample normal is one facet's.
    n = (maps.surface_normal[members, :3] * weights).sum(axis=0)
    n /= vector_length(n)
    texels = np.stack([members % width, members // width], axis=1)
    # The shooter's plane in front of its texels' surface, not through their centroid: the
    # texels of a curved sheet bulge past the plane through their centroid, where the
    # sheet's back faces (an emitter's back-face copy) were in front of the shooter, a
    # millimetre from its quad; and a sheet bending within a texel rises past its sample
    # point, where a quad through it poked through a glowing lamp shade's shell, in front
    # of the shell's other side.
    centre = centre + n * (float((((position[members, :3] - centre) @ n)
                                  + _own_bend_rise(maps.surface_normal[members, 3],
                                                   texel_size[members])).max())
                           + _bend_rise(texels, position[members, :3], normal[members]))
    t = lightmap_tangent(texels, position[members, :3], n)
    b = vector_cross(n, t)
    taken = unshot[members].astype(np.float32)
    taken[:, 3] = 0.0   # the texel size stays
    labels, by_label = charts
    chart = by_label.get(int(labels[strongest]))
    origin = (region.x0, region.y0)
    if chart is not None and _lies_along(chart, n):
        quad = chart_quad(texels + origin, position[members, :3], chart, total_area,
                          normal=n)
        # Into the shooter's plane: what lies in front of the shooter must lie in front of
        # its quad.
        quad = quad_in_plane(quad, centre, n, total_area)
    else:
        quad = shooter_quad(position[members, :3] - centre, texel_size[members], t, b,
                            total_area, centre)
    surface = int(maps.surface[strongest])
    taken_power = (radiance[members] * weights).sum(axis=0)
    reflection = lobes.Reflection(power=taken_power, lobe=lobes.diffuse())
    if state.glossy:
        at = (texels + origin)[:, ::-1].T
        reflection = lobes.reflect(
            n, None if maps.incoming is None else maps.incoming[members] * weights,
            radiance[members] * weights,
            reflectance[members], _glossy_colour(state, page, texels + origin,
                                                 reflectance[members]),
            page.roughness[tuple(at)].astype(np.float64), fresnel=state.scene.glossy_fresnel)
    mean_radiance = reflection.power / total_area
    shares = _cell_shares(quad, position[members, :3], texel_size[members])
    return Shooter(
        page=page, texels=texels + origin,
        centre=centre, frame=np.stack([t, b, n], axis=1), area=total_area, quad=quad,
        radiance=mean_radiance,
        cell_radiance=_cell_radiance(shares, radiance[members] * weights, mean_radiance),
        unshot=taken,
        incoming=None if maps.incoming is None else maps.incoming[members].astype(np.float32),
        lobe=reflection.lobe,
        cell_lobes=lobes.cell_lobes(reflection.lobe, n, np.zeros((shares.shape[1], 4))
                                    if maps.incoming is None
                                    else shares.T @ (maps.incoming[members] * weights)),
        surplus=math.pi * (reflection.power - taken_power),
        # Texels that do not receive (surface 0: an emitter's back) take no light, so a thin
        # gap's light does not bounce off them.
        albedo=((reflectance[members] * weights).sum(axis=0) / total_area if surface > 0
                else np.zeros(3)),
        surface=surface, emits=bool(_emitting(state, page, texels + origin).any()))


def _cell_shares(quad, points, sizes):
    """(N, SHOOTER_CELLS^2) the share of each texel, at ``points`` with squares of side
    ``sizes``, in each cell of ``quad`` (row by row from its first corner, along its first
    edge). By overlap, not by sample point: a shooter of one texel, or one texel wide, would
    put its power in one cell of its own quad, a quarter texel off."""
    corners = np.asarray(quad, dtype=np.float64)
    edges = np.stack([corners[1] - corners[0], corners[3] - corners[0]], axis=1)   # (3, 2)
    along = np.linalg.lstsq(edges, (points - corners[0]).T, rcond=None)[0].T     # (N, 2)
    half = 0.5 * sizes[:, None] / np.linalg.norm(edges, axis=0)[None, :]           # (N, 2)
    bounds = np.arange(SHOOTER_CELLS + 1) / SHOOTER_CELLS
    # Each texel's square, kept within the quad, over each cell along each edge.
    low = np.clip(along - half, 0.0, 1.0)[..., None]
    high = np.clip(along + half, 0.0, 1.0)[..., None]
    overlap = (np.minimum(high, bounds[1:]) - np.maximum(low, bounds[:-1])).clip(0.0, None)
    inside = overlap.sum(axis=2, keepdims=True)
    nearest = np.clip((along * SHOOTER_CELLS).astype(int), 0, SHOOTER_CELLS - 1)
    overlap = np.where(inside > 0.0, overlap / np.maximum(inside, 1e-30),
                       np.arange(SHOOTER_CELLS) == nearest[..., None])        # (N, 2, cells)
    return (overlap[:, 1, :, None] * overlap[:, 0, None, :]).reshape(len(points), -1)


def _cell_radiance(shares, powers, radiance):
    """(SHOOTER_CELLS^2, 3) the radiance of each cell from the ``powers`` of the texels in it
    (``shares``: _cell_shares): their shares of the shooter's mean ``radiance``, so that the
    cells shoot what it does."""
    per_cell = shares.T @ powers
    total = per_cell.sum(axis=0)
    count = shares.shape[1]
    share = np.divide(per_cell, total, out=np.full((count, 3), 1.0 / count), where=total > 0.0)
    return share * count * radiance


def _glossy_colour(state, page, texels, reflectance):
    """(N, 3) per texel what its glossy layers reflect at normal incidence: its reflectance
    beyond the diffuse albedo; none where emission not yet shot is in its unshot light
    (emitters shoot as if diffuse)."""
    glossy = (reflectance - page.albedo[texels[:, 1], texels[:, 0]]).clip(0.0, None)
    glossy[_emitting(state, page, texels)] = 0.0
    return glossy


def _emitting(state, page, texels):
    """(N,) bool: which of a page's ``texels`` hold emission not yet shot."""
    emitting, power = page.emission_left
    if not len(emitting):
        return np.zeros(len(texels), dtype=bool)
    flat = texels[:, 1].astype(np.int64) * state.packed.width + texels[:, 0]
    where = np.searchsorted(emitting, flat).clip(0, len(emitting) - 1)
    return (emitting[where] == flat) & (power[where].max(axis=1) > 0.0)


def _lies_along(chart, normal):
    """Whether the chart's steps along both lightmap axes lie in the plane of ``normal``."""
    steps = chart.basis.T
    return bool((np.abs(steps @ normal)
                 <= FLAT_CHART_SINE * np.linalg.norm(steps, axis=1)).all())


def _own_bend_rise(spreads, sizes):
    """(N,) how far the surface within each texel (of side ``sizes``) can rise past its
    sample point's plane: half the texel's diagonal times the sine of the angle between its
    mean normal and its normals (their spread, the mean's length, is its cosine)."""
    return 0.5 * math.sqrt(2.0) * sizes * np.sqrt(np.clip(1.0 - spreads * spreads, 0.0, 1.0))


def _bend_rise(texels, points, normals):
    """How far a sheet bending between neighbouring texels can rise past both sample points:
    half their distance times the sine of half the bend (the crest of two facets meeting
    halfway between them), where it bends away from their front (a concave bend sags)."""
    if (normals == normals[0]).all():
        return 0.0   # a flat sheet
    low = texels.min(axis=0)
    rows = np.full(tuple(np.ptp(texels, axis=0)[::-1] + 1), -1)
    rows[texels[:, 1] - low[1], texels[:, 0] - low[0]] = np.arange(len(texels))
    rise = 0.0
    for a, b in ((rows[:, :-1], rows[:, 1:]), (rows[:-1], rows[1:])):   # along x, then y
        both = (a >= 0) & (b >= 0)
        a, b = a[both], b[both]
        if len(a) == 0:
            continue
        distance = np.linalg.norm(points[a] - points[b], axis=1)
        half_bend_sine = 0.5 * np.linalg.norm(normals[a] - normals[b], axis=1)
        convex = ((normals[b] - normals[a]) * (points[b] - points[a])).sum(axis=1) > 0.0
        rise = max(rise, float((0.5 * distance * half_bend_sine * convex).max()))
    return rise


def unblocked_members(caches, region, strongest, members, position, texel_size):
    """The members whose straight way to the strongest texel no occluder standing in the
    block blocks (a wall standing on the floor, a shelf touching a cabinet): shot from one
    centre, texels on both sides would light each side from the other. An occluder blocks
    where its triangle, grown by BLOCKING_REACH texels, meets the way, not its whole plane:
    a crate standing on a level's floor kept the floor beyond each of its sides' planes for
    later shots, most of the block. The others stay unshot for a later shot."""
    if len(members) < 2:
        return members
    points = position[:, :3]
    if region not in caches.crossing_occluders:   # blocks are shot many times: once per block
        caches.crossing_occluders[region] = _occluders_crossing(
            caches.occluders, points[position[:, 3] > 0.0], texel_size)
    crossing = caches.crossing_occluders[region]
    if len(crossing.offsets) == 0:
        return members
    normals, offsets = crossing.normals, crossing.offsets
    start = points[strongest]
    own = start @ normals.T - offsets                                 # (planes,)
    other = points[members] @ normals.T - offsets                     # (members, planes)
    margin = CROSSING_MARGIN * texel_size
    crosses = (own * other < 0.0) & (np.abs(own) > margin) & (np.abs(other) > margin)
    share = own / np.where(crosses, own - other, 1.0)                 # along the way
    at = start + share[..., None] * (points[members, None, :] - start)  # (members, planes, 3)
    near = _near_triangles(at, crossing.corners, BLOCKING_REACH * texel_size)
    return members[~(crosses & near).any(axis=1)]


def _near_triangles(points, corners, reach):
    """(M, P) whether each of ``points`` (M, P, 3), in the plane of triangle P
    (``corners`` (P, 3, 3)), lies in it or within ``reach`` of its edges."""
    inside = np.ones(points.shape[:2], dtype=bool)
    near_edge = np.zeros(points.shape[:2], dtype=bool)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    for i in range(3):
        a, b = corners[:, i], corners[:, (i + 1) % 3]
        edge = b - a
        to_point = points - a
        inside &= (np.cross(edge, to_point) * normal).sum(axis=-1) >= 0.0
        along = np.clip((to_point * edge).sum(axis=-1)
                        / np.maximum((edge * edge).sum(axis=-1), 1e-30), 0.0, 1.0)
        gap = np.linalg.norm(to_point - along[..., None] * edge, axis=-1)
        near_edge |= gap <= reach
    return inside | near_edge


def _occluders_crossing(occluders, points, texel_size):
    """The CrossingOccluders of the occluders near ``points`` whose planes have some of them
    on each side."""
    near = occluders.within(points.min(axis=0) - texel_size, points.max(axis=0) + texel_size)
    normals, offsets = occluders.normals[near], occluders.offsets[near]
    sides = points @ normals.T - offsets
    margin = CROSSING_MARGIN * texel_size
    crossing = (sides.max(axis=0) > margin) & (sides.min(axis=0) < -margin)
    return CrossingOccluders(normals[crossing], offsets[crossing],
                             occluders.corners[near][crossing])
