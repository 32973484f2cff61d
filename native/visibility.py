"""Visibility: the distance map around a shot's eye (the hemicube's faces, one or two
stereographic or nonlinear hemispheres, or the sun's orthographic window), into which every
occluding triangle is drawn with its surface number; the receivers test against it. The
occluders lie in clusters of nearby triangles: a one-sided shooter draws only the clusters
that reach above its plane, and a cube drawn face by face only those that reach into each
face. A batch of shooters draws a hemicube each into one map, six layers each
(render_batch)."""
import moderngl
import numpy as np

from . import memory
from .geometry import TrianglePlanes
from .gpu import render_state, set_uniform
from .state import VisibilityMap

# How many cube faces a view draws (render): the hemicube in front of a shooter, all round a
# point light (the sun's orthographic window: BakeState.sun_faces tiles). Hemisphere
# projections draw the front hemisphere, or both for ALL_FACES.
FRONT_FACES = 5
ALL_FACES = 6
# The map starts at this distance everywhere (nothing drawn), and a texel under
# DRAWN_DISTANCE holds something.
CLEAR_DISTANCE = 3.0e38
DRAWN_DISTANCE = 1e38
# covered_shares() counts this many map texels per point (llvmpipe ends a loop, nested ones
# counted together, after 65535 turns).
COUNTED_TEXELS = 32768
# A scene without occluders draws one triangle out here, which keeps the buffers valid.
FAR_AWAY = 1e30
# Triangles per cluster (consecutive in the vertex buffer, in Morton order of their centres).
CLUSTER_TRIANGLES = 64
# Bits per axis of the Morton code that orders the triangles into clusters.
MORTON_BITS = 10
# Each cube face's frame (projection.glsl's FACE_RIGHT, FACE_UP, FACE_FORWARD) in the view's:
# the face sees what lies within forward +- right and forward +- up.
FACE_RIGHT = np.array([(1, 0, 0), (0, 1, 0), (0, -1, 0), (-1, 0, 0), (1, 0, 0), (1, 0, 0)],
                      dtype=np.float64)
FACE_UP = np.array([(0, 1, 0), (0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1), (0, -1, 0)],
                   dtype=np.float64)
FACE_FORWARD = np.array([(0, 0, 1), (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, -1)],
                        dtype=np.float64)
# The per-face draws (llvmpipe's path) hold at most this many clusters: on long draws whose
# triangles it clips, llvmpipe's vertex stage walks all of the draw's vertices each time its
# small buffer of set-up vertices fills (as profiled), which made one draw per run of clusters
# slower than the geometry shader (BENCHMARKS.md, "Scaling with texel density").
PER_FACE_DRAW_CLUSTERS = 2
# The clusters' bounds grow by this share of the coordinates' size (the farthest eye's): the
# shaders place corners in single precision, a cluster just outside a plane in double may
# draw a fragment inside it.
CLUSTER_PAD = 2.0 ** -18


def create(state):
    """The visibility map (memory.visibility_layers: a cube's six faces per shooter of a
    batch, or two hemispheres) and the vertex arrays that draw the occluders into it."""
    gl, scene, settings, programs = state.gl, state.scene, state.settings, state.programs
    layers = memory.visibility_layers(settings, state.receiver_batch)
    texture = gl.texture_array((state.map_size, state.map_size, layers), 2)
    framebuffer = gl.framebuffer([texture])
    # Only occluders go into the visibility buffer; at least one triangle keeps it valid.
    occluders = scene.triangles[scene.occlude] if scene.occlude.any() else scene.triangles[:0]
    positions = scene.vertices[occluders].astype("f4")
    surfaces = state.surfaces[scene.occlude]
    if not len(positions):
        positions = np.full((1, 3, 3), FAR_AWAY, dtype="f4")
        surfaces = np.zeros(1)
    order = _morton_order(positions.mean(axis=1))
    positions, surfaces = positions[order], surfaces[order]
    scene_vbo = gl.buffer(positions.tobytes())
    surface_vbo = gl.buffer(np.repeat(surfaces, 3).astype("f4").tobytes())
    scene_content = [(scene_vbo, "3f", "in_position"), (surface_vbo, "1f", "in_surface")]
    vaos = {name: gl.vertex_array(programs[name], scene_content)
            for name in ("visibility", "hemisphere", "nonlinear")}
    initial = settings.subdivision_level if settings.subdivision == "REGULAR" else 0
    caster_levels = np.full(len(positions), initial, dtype=np.int32)
    caster_vbo = gl.buffer(np.repeat(caster_levels, 3).astype("f4").tobytes())
    vaos["hemisphere_tessellated"] = gl.vertex_array(
        programs["hemisphere_tessellated"],
        scene_content + [(caster_vbo, "1f", "in_caster_level")])
    vaos["covered"] = gl.vertex_array(programs["covered"], [])
    covered = gl.texture((state.receiver_batch, 1), 4)
    # The occluders' planes keep a shooter on one side of what crosses it (shooters).
    low, high = _cluster_bounds(positions.astype(np.float64))
    pad = CLUSTER_PAD * (float(np.abs(state.bounds.centre).max()) + 4.0 * state.bounds.radius)
    return VisibilityMap(texture=texture, framebuffer=framebuffer, vaos=vaos,
                         triangle_vertices=positions.shape[0] * 3,
                         occluders=TrianglePlanes(positions.astype(np.float64)),
                         caster_levels=caster_levels, caster_vbo=caster_vbo,
                         cluster_low=low - pad, cluster_high=high + pad,
                         covered=covered, covered_framebuffer=gl.framebuffer([covered]))


def _morton_order(points):
    """The order of ``points`` (N, 3) along a Z-order curve over their bounds: neighbours in
    it lie near in space."""
    low, high = points.min(axis=0), points.max(axis=0)
    cells = ((points - low) / np.maximum(high - low, 1e-30) * ((1 << MORTON_BITS) - 1))
    cells = cells.astype(np.int64)
    code = np.zeros(len(points), dtype=np.int64)
    for bit in range(MORTON_BITS):
        for axis in range(3):
            code |= ((cells[:, axis] >> bit) & 1) << (3 * bit + axis)
    return np.argsort(code, kind="stable")


def _cluster_bounds(corners):
    """(low, high) (C, 3) of each cluster of CLUSTER_TRIANGLES consecutive triangles."""
    count = -(-len(corners) // CLUSTER_TRIANGLES)
    low, high = np.empty((count, 3)), np.empty((count, 3))
    for cluster in range(count):
        part = corners[cluster * CLUSTER_TRIANGLES:(cluster + 1) * CLUSTER_TRIANGLES]
        low[cluster], high[cluster] = part.min(axis=(0, 1)), part.max(axis=(0, 1))
    return low, high


def _reaching(visibility, eye, normals):
    """(C, P): whether each cluster's bounds reach the side of each plane through ``eye`` that
    ``normals`` (P, 3) point to (the shader clips the rest of a triangle)."""
    middle = 0.5 * (visibility.cluster_high + visibility.cluster_low) - eye
    half = 0.5 * (visibility.cluster_high - visibility.cluster_low)
    return middle @ normals.T + half @ np.abs(normals).T >= 0.0


def _sun_tiles_reached(visibility, view, half_width, tiles):
    """(C, tiles^2): whether each cluster's bounds reach each tile of the sun's window
    (``half_width`` its half side, ``tiles`` a side; projection.glsl's face_clip)."""
    middle = (0.5 * (visibility.cluster_high + visibility.cluster_low) - view.eye) @ view.frame
    half = 0.5 * (visibility.cluster_high - visibility.cluster_low) @ np.abs(view.frame)
    side = 2.0 * half_width / tiles
    low = -half_width + side * np.arange(tiles)
    reached = [(middle[:, axis, None] + half[:, axis, None] >= low)
               & (middle[:, axis, None] - half[:, axis, None] <= low + side) for axis in (0, 1)]
    return (reached[0][:, None, :] & reached[1][:, :, None]).reshape(len(middle), -1)


def _face_normals(view, faces):
    """(faces, 4, 3): the world normals of the four planes through the eye that bound each of
    the first ``faces`` cube faces, pointing into it."""
    forward, right, up = (axes[:faces, None, :] for axes in (FACE_FORWARD, FACE_RIGHT, FACE_UP))
    sides = np.concatenate([right, -right, up, -up], axis=1)
    return (forward + sides) @ np.asarray(view.frame, dtype=np.float64).T


def _vertex_runs(visibility, drawn, *, most_clusters=None):
    """(first vertex, vertices) of the runs of consecutive clusters ``drawn`` (C,) marks, each
    cut into draws of at most ``most_clusters`` clusters where given."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], drawn.astype(np.int8), [0]])))
    per_cluster = 3 * CLUSTER_TRIANGLES
    step = most_clusters or len(drawn)
    return [(int(start) * per_cluster,
             min(int(start + step) * per_cluster, int(end) * per_cluster,
                 visibility.triangle_vertices) - int(start) * per_cluster)
            for run_start, end in zip(edges[::2], edges[1::2])
            for start in range(run_start, end, step)]


def program_for(settings, orthographic):
    """The name of the program that draws a view."""
    hemisphere = settings.projection != "HEMICUBE" and not orthographic
    if hemisphere and settings.projection == "NONLINEAR":
        return "nonlinear"
    if hemisphere:
        # Subdivision also tessellates casters: the per-vertex projection draws their
        # edges straight, misplacing shadow boundaries (the paper's Figure 5).
        return "hemisphere_tessellated" if settings.subdivision != "NONE" else "hemisphere"
    return "visibility"


def render(state, visibility, view, *, faces, clip_below):
    """Distance map around the view's eye: ``faces`` cube faces (ALL_FACES all round,
    FRONT_FACES the hemicube in front, the sun's window's tiles, BakeState.sun_faces) or, with a
    hemisphere projection, the front hemisphere alone or both; ``clip_below`` clips what lies
    behind the eye's plane (a one-sided shooter). Only the clusters of occluders that reach
    what is drawn are drawn: above the eye's plane, and with the cube drawn face by face,
    into each face."""
    _clear(visibility)
    _draw(state, visibility, view, faces=faces, clip_below=clip_below, first_layer=0)


def render_batch(state, visibility, views, *, faces=FRONT_FACES, clip_below=True):
    """A batch's ``views``, the i-th into the layers from 6 i (receive_patch.frag): the
    hemicubes in front of patch shooters, each behind its plane clipped; or suns' windows
    (BakeState.sun_faces tiles, nothing clipped), the i-th from sun_faces i
    (receive_light.frag). A batch of one may use any projection (render)."""
    _clear(visibility)
    layers = faces if views[0].orthographic else ALL_FACES
    for index, view in enumerate(views):
        _draw(state, visibility, view, faces=faces, clip_below=clip_below,
              first_layer=layers * index)


def _clear(visibility):
    visibility.framebuffer.use()
    visibility.framebuffer.clear(CLEAR_DISTANCE, CLEAR_DISTANCE, CLEAR_DISTANCE, CLEAR_DISTANCE)


def _draw(state, visibility, view, *, faces, clip_below, first_layer):
    """render()'s drawing, into the layers from ``first_layer`` (a hemicube's only)."""
    settings = state.settings
    hemisphere = settings.projection != "HEMICUBE" and not view.orthographic
    name = program_for(settings, view.orthographic)
    # The cube's faces one by one (preprocess.draws_per_face), or routed by a geometry shader.
    per_face = name == "visibility" and state.per_face_visibility
    program = state.programs[name]
    view.set_uniforms(program, state)
    if not per_face:   # a geometry shader draws the faces or hemispheres u_face_count asks
        set_uniform(program, "u_face_count", (2 if faces == ALL_FACES else 1) if hemisphere
                    else faces)
    if name == "visibility":
        set_uniform(program, "u_clip_below", int(clip_below))
        set_uniform(program, "u_first_layer", first_layer)
    clip = clip_below or name.startswith("hemisphere")
    above = view.frame[:, 2][None, :] if clip_below else np.zeros((0, 3))
    if not per_face:
        draws = [(None, _reaching(visibility, view.eye, above).all(axis=1))]
    elif view.orthographic:   # the sun's tiles cover the scene
        in_tiles = _sun_tiles_reached(visibility, view, state.bounds.radius, state.sun_tiles)
        draws = [(face, in_tiles[:, face]) for face in range(faces)]
    else:
        sides = _face_normals(view, faces)
        reach = _reaching(visibility, view.eye, np.concatenate([above, sides.reshape(-1, 3)]))
        in_front = reach[:, :len(above)].all(axis=1)
        inside = reach[:, len(above):].reshape(-1, faces, 4).all(axis=2)
        draws = [(face, in_front & inside[:, face]) for face in range(faces)]
    with render_state(state.ctx, blend=moderngl.MIN, clip_distance=clip):
        for face, drawn in draws:
            if face is not None:
                set_uniform(program, "u_face", face)
            runs = _vertex_runs(visibility, drawn,
                                most_clusters=PER_FACE_DRAW_CLUSTERS if per_face else None)
            for first, vertices in runs:
                visibility.vaos[name].render(moderngl.TRIANGLES, first=first, vertices=vertices)


def covered_rows(state):
    """The map rows a point of covered_share.vert counts (COUNTED_TEXELS texels or fewer)."""
    return max(1, COUNTED_TEXELS // (state.map_size * state.sun_faces))


def covered_shares(state, visibility, count):
    """(count,) the share of the texels that something was drawn into, of the sun_faces
    layers of each of the first ``count`` views of a batch (render_batch): the suns' windows
    the scene covers. Counted on the GPU (covered_share.vert), COUNTED_TEXELS a point:
    reading the maps back took longer than drawing them."""
    bands = -(-state.map_size // covered_rows(state))
    visibility.texture.use(location=0)
    visibility.covered_framebuffer.clear(0.0, 0.0, 0.0, 0.0)
    visibility.covered_framebuffer.use()
    with render_state(state.ctx, blend=moderngl.FUNC_ADD):
        visibility.vaos["covered"].render(moderngl.POINTS, vertices=count * bands)
    counts = np.frombuffer(visibility.covered.read(), dtype="f4").reshape(-1, 4)[:count, 0]
    return counts / (state.sun_faces * state.map_size ** 2)
