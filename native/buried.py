"""Surface buried inside solids: where a level's brushes cross (a pillar through the floor, a
step overlapping the next), the part of a texel inside another closed mesh can neither
receive nor send light. Each texel keeps only its open part: its area shrinks to it and its
sample point moves to it, so that what the texel receives and shoots is the open part's.
Inside is decided by the generalized winding number (Jacobson et al. 2013) of each closed,
outward-facing mesh whose box holds the point; a room's shell, whose faces look inwards,
and an open mesh bury nothing."""
from dataclasses import dataclass

import numpy as np

from .geometry import connected_components
from .state import read_map

# Points per texel edge at which a texel's surface is tested, off the texel's middle lines
# by a share of their spacing that no edge of a chart's triangles follows: a point on the
# edge two triangles share would count twice.
SAMPLES_PER_TEXEL = 4
GRID_OFFSET = (0.5 + 0.0137, 0.5 + 0.0291)
# A point this much inside a mesh (its winding number) is buried: 1 deep inside, 1/2 on its
# surface.
BURIED_WINDING = 0.75
# Points are tested this share of a texel in front of their surface: on it, the crossing
# mesh's own faces would count half.
LIFT = 1e-3
# Vertices this share of the scene's size apart are one (a mesh's seams).
WELD = 1e-7
# Meshes of at most this many triangles bury: brushes, pillars, crates, steps. A point is
# weighed against every triangle of a mesh whose box holds it; against a level's large
# closed chunks that took minutes (what they bury is left as it is).
MOST_SOLID_TRIANGLES = 256
# Points and triangles weighed at once (memory).
PAIRS_AT_ONCE = 1 << 22


def keep_open_parts(state):
    """Shrink each texel's area (the position map's w) to its surface's open part and move
    its sample point there, on every page; a texel buried whole gets area 0 and receives
    nothing. Returns the buried area (m^2)."""
    scene, atlas = state.scene, state.packed
    mesh, solids = _solids(scene)
    if not solids:
        return 0.0
    corners = scene.vertices[scene.triangles[atlas.triangles]]
    low, high = corners.min(axis=1), corners.max(axis=1)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    offset = np.einsum("ij,ij->i", normal, corners[:, 0])
    # How far in front of its surface a triangle's points are tested (_surface_points).
    lift = LIFT * np.sqrt(scene.triangle_area[atlas.triangles]
                          / np.maximum(_uv_areas(atlas.texels), 1e-30))
    own = mesh[atlas.triangles]
    points = {}     # charted triangle -> SurfacePoints, made as a solid's box needs them
    for solid_mesh, solid, solid_low, solid_high in solids:
        # Boxes that overlap, not only touch, along each axis the triangle spans: a crate
        # beside a floor's triangle buries none of it, the one standing on it some.
        margin = 1e-6 * (solid_high - solid_low).max()
        flat = high - low <= margin
        overlap = ((high > solid_low + margin) & (low < solid_high - margin)
                   | flat & (high >= solid_low) & (low <= solid_high))
        near = np.nonzero(overlap.all(axis=1) & (own != solid_mesh))[0]
        # Only where the solid reaches from behind the tested points to in front of them.
        heights = solid.reshape(-1, 3) @ normal[near].T - offset[near]
        near = near[(heights.min(axis=0) <= lift[near]) & (heights.max(axis=0) >= lift[near])]
        for charted in near:
            if charted not in points:
                points[charted] = _surface_points(scene, atlas, charted)
            found = points[charted]
            inside_box = np.all((found.lifted >= solid_low) & (found.lifted <= solid_high),
                                axis=1) & ~found.buried
            where = np.nonzero(inside_box)[0]
            if len(where):
                found.buried[where] = (_winding_numbers(solid, found.lifted[where])
                                       > BURIED_WINDING)
    found = [points[charted] for charted in sorted(points) if points[charted].buried.any()]
    if not found:
        return 0.0
    page = np.concatenate([np.full(len(f.texel), f.page) for f in found])
    texel, position, area, buried = (np.concatenate([getattr(f, name) for f in found])
                                     for name in ("texel", "position", "area", "buried"))
    for index, map_page in enumerate(state.pages):
        here = page == index
        if buried[here].any():
            _shrink(map_page, texel[here], position[here], area[here], buried[here])
    return float(area[buried].sum())


@dataclass
class SurfacePoints:
    """A charted triangle's test points, SAMPLES_PER_TEXEL^2 per texel."""
    page: int
    texel: np.ndarray       # (N,) flat texel index on the page
    position: np.ndarray    # (N, 3) world
    lifted: np.ndarray      # (N, 3) LIFT of a texel in front of the surface
    area: np.ndarray        # (N,) world area each stands for
    buried: np.ndarray      # (N,) bool


def _solids(scene):
    """Per scene triangle its mesh (occluding triangles welded into connected meshes, a back
    face's copy its front's; -1 for the rest), and [(mesh, corners (T, 3, 3), box low, box
    high)] of the meshes that are closed (each edge shared by two of their triangles) and
    face outwards (their signed volume about their box's middle is positive). A room's
    shell faces inwards; from inside an open mesh (a lamp shade) its winding number is high
    too, yet light gets there."""
    mesh = np.full(len(scene.triangles), -1, dtype=np.int64)
    triangles = np.nonzero(scene.occlude)[0]
    if not len(triangles):
        return mesh, []
    corners = scene.vertices[scene.triangles[triangles]]
    size = float(np.ptp(scene.vertices, axis=0).max()) or 1.0
    keys = np.round(corners.reshape(-1, 3) / (WELD * size)).astype(np.int64)
    _, welded = np.unique(keys, axis=0, return_inverse=True)
    welded = welded.reshape(-1, 3)
    # Triangles sharing a welded vertex are one mesh.
    vertex_mesh = connected_components(int(welded.max()) + 1,
                                       welded[:, [0, 0]].ravel(), welded[:, [1, 2]].ravel())
    mesh[triangles] = vertex_mesh[welded[:, 0]]
    if scene.back_of is not None:
        copies = scene.back_of >= 0
        mesh[copies] = mesh[scene.back_of[copies]]
    solids = []
    order = np.argsort(mesh[triangles], kind="stable")
    labels = mesh[triangles][order]
    starts = np.r_[0, np.nonzero(np.diff(labels))[0] + 1, len(order)]
    for start, end in zip(starts[:-1], starts[1:]):
        part = corners[order[start:end]]
        if not 4 <= len(part) <= MOST_SOLID_TRIANGLES or not _closed(welded[order[start:end]]):
            continue
        low, high = part.reshape(-1, 3).min(axis=0), part.reshape(-1, 3).max(axis=0)
        about = part - 0.5 * (low + high)
        if np.einsum("ij,ij->i", about[:, 0], np.cross(about[:, 1], about[:, 2])).sum() > 0.0:
            solids.append((int(labels[start]), part, low, high))
    return mesh, solids


def _closed(welded):
    """Whether each edge of the triangles (welded vertex numbers) is shared by two of them."""
    edges = np.sort(np.concatenate([welded[:, [0, 1]], welded[:, [1, 2]], welded[:, [2, 0]]]),
                    axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool((counts == 2).all())


def _surface_points(scene, atlas, charted):
    """The SurfacePoints of charted triangle ``charted``: a grid in its texels, the points
    inside it."""
    step = 1.0 / SAMPLES_PER_TEXEL
    uv = atlas.texels[charted]
    low, high = np.floor(uv.min(axis=0)), np.ceil(uv.max(axis=0))
    u, v = np.meshgrid(np.arange(low[0] + GRID_OFFSET[0] * step, high[0], step),
                       np.arange(low[1] + GRID_OFFSET[1] * step, high[1], step))
    at = np.stack([u.ravel(), v.ravel()], axis=1)
    weights = _barycentric(uv, at)
    inside = (weights > 0.0).all(axis=1)
    at, weights = at[inside], weights[inside]
    corners = scene.vertices[scene.triangles[atlas.triangles[charted]]]
    normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    world_area = 0.5 * np.linalg.norm(normal)
    normal /= max(2.0 * world_area, 1e-30)
    texel_size = np.sqrt(world_area / max(float(_uv_areas(uv)), 1e-30))
    position = weights @ corners
    return SurfacePoints(
        page=int(atlas.page[charted]),
        texel=at[:, 1].astype(np.int64) * atlas.width + at[:, 0].astype(np.int64),
        position=position, lifted=position + LIFT * texel_size * normal,
        area=np.full(len(at), world_area / max(len(at), 1)),
        buried=np.zeros(len(at), dtype=bool))


def _uv_areas(uv):
    """Areas of (..., 3, 2) triangles."""
    edge_a, edge_b = uv[..., 1, :] - uv[..., 0, :], uv[..., 2, :] - uv[..., 0, :]
    return 0.5 * np.abs(edge_a[..., 0] * edge_b[..., 1] - edge_a[..., 1] * edge_b[..., 0])


def _barycentric(uv, points):
    a, b, c = uv
    total = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    wb = ((points[:, 0] - a[0]) * (c[1] - a[1]) - (points[:, 1] - a[1]) * (c[0] - a[0])) / total
    wc = ((b[0] - a[0]) * (points[:, 1] - a[1]) - (b[1] - a[1]) * (points[:, 0] - a[0])) / total
    return np.stack([1.0 - wb - wc, wb, wc], axis=1)


def _winding_numbers(corners, points):
    """The generalized winding number of the triangles ``corners`` (T, 3, 3) at each point:
    the solid angle they span, signed by their facing, over 4 pi (Van Oosterom and
    Strackee's formula)."""
    total = np.zeros(len(points))
    batch = max(1, PAIRS_AT_ONCE // max(len(corners), 1))
    for start in range(0, len(points), batch):
        p = points[start:start + batch, None, None, :]
        a, b, c = (corners[None, :, i, :] - p[:, :, 0, :] for i in range(3))
        la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
        numerator = np.einsum("ptk,ptk->pt", a, np.cross(b, c))
        denominator = (la * lb * lc + np.einsum("ptk,ptk->pt", a, b) * lc
                       + np.einsum("ptk,ptk->pt", b, c) * la
                       + np.einsum("ptk,ptk->pt", c, a) * lb)
        total[start:start + batch] = (2.0 * np.arctan2(numerator, denominator)).sum(axis=1)
    return total / (4.0 * np.pi)


def _shrink(page, texel, position, area, buried):
    """Per texel of the page with a buried point: its area less the buried points' and its
    sample point at its open point nearest their mean (a pillar through a texel's middle
    leaves a ring whose mean is inside it); buried whole, area 0."""
    texture = page.textures["position"]
    stored = read_map(texture).reshape(-1, 4).astype(np.float64)
    touched = np.unique(texel[buried])
    slot = np.searchsorted(touched, texel)
    mine = np.isin(texel, touched)
    lost = np.bincount(slot[mine & buried], weights=area[mine & buried],
                       minlength=len(touched))
    open_points = mine & ~buried
    count = np.bincount(slot[open_points], minlength=len(touched))
    mean = np.stack([np.bincount(slot[open_points], weights=position[open_points, axis],
                                 minlength=len(touched)) for axis in range(3)],
                    axis=1).astype(np.float64)   # bincount of nothing counts in integers
    stored[touched, 3] = np.maximum(stored[touched, 3] - lost, 0.0)
    moved = count > 0
    mean[moved] /= count[moved, None]
    candidates = np.nonzero(open_points)[0]
    if len(candidates):
        distance = np.linalg.norm(position[candidates] - mean[slot[candidates]], axis=1)
        order = np.lexsort((distance, slot[candidates]))
        first = order[np.r_[True, np.diff(slot[candidates][order]) != 0]]
        stored[touched[slot[candidates[first]]], :3] = position[candidates[first]]
    stored[touched[~moved], 3] = 0.0
    texture.write(stored.astype(np.float32).tobytes())
