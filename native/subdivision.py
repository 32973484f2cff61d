"""Adaptive subdivision: after a strong shot's visibility map is drawn, occlusion queries
count each receiving triangle's lit and shadowed texels; where a shadow boundary crosses it,
the texels along the boundary gather at more points from then on (and, with a hemisphere
projection, the casters of the shadow are tessellated as finely). REGULAR subdivision raises
every receiving triangle once, at the start."""
from dataclasses import dataclass

import moderngl
import numpy as np

from .geometry import runs
from .gpu import buffer_content, query_pool, render_state, set_uniform

# Adaptive subdivision looks for shadow boundaries only in shots carrying at least this share
# of the strongest shot's power: the weak late shots add soft light, and each look costs two
# occlusion queries per receiving triangle facing the shooter.
SUBDIVISION_MIN_SHARE = 0.1
# The sun's casters lie in a cylinder along its direction, from this many scene radii behind.
SUN_CASTER_DISTANCE = 4.0
ALL_CHANNELS = (True, True, True, True)
NO_CHANNELS = (False, False, False, False)


@dataclass
class Slots:
    """Per triangle of the lightmap vertex buffer (its 'slot'): page, whether it receives,
    its subdivision level, and (but without subdivision) its geometry and the vertex arrays
    that count and raise its texels."""
    pages: np.ndarray
    receives: np.ndarray
    levels: np.ndarray
    corners: np.ndarray = None
    centres: np.ndarray = None
    normals: np.ndarray = None
    vaos: dict = None


def prepare(state, raster, layout):
    """The Slots of preprocess's RasterVertices (drawn with vertex ``layout``)."""
    scene = state.scene
    slots = Slots(pages=raster.slot_pages, receives=scene.receive[raster.slot_triangles],
                  levels=np.zeros(len(raster.slot_triangles), dtype=np.int32))
    if state.settings.subdivision == "NONE":
        return slots
    corners = scene.vertices[scene.triangles[raster.slot_triangles]]
    slots.corners = corners
    slots.centres = corners.mean(axis=1)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    slots.normals = normals / np.maximum(np.linalg.norm(normals, axis=1), 1e-30)[:, None]
    slots.vaos = {
        name: state.gl.vertex_array(state.programs[name],
                                    [buffer_content(state.programs[name], raster.vbo, layout)])
        for name in ("count", "level")}
    return slots


def raise_levels(state, slots, indices, level, *, visibility=None, view=None):
    """Subdivide the triangles ``indices`` of ``slots`` to ``level``: their texels (only those
    on the shadow boundary of the shot whose ``view`` drew ``visibility``, when given) gather
    light at 4^level points from now on."""
    if len(indices) == 0:
        return
    boundary_only = view is not None
    slots.levels[indices] = np.maximum(slots.levels[indices], level)
    program = state.programs["level"]
    set_uniform(program, "u_level", float(level))
    set_uniform(program, "u_boundary_only", int(boundary_only))
    if boundary_only:
        view.set_uniforms(program, state)
        visibility.texture.use(location=0)
    vao = slots.vaos["level"]
    with render_state(state.ctx, blend=moderngl.MAX):
        for page_slots in _per_page(state, slots, indices, "level_only", ALL_CHANNELS):
            for first, count in runs(page_slots):
                vao.render(moderngl.TRIANGLES, vertices=3 * count, first=3 * first)


def subdivide_shadowed(state, slots, visibility, view, *, clip_below):
    """Adaptive subdivision after the visibility map is drawn: occlusion queries count the
    lit and shadowed texels of each receiving triangle facing the shooter; a triangle whose
    shadowed share lies between the thresholds is refined along the shadow boundary."""
    settings = state.settings
    eye, frame = view.eye, view.frame
    candidates = slots.receives.copy()
    if view.orthographic:
        candidates &= slots.normals @ -frame[:, 2] > 0.0
    else:
        candidates &= ((eye - slots.centres) * slots.normals).sum(axis=1) > 0.0
        if clip_below:
            heights = (slots.corners - eye) @ frame[:, 2]
            candidates &= heights.max(axis=1) > 0.0
    indices = np.nonzero(candidates)[0]
    if len(indices) == 0:
        return
    program = state.programs["count"]
    view.set_uniforms(program, state)
    set_uniform(program, "u_clip_below", int(clip_below))
    visibility.texture.use(location=0)
    queries = query_pool(state.ctx)
    batch = len(queries) // 2
    counts = np.concatenate([_count_shadowed(state, slots, indices[start:start + batch], queries)
                             for start in range(0, len(indices), batch)])
    looked = counts.sum(axis=1)
    share = np.divide(counts[:, 1], looked, out=np.zeros(len(indices)), where=looked > 0)
    shadowed = ((looked > 0) & (share >= settings.subdivision_shadow_min)
                & (share <= settings.subdivision_shadow_max))
    # Each time a triangle shows a shadow boundary it goes one level finer (up to the
    # maximum), and the texels on this shot's boundary take that level.
    next_level = np.minimum(slots.levels[indices] + 1, settings.subdivision_level)
    for level in range(1, settings.subdivision_level + 1):
        raise_levels(state, slots, indices[shadowed & (next_level == level)], level,
                     visibility=visibility, view=view)
    if settings.projection == "HEMISPHERE" and shadowed.any():
        _subdivide_casters(state, slots, visibility, view, indices[shadowed])


def _subdivide_casters(state, slots, visibility, view, receivers):
    """Raise the casters of the subdivided receivers' shadows to the receivers' level: the
    occluders whose bounding spheres meet the cone from the eye to a receiver's bounding
    sphere, in front of it."""
    eye = view.eye
    if view.orthographic:  # the sun: a cylinder along its direction, from far behind
        eye = view.eye - view.frame[:, 2] * SUN_CASTER_DISTANCE * state.bounds.radius
    corners = slots.corners[receivers]
    centres = corners.mean(axis=1)
    radii = np.linalg.norm(corners - centres[:, None], axis=2).max(axis=1)
    levels = slots.levels[receivers]
    axis = centres - eye
    length = np.linalg.norm(axis, axis=1)
    axis /= np.maximum(length, 1e-30)[:, None]
    occluders = visibility.occluders
    to_caster = occluders.centres[None, :, :] - eye                          # (1, O, 3)
    along = (to_caster * axis[:, None, :]).sum(axis=2)                       # (R, O)
    across = np.linalg.norm(to_caster - along[..., None] * axis[:, None, :], axis=2)
    cone = radii[:, None] * np.clip(along, 0.0, None) / np.maximum(length, 1e-30)[:, None]
    radii = occluders.radii
    meets = ((along + radii > 0.0) & (along - radii < length[:, None])
             & (across <= cone + radii))
    wanted = np.max(np.where(meets, levels[:, None], 0), axis=0)
    raised = wanted > visibility.caster_levels
    if raised.any():
        visibility.caster_levels = np.maximum(visibility.caster_levels, wanted)
        visibility.caster_vbo.write(np.repeat(visibility.caster_levels, 3).astype("f4").tobytes())


def _per_page(state, slots, indices, framebuffer, color_mask):
    """Yield the part of ``indices`` on each page, with that page's ``framebuffer`` bound
    under ``color_mask`` and its position, normal and material maps on their units."""
    for page_index in np.unique(slots.pages[indices]):
        page = state.pages[page_index]
        target = getattr(page, framebuffer)
        with render_state(state.ctx, framebuffer=target, color_mask=color_mask):
            target.use()
            page.use_maps("position", "normal", "material")
            yield indices[slots.pages[indices] == page_index]


def _count_shadowed(state, slots, indices, queries):
    """(lit, shadowed) texel counts of each triangle in ``indices``, by occlusion queries."""
    program = state.programs["count"]
    vao = slots.vaos["count"]
    index = 0
    # Only the query counts matter: nothing is written.
    for page_slots in _per_page(state, slots, indices, "unshot_only", NO_CHANNELS):
        for slot in page_slots:
            for hidden in (0, 1):
                set_uniform(program, "u_count_hidden", hidden)
                with queries[index + hidden]:
                    vao.render(moderngl.TRIANGLES, vertices=3, first=3 * int(slot))
            index += 2
    return np.array([query.samples for query in queries[:index]],
                    dtype=np.float64).reshape(-1, 2)
