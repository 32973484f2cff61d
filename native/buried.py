"""Surface hidden from the light. Where a level's brushes cross (a pillar through the floor,
a step overlapping the next), the part of a texel inside another closed mesh can neither
receive nor send light; where two faces lie in one plane facing one way (a floor drawn
twice, two brushes' tops at one height: z-fighting), each point of their overlap is one
surface, not two. Each texel keeps only its open part, and shares its coincident part with
the other faces there: its area shrinks to what it keeps and, where a part is wholly
hidden, its sample point moves off it, so that what the texel receives and shoots is its
own. Inside is decided by the generalized winding number (Jacobson et al. 2013) of each
closed, outward-facing mesh whose box holds the point; a room's shell, whose faces look
inwards, and an open mesh bury nothing."""
from dataclasses import dataclass

import numpy as np

from .geometry import TrianglePlanes, connected_components, tangents_of, unique_rows
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
# Points and triangles weighed, or pairs of triangles tested, at once (memory).
PAIRS_AT_ONCE = 1 << 22
# Triangles whose unit normals round to one at this many steps per unit are tested for
# lying in one plane (a duplicated face's normal is its copy's to the last bits).
NORMAL_STEPS = 1000


def keep_open_parts(state):
    """Shrink each texel's area (the position map's w) to the surface it keeps and move its
    sample point off what it loses whole, on every page; a texel hidden whole gets area 0
    and receives nothing."""
    scene, atlas = state.scene, state.packed
    points = {}     # charted triangle -> SurfacePoints, made as they are needed

    def points_of(charted):
        """The SurfacePoints of the charted triangles ``charted`` (an array), or of one."""
        many = np.atleast_1d(charted)
        missing = np.array([c for c in many if c not in points], dtype=np.int64)
        if len(missing):
            points.update(zip(missing.tolist(), _surface_points(scene, atlas, missing)))
        return [points[c] for c in many.tolist()] if np.ndim(charted) else points[charted]

    planes = TrianglePlanes(scene.vertices[scene.triangles[atlas.triangles]])
    _bury_in_solids(scene, atlas, planes, points_of)
    _share_coincident_faces(scene, atlas, planes, state.bounds.epsilon, points_of)
    found = [points[charted] for charted in sorted(points) if (points[charted].kept < 1).any()]
    if not found:
        return
    page = np.concatenate([np.full(len(f.texel), f.page) for f in found])
    texel, position, area, kept = (np.concatenate([getattr(f, name) for f in found])
                                   for name in ("texel", "position", "area", "kept"))
    for index, map_page in enumerate(state.pages):
        here = page == index
        if (kept[here] < 1).any():
            _shrink(map_page, texel[here], position[here], area[here], kept[here])


def _bury_in_solids(scene, atlas, planes, points_of):
    """Keep nothing of the charted triangles' points (``planes``: their TrianglePlanes)
    inside a closed brush."""
    mesh, solids = _solids(scene)
    if not solids:
        return
    low, high, normal, offset = planes.low, planes.high, planes.normals, planes.offsets
    # How far in front of its surface a triangle's points are tested (_surface_points).
    lift = LIFT * np.sqrt(scene.triangle_area[atlas.triangles]
                          / np.maximum(_uv_areas(atlas.texels), 1e-30))
    own = mesh[atlas.triangles]
    # A back face's copy (Scene.with_back_faces) looks into its own mesh: a closed brush
    # buries it as it buries any face inside it.
    copy = (np.zeros(len(own), bool) if scene.back_of is None
            else scene.back_of[atlas.triangles] >= 0)
    for solid_mesh, solid, solid_low, solid_high in solids:
        # Boxes that overlap, not only touch, along each axis the triangle spans: a crate
        # beside a floor's triangle buries none of it, the one standing on it some.
        margin = 1e-6 * (solid_high - solid_low).max()
        flat = high - low <= margin
        overlap = ((high > solid_low + margin) & (low < solid_high - margin)
                   | flat & (high >= solid_low) & (low <= solid_high))
        near = np.nonzero(overlap.all(axis=1) & ((own != solid_mesh) | copy))[0]
        # Only where the solid reaches from behind the tested points to in front of them.
        heights = solid.reshape(-1, 3) @ normal[near].T - offset[near]
        near = near[(heights.min(axis=0) <= lift[near]) & (heights.max(axis=0) >= lift[near])]
        if not len(near):
            continue
        # The near triangles' points together: one winding-number sum over the solid.
        found = points_of(near)
        lifted = np.concatenate([points.lifted for points in found])
        kept = np.concatenate([points.kept for points in found])
        where = np.nonzero(np.all((lifted >= solid_low) & (lifted <= solid_high), axis=1)
                           & (kept > 0))[0]
        if not len(where):
            continue
        buried = np.zeros(len(kept), dtype=bool)
        buried[where] = _winding_numbers(solid, lifted[where]) > BURIED_WINDING
        ends = np.cumsum([len(points.kept) for points in found])[:-1]
        for points, inside in zip(found, np.split(buried, ends)):
            points.kept[inside] = 0.0


def _share_coincident_faces(scene, atlas, planes, epsilon, points_of):
    """Where charted triangles overlap in one plane facing one way, each keeps of a point
    they share its share: 1 / (the faces there); an emitting face keeps a point from those
    that do not emit (a lamp drawn in the ceiling's plane covers the ceiling, as the
    visibility test has it)."""
    pairs = coincident_pairs(planes, epsilon)
    if not len(pairs):
        return
    emits = scene.emission[atlas.triangles].max(axis=1) > 0.0
    inward, offsets = _edge_planes(planes.corners)
    # A texel's share is over the points of all the triangles in it: sample those that share
    # a texel with a coincident one too.
    points_of(_sharing_texels(atlas, np.unique(pairs)))
    both_ways = np.concatenate([pairs, pairs[:, ::-1]])
    both_ways = both_ways[np.argsort(both_ways[:, 0], kind="stable")]
    starts = np.r_[0, np.nonzero(np.diff(both_ways[:, 0]))[0] + 1, len(both_ways)]
    for start, end in zip(starts[:-1], starts[1:]):
        charted, partners = both_ways[start, 0], both_ways[start:end, 1]
        found = points_of(charted)
        covering, emitting = _covering(inward[partners], offsets[partners], emits[partners],
                                       found.position)
        if emits[charted]:
            found.kept /= 1.0 + emitting
        else:
            found.kept *= np.where(emitting > 0, 0.0, 1.0 / (1.0 + covering))


def _sharing_texels(atlas, charted):
    """The charted triangles whose texel boxes meet those of ``charted`` on their page."""
    low = np.floor(atlas.texels.min(axis=1)).astype(np.int64)
    high = np.ceil(atlas.texels.max(axis=1)).astype(np.int64)
    found = []
    for page in np.unique(atlas.page[charted]):
        marked = np.zeros((atlas.height + 1, atlas.width + 1), dtype=np.int32)
        for index in charted[atlas.page[charted] == page]:
            marked[low[index, 1] + 1:high[index, 1] + 1, low[index, 0] + 1:high[index, 0] + 1] = 1
        summed = marked.cumsum(axis=0, dtype=np.int32).cumsum(axis=1, dtype=np.int32)
        on_page = np.nonzero(atlas.page == page)[0]
        (x0, y0), (x1, y1) = low[on_page].T, high[on_page].T
        meets = summed[y1, x1] - summed[y0, x1] - summed[y1, x0] + summed[y0, x0] > 0
        found.append(on_page[meets])
    return np.concatenate(found)


def coincident_pairs(triangles, epsilon):
    """Pairs (i, j), i < j, of the triangles (TrianglePlanes) that lie in one plane (each
    one's corners within ``epsilon`` of the other's plane), face one way and overlap over
    more than ``epsilon`` across: triangles that only meet along an edge are no pair."""
    corners, normal, offset = triangles.corners, triangles.normals, triangles.offsets
    # Planes: triangles of one rounded normal whose offsets follow each other within
    # epsilon; each plane's triangles in the frame of their rounded normal.
    keys, direction = unique_rows(np.round(normal * NORMAL_STEPS).astype(np.int64),
                                  return_inverse=True)
    order = np.lexsort((offset, direction))
    new_plane = np.r_[True, (np.diff(direction[order]) != 0)
                      | (np.diff(offset[order]) > epsilon)]
    plane = np.empty(len(order), dtype=np.int64)
    plane[order] = np.cumsum(new_plane) - 1
    shared = np.bincount(plane)[plane] > 1
    if not shared.any():
        return np.zeros((0, 2), dtype=np.int64)
    members = np.nonzero(shared)[0]
    axis_normal = keys[direction[members]].astype(np.float64)
    axis_normal /= np.linalg.norm(axis_normal, axis=1, keepdims=True)
    u = tangents_of(axis_normal)
    v = np.cross(axis_normal, u)
    flat = np.stack([np.einsum("tcj,tj->tc", corners[members], u),
                     np.einsum("tcj,tj->tc", corners[members], v)], axis=2)   # (M, 3, 2)
    # Boxes overlapping along the plane's u: each plane's triangles in turn along one line
    # (planes a span apart), then those meeting the box along v.
    low, high = flat.min(axis=1), flat.max(axis=1)
    span = float((high[:, 0] - low[:, 0]).max() + np.ptp(low[:, 0])) + 1.0
    line_low = low[:, 0] - low[:, 0].min() + plane[members] * span
    line_high = line_low + (high[:, 0] - low[:, 0])
    order = np.argsort(line_low, kind="stable")
    ends = np.searchsorted(line_low[order], line_high[order] - epsilon)
    pairs = []
    for first, last in _ranges_at_once(np.arange(len(order)) + 1, ends):
        counts = np.maximum(ends[first:last] - np.arange(first, last) - 1, 0)
        a = np.repeat(np.arange(first, last), counts)
        b = np.arange(len(a)) - np.repeat(np.cumsum(counts) - counts, counts) + a + 1
        a, b = order[a], order[b]
        meets = (high[a, 1] > low[b, 1] + epsilon) & (high[b, 1] > low[a, 1] + epsilon)
        a, b = a[meets], b[meets]
        i, j = members[a], members[b]
        in_plane = (np.abs(np.einsum("tcj,tj->tc", corners[j], normal[i])
                           - offset[i, None]).max(axis=1) <= epsilon) \
            & (np.abs(np.einsum("tcj,tj->tc", corners[i], normal[j])
                      - offset[j, None]).max(axis=1) <= epsilon)
        overlap = in_plane & _overlap_2d(flat[a], flat[b], epsilon)
        pairs.append(np.stack([np.minimum(i, j), np.maximum(i, j)], axis=1)[overlap])
    return np.concatenate(pairs) if pairs else np.zeros((0, 2), dtype=np.int64)


def _ranges_at_once(starts, ends):
    """Runs [first, last) of rows whose ranges [starts, ends) hold about PAIRS_AT_ONCE
    items together (memory)."""
    total = np.cumsum(np.maximum(ends - starts, 0))
    first = 0
    while first < len(starts):
        last = max(int(np.searchsorted(total, total[first] - (ends[first] - starts[first])
                                       + PAIRS_AT_ONCE, side="right")), first + 1)
        yield first, min(last, len(starts))
        first = last


def _overlap_2d(a, b, epsilon):
    """Whether the 2D triangles a[k] and b[k] ((K, 3, 2) each) overlap over more than
    ``epsilon`` across along each of their edges' normals (the separating axis test)."""
    overlap = np.ones(len(a), dtype=bool)
    for triangle in (a, b):
        edges = np.roll(triangle, -1, axis=1) - triangle
        axes = np.stack([-edges[..., 1], edges[..., 0]], axis=2)
        axes /= np.maximum(np.linalg.norm(axes, axis=2, keepdims=True), 1e-30)
        for edge in range(3):
            on_a = np.einsum("tcj,tj->tc", a, axes[:, edge])
            on_b = np.einsum("tcj,tj->tc", b, axes[:, edge])
            overlap &= (np.minimum(on_a.max(axis=1), on_b.max(axis=1))
                        - np.maximum(on_a.min(axis=1), on_b.min(axis=1))) > epsilon
    return overlap


def _edge_planes(corners):
    """Per triangle of ``corners`` (T, 3, 3), its edges' inward directions in its plane
    (T, 3, 3) and their offsets (T, 3): a point of the plane is inside where its products
    with the three exceed the offsets."""
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    inward = np.cross(normal[:, None, :], np.roll(corners, -1, axis=1) - corners)
    return inward, np.einsum("tej,tej->te", inward, corners)


def _covering(inward, offsets, emits, points):
    """How many of the triangles given by _edge_planes hold each point on their plane, and
    how many of those that ``emits``."""
    count = len(inward)
    inward, offsets = inward.reshape(-1, 3).T, offsets.reshape(-1)
    covering, emitting = np.zeros(len(points), np.int64), np.zeros(len(points), np.int64)
    batch = max(1, PAIRS_AT_ONCE // max(inward.shape[1], 1))
    for start in range(0, len(points), batch):
        inside = (points[start:start + batch] @ inward > offsets).reshape(-1, count, 3)
        inside = inside.all(axis=2)
        covering[start:start + batch] = inside.sum(axis=1)
        emitting[start:start + batch] = inside[:, emits].sum(axis=1)
    return covering, emitting


@dataclass
class SurfacePoints:
    """A charted triangle's test points, SAMPLES_PER_TEXEL^2 per texel."""
    page: int
    texel: np.ndarray       # (N,) flat texel index on the page
    position: np.ndarray    # (N, 3) world
    lifted: np.ndarray      # (N, 3) LIFT of a texel in front of the surface
    area: np.ndarray        # (N,) world area each stands for
    kept: np.ndarray        # (N,) the triangle's share: 0 buried or under an emitting face,
                            # 1 / k among k coincident faces


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
    _, welded = unique_rows(keys, return_inverse=True)
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
    _, counts = unique_rows(edges, return_counts=True)
    return bool((counts == 2).all())


def _surface_points(scene, atlas, charted):
    """The SurfacePoints of each charted triangle of ``charted``: a grid in its texels, the
    points inside it."""
    step = 1.0 / SAMPLES_PER_TEXEL
    uv = atlas.texels[charted]
    low, high = np.floor(uv.min(axis=1)), np.ceil(uv.max(axis=1))
    columns, rows = np.round((high - low) * SAMPLES_PER_TEXEL).astype(np.int64).T
    corners = scene.vertices[scene.triangles[atlas.triangles[charted]]]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    world_area = 0.5 * np.linalg.norm(normal, axis=1)
    normal /= np.maximum(2.0 * world_area, 1e-30)[:, None]
    texel_size = np.sqrt(world_area / np.maximum(_uv_areas(uv), 1e-30))
    found = []
    counts = columns * rows
    for first, last in _ranges_at_once(np.zeros_like(counts), counts):
        part = np.arange(first, last)
        owner = np.repeat(part, counts[part])
        index = np.arange(len(owner)) - np.repeat(np.cumsum(counts[part]) - counts[part],
                                                  counts[part])
        at = low[owner] + step * (np.stack([index % columns[owner], index // columns[owner]],
                                           axis=1) + GRID_OFFSET)
        weights = _barycentric(uv[owner], at)
        inside = (weights > 0.0).all(axis=1)
        owner, at, weights = owner[inside], at[inside], weights[inside]
        position = np.einsum("pc,pcj->pj", weights, corners[owner])
        held = np.bincount(owner - first, minlength=last - first)
        for k, (start, end) in enumerate(zip(np.cumsum(held) - held, np.cumsum(held))):
            triangle = first + k
            found.append(SurfacePoints(
                page=int(atlas.page[charted[triangle]]),
                texel=(at[start:end, 1].astype(np.int64) * atlas.width
                       + at[start:end, 0].astype(np.int64)),
                position=position[start:end],
                lifted=position[start:end] + LIFT * texel_size[triangle] * normal[triangle],
                area=np.full(end - start, world_area[triangle] / max(end - start, 1)),
                kept=np.ones(end - start)))
    return found


def _uv_areas(uv):
    """Areas of (..., 3, 2) triangles."""
    edge_a, edge_b = uv[..., 1, :] - uv[..., 0, :], uv[..., 2, :] - uv[..., 0, :]
    return 0.5 * np.abs(edge_a[..., 0] * edge_b[..., 1] - edge_a[..., 1] * edge_b[..., 0])


def _barycentric(uv, points):
    """Barycentric weights of each point (N, 2) in its triangle uv (N, 3, 2)."""
    a, b, c = uv[:, 0], uv[:, 1], uv[:, 2]
    total = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    wb = ((points[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
          - (points[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])) / total
    wc = ((b[:, 0] - a[:, 0]) * (points[:, 1] - a[:, 1])
          - (b[:, 1] - a[:, 1]) * (points[:, 0] - a[:, 0])) / total
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


def _shrink(page, texel, position, area, kept):
    """Per texel of the page with a point it does not keep whole: its area less the points
    it keeps nothing of and, where it has such points, its sample point at its kept point
    nearest their mean (a pillar through a texel's middle leaves a ring whose mean is inside
    it); nothing kept, area 0. Of what it shares with coincident faces it sends that share
    alone into the room: its reflectance and emission scale by what it keeps of its area,
    and page.share holds it for the ledger."""
    texture = page.textures["position"]
    stored = read_map(texture).reshape(-1, 4).astype(np.float64)
    touched = np.unique(texel[kept < 1])
    slot = np.searchsorted(touched, texel)
    mine = np.isin(texel, touched)
    hidden, shared = mine & (kept == 0), mine & (kept > 0)
    lost = np.bincount(slot[hidden], weights=area[hidden], minlength=len(touched))
    stored[touched, 3] = np.maximum(stored[touched, 3] - lost, 0.0)
    moving = np.unique(slot[hidden])
    kept_points = shared & np.isin(slot, moving)
    count = np.bincount(slot[kept_points], minlength=len(touched))
    mean = np.stack([np.bincount(slot[kept_points], weights=position[kept_points, axis],
                                 minlength=len(touched)) for axis in range(3)],
                    axis=1).astype(np.float64)   # bincount of nothing counts in integers
    moved = count > 0
    mean[moved] /= count[moved, None]
    candidates = np.nonzero(kept_points)[0]
    if len(candidates):
        distance = np.linalg.norm(position[candidates] - mean[slot[candidates]], axis=1)
        order = np.lexsort((distance, slot[candidates]))
        first = order[np.r_[True, np.diff(slot[candidates][order]) != 0]]
        stored[touched[slot[candidates[first]]], :3] = position[candidates[first]]
    stored[touched[np.bincount(slot[shared], minlength=len(touched)) == 0], 3] = 0.0
    texture.write(stored.astype(np.float32).tobytes())
    given = np.bincount(slot[shared], weights=(area * (1.0 - kept))[shared],
                        minlength=len(touched))
    if given.any():
        sampled = np.bincount(slot[shared], weights=area[shared], minlength=len(touched))
        share = np.clip(1.0 - given / np.maximum(sampled, 1e-30), 0.0, 1.0)
        _send_share(page, touched[given > 0], share[given > 0])


def _send_share(page, texels, share):
    """Scale the texels' (flat indices) reflectance and emission (the unshot map holds it
    yet) by ``share`` and keep it in page.share."""
    material = page.textures["material"]
    raw = np.frombuffer(material.read(), dtype=np.uint16).reshape(-1, 4).copy()
    raw[texels, :3] = np.round(raw[texels, :3] * share[:, None]).astype(np.uint16)
    material.write(raw.tobytes())
    unshot = page.textures["unshot"]
    emitted = read_map(unshot).reshape(-1, 4)
    emitted[texels, :3] *= share[:, None].astype(np.float32)
    unshot.write(emitted.tobytes())
    page.share = np.ones((material.height, material.width), dtype=np.float32)
    page.share.reshape(-1)[texels] = share
