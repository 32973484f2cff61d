"""Where a texel at a chart's border tests visibility. A whole texel tests it at four points of
its square (receiver_common.glsl visible_over_texel), which its neighbours show to be
surface; a border texel's square reaches off its surface (beside a lamp's pole, into the
air), so it tested at its sample point alone, and in a level's 2 m texels at a wall's foot or
under a ledge that point stood in a shadow most of the texel's surface is out of (or the
other way round). A border texel now tests at four points of the surface it keeps: those
of the burying's grid (buried.surface_point_rows) nearest its surface's middle plus and minus
each principal half-axis, two points of a uniform strip's Gauss rule along each axis."""
import numpy as np

from . import buried
from .geometry import tangents_of
from .state import decode_normals, read_map

# A texel covering less of its square than this is a border texel (receiver_common.glsl
# COVERED: more, it is whole where its neighbours are on its surface).
WHOLE_TEXEL = 0.98
# A texel whose mean normal is shorter than this bends within it (preprocess.FLAT_SPREAD):
# its points would not lie in its sample's plane.
FLAT_SPREAD = 0.999
# The points' maps (RGBA16F each, two points apiece): offsets from the sample point in the
# tangent plane of its normal (tangent_of() and the bitangent), over the root of its area.
MAPS = ("border_points", "border_points_more")
POINTS = 4


def write(state, tested):
    """Each page's MAPS: four points of each border texel's surface, zero elsewhere (and
    where the grid holds no point of it: a chart under a sixteenth of a texel). ``tested``:
    {charted triangle: buried.SurfacePoints} of the triangles the burying tested, with what
    it keeps of each point; the others keep all."""
    atlas = state.packed
    for index, page in enumerate(state.pages):
        sample = read_map(page.textures["position"]).astype(np.float64)
        stored_normal = read_map(page.textures["normal"])
        edge = read_map(page.textures["unshot"])[..., 3].astype(np.float64)
        border = ((sample[..., 3] > 0.0) & (sample[..., 3] < WHOLE_TEXEL * edge * edge)
                  & (stored_normal[..., 2] >= FLAT_SPREAD))
        offsets = np.zeros(border.shape + (2 * POINTS,), np.float32)
        charted = _touching(atlas, index, border)
        if len(charted):
            rows = buried.surface_point_rows(state.scene, atlas, charted)
            weight = rows.area * _kept(rows, charted, tested)
            chosen = border.reshape(-1)[rows.texel] & (weight > 0.0)
            if chosen.any():
                texel = rows.texel[chosen]
                points, texels = _points(texel, rows.position[chosen], weight[chosen],
                                         sample.reshape(-1, 4),
                                         decode_normals(stored_normal.reshape(-1, 4)[texel]))
                offsets.reshape(-1, 2 * POINTS)[texels] = points
        for name, half in zip(MAPS, (offsets[..., :4], offsets[..., 4:])):
            page.textures[name].write(np.ascontiguousarray(half).astype(np.float16).tobytes())


def _touching(atlas, page, border):
    """The charted triangles of ``page`` whose texels' box holds a texel of ``border``
    (a summed-area table of it)."""
    on_page = np.flatnonzero(atlas.page == page)
    table = np.zeros((border.shape[0] + 1, border.shape[1] + 1), np.int64)
    table[1:, 1:] = border.cumsum(axis=0).cumsum(axis=1)
    uv = atlas.texels[on_page]
    x0, y0 = np.floor(uv.min(axis=1)).astype(np.int64).clip(0).T
    x1 = np.ceil(uv[..., 0].max(axis=1)).astype(np.int64).clip(0, border.shape[1])
    y1 = np.ceil(uv[..., 1].max(axis=1)).astype(np.int64).clip(0, border.shape[0])
    held = table[y1, x1] - table[y0, x1] - table[y1, x0] + table[y0, x0]
    return on_page[held > 0]


def _kept(rows, charted, tested):
    """(N,) what the burying keeps of each of the ``rows`` of the ``charted`` triangles."""
    kept = np.ones(len(rows.owner))
    held = np.bincount(rows.owner, minlength=len(charted))
    starts = np.cumsum(held) - held
    for triangle, points in tested.items():
        at = np.searchsorted(charted, triangle)
        if at < len(charted) and charted[at] == triangle:
            kept[starts[at]:starts[at] + held[at]] = points.kept
    return kept


def _points(texel, position, weight, sample, normal):
    """(texels, 2 * POINTS) offsets of each texel's chosen points, and the texels' rows."""
    rows, group = np.unique(texel, return_inverse=True)
    t = tangents_of(normal)
    b = np.cross(normal, t)
    relative = position - sample[texel, :3]
    xy = np.stack([(relative * t).sum(axis=1), (relative * b).sum(axis=1)], axis=1)
    total = np.bincount(group, weight)

    def mean(values):
        return np.bincount(group, weight * values) / total

    middle = np.stack([mean(xy[:, 0]), mean(xy[:, 1])], axis=1)
    xx = mean(xy[:, 0] ** 2) - middle[:, 0] ** 2
    yy = mean(xy[:, 1] ** 2) - middle[:, 1] ** 2
    xy_moment = mean(xy[:, 0] * xy[:, 1]) - middle[:, 0] * middle[:, 1]
    # The principal axes of [[xx, xy], [xy, yy]], the roots of their variances long.
    heading = 0.5 * np.arctan2(2.0 * xy_moment, xx - yy)
    half_gap = np.sqrt((0.5 * (xx - yy)) ** 2 + xy_moment ** 2)
    axes = []
    for variance, angle in ((0.5 * (xx + yy) + half_gap, heading),
                            (0.5 * (xx + yy) - half_gap, heading + 0.5 * np.pi)):
        axes.append(np.sqrt(np.maximum(variance, 0.0))[:, None]
                    * np.stack([np.cos(angle), np.sin(angle)], axis=1))
    side = np.sqrt(sample[rows, 3])
    chosen = []
    for target in (middle + sign * axis for axis in axes for sign in (1.0, -1.0)):
        distance = ((xy - target[group]) ** 2).sum(axis=1)
        order = np.lexsort((distance, group))
        first = order[np.r_[True, np.diff(group[order]) != 0]]
        chosen.append(xy[first] / side[:, None])
    return np.concatenate(chosen, axis=1), rows
