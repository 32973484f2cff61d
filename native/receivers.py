"""Receiver update and lights: every receiving texel gathers a shot's light against the
visibility map (receive_patch.frag for a patch, receive_light.frag for a point, spot or sun
light) into its page's gathered maps; then the power that light brings is summed, and each
texel adds its light to its irradiance and unshot maps, all scaled down alike where the
texels took more than the shot sent (deliver.frag). A patch first takes what it shoots
from its texels. Patches shoot in batches (memory.receiver_batch), and so do suns (the sky's
many): one pass over the texels gathers every shooter of the batch, each against its own
visibility map. The pass draws
only the tiles of texels that can receive a shooter (not those behind its plane, nor flat
ones facing away from it), and a tile gathers only from the shooters it can receive. The
lights' views, uniforms and power, and the sky as suns."""
from dataclasses import dataclass
import math

import moderngl
import numpy as np

from .geometry import frame_around
from .gpu import buffer_content, render_state, set_uniform
from .scene import SpotLight, SunLight
from .state import (NO_SURFACE, TOTAL_UNITS, View, blend_points, decode_normals,
                    read_map)

# u_light_kind of receive_light.frag.
POINT_LIGHT, SPOT_LIGHT, SUN_LIGHT = 0, 1, 2
# The receiver pass draws the page in tiles of this many texels a side, those that can
# receive the shot (a chart can span pages' worth of texels; tiles bound few texels each).
TILE = 8
# A tile is flat (ReceiverTiles.normal) where its texels' normals are within this of their
# mean.
FLAT_NORMAL_DEVIATION = 1e-3
# receiver_boxes.vert's vertices: two triangles per tile, (x, y) each from its box.
BOX_CORNERS = np.array([(0, 1), (2, 1), (2, 3), (0, 1), (2, 3), (0, 3)])
# Per vertex: the corner (x, y) and the bits of the shooters the tile receives.
BOX_LAYOUT = (("in_corner", 2), ("in_shooters", 1))
BOX_VERTEX_BYTES = 3 * 4
# A receiver this many times as coarse as its shooter (their sides), near it, gathers over
# its square, not at its sample point (receive_patch.frag, square_form_factor()).
COARSER = 1.5
# The patch receivers' programs by whether they gather over coarse texels' squares
# (receive_patch.frag's SQUARE_RECEIVERS): those are drawn only on square_tiles.
PATCH_PROGRAMS = {False: "patch", True: "patch_squares"}
# A pass's texels may receive this share more than its shooters sent: the form factors at
# their sample points err both ways, and cancel over shots in a closed room (deliver.frag).
RECEIVED_SURPLUS = 0.05
# gathered_power.vert's vertices: a point per tile, its box.
POWER_LAYOUT = (("in_box", 4),)
POWER_VERTEX_BYTES = 4 * 4


@dataclass
class ReceiverTiles:
    """Per tile of the pages holding texels, what decides whether it can receive a shot: its
    page, its texel box, its texels' world bounds grown by their largest side (subdivided
    texels gather off their sample points, in their tangent plane: a flat tile's bounds grow
    along its plane only), and, for a flat tile, its normal, the least of n . p over its
    texels, how far its texels' normals stray from n (0 normal: not flat), and its largest
    texel's side (the root of the area it covers)."""
    page: np.ndarray            # (T,)
    boxes: np.ndarray           # (T, 4) x0, y0, x1, y1 in texels
    low: np.ndarray             # (T, 3)
    high: np.ndarray            # (T, 3)
    normal: np.ndarray          # (T, 3)
    nearest_plane: np.ndarray   # (T,)
    normal_deviation: np.ndarray  # (T,)
    largest_side: np.ndarray    # (T,)
    vbo: object                 # the boxes drawn for a pass, BOX_CORNERS each (BOX_LAYOUT)
    power_vbo: object           # and a point each (POWER_LAYOUT)
    vaos: dict                  # per receiver program
    # The pass's totals (state.TOTAL_UNITS), 1 x 1 textures by name: the power its texels
    # received, and the unshot power it would add; and the framebuffer writing them.
    totals: dict
    totals_framebuffer: object


def create_tiles(state):
    """The tiles of every page that hold texels, from the pages' maps."""
    columns = [[] for _ in range(8)]
    for index, page in enumerate(state.pages):
        for column, values in zip(columns, _page_tiles(index, page)):
            column.append(values)
    page, boxes, low, high, normal, nearest, deviation, side = (np.concatenate(c)
                                                                for c in columns)
    gl, programs = state.gl, state.programs
    vbo = gl.buffer(reserve=max(len(page), 1) * len(BOX_CORNERS) * BOX_VERTEX_BYTES)
    power_vbo = gl.buffer(reserve=max(len(page), 1) * POWER_VERTEX_BYTES)
    vaos = {kind: gl.vertex_array(programs[kind],
                                  [buffer_content(programs[kind], vbo, BOX_LAYOUT)])
            for kind in (*PATCH_PROGRAMS.values(), "light", "deliver")}
    vaos["gathered_power"] = gl.vertex_array(programs["gathered_power"], [buffer_content(
        programs["gathered_power"], power_vbo, POWER_LAYOUT)])
    totals = {name: gl.texture((1, 1), 4) for name in TOTAL_UNITS}
    return ReceiverTiles(page=page, boxes=boxes, low=low, high=high, normal=normal,
                         nearest_plane=nearest, normal_deviation=deviation,
                         largest_side=side, vbo=vbo,
                         power_vbo=power_vbo, vaos=vaos, totals=totals,
                         totals_framebuffer=gl.framebuffer(list(totals.values())))


def _page_tiles(index, page):
    position = read_map(page.textures["position"]).astype(np.float64)
    stored = read_map(page.textures["normal"])
    height, width = position.shape[:2]
    rows, cols = -(-height // TILE), -(-width // TILE)

    def tiled(values, fill):   # (rows, cols, TILE * TILE, components)
        padded = np.full((rows * TILE, cols * TILE) + values.shape[2:], fill, values.dtype)
        padded[:height, :width] = values
        return padded.reshape(rows, TILE, cols, TILE, -1).swapaxes(1, 2).reshape(
            rows * cols, TILE * TILE, -1)

    held = tiled(position[..., 3:] > 0.0, False)[..., 0]
    points = tiled(position[..., :3], np.nan)
    normals = tiled(decode_normals(stored), np.nan)
    bent = tiled(stored[..., 2:3] < 1.0, False)[..., 0]
    side = np.sqrt(tiled(position[..., 3:], 0.0)[..., 0].max(axis=1))
    keep = held.any(axis=1)
    held, points, normals, bent, side = held[keep], points[keep], normals[keep], bent[keep], \
        side[keep]
    points = np.where(held[..., None], points, np.nan)
    normals = np.where(held[..., None], normals, np.nan)
    mean = np.nanmean(normals, axis=1)
    mean /= np.maximum(np.linalg.norm(mean, axis=1, keepdims=True), 1e-30)
    deviation = np.nanmax(np.linalg.norm(normals - mean[:, None], axis=2), axis=1)
    # A texel whose surface bends gathers at other normals (receiver_common.glsl).
    flat = (deviation <= FLAT_NORMAL_DEVIATION) & ~(bent & held).any(axis=1)
    # The most a point off a texel's sample point, in its tangent plane, moves along each
    # axis.
    reach = side[:, None] * np.where(
        flat[:, None], np.sqrt(np.maximum(1.0 - mean * mean, 0.0)) + deviation[:, None], 1.0)
    tile = np.flatnonzero(keep)
    x0, y0 = (tile % cols) * TILE, (tile // cols) * TILE
    boxes = np.stack([x0, y0, np.minimum(x0 + TILE, width), np.minimum(y0 + TILE, height)],
                     axis=1)
    return (np.full(len(tile), index), boxes, np.nanmin(points, axis=1) - reach,
            np.nanmax(points, axis=1) + reach, np.where(flat[:, None], mean, 0.0),
            np.nanmin(np.einsum("tkc,tc->tk", points, mean), axis=1), deviation, side)


def receiving_tiles(tiles, shooter, epsilon):
    """Which tiles can receive from a patch shooter (receive_patch.frag gives nothing to a
    point at most ``epsilon`` above its plane, nor one whose normal does not face it)."""
    n, centre = shooter.frame[:, 2], shooter.centre
    middle, half = 0.5 * (tiles.high + tiles.low), 0.5 * (tiles.high - tiles.low)
    in_front = (middle - centre) @ n + half @ np.abs(n) > epsilon
    # A flat tile faces away where n_t . (p - centre) >= 0 at every texel: its nearest
    # plane's value bounds n . p, and a texel normal's stray d changes the product by at
    # most d |p - centre|.
    reach = np.linalg.norm(np.maximum(np.abs(tiles.low - centre),
                                      np.abs(tiles.high - centre)), axis=1)
    flat = tiles.normal.any(axis=1)
    away = flat & (tiles.nearest_plane - tiles.normal @ centre
                   - tiles.normal_deviation * reach > epsilon)
    return in_front & ~away


def take_unshot(state, shooter):
    """Subtract what the shot took from its texels' unshot energy (exactly the values it
    read, so energy they received since stays)."""
    blend_points(state, shooter.page.unshot_only, shooter.texels, shooter.unshot,
                 moderngl.FUNC_REVERSE_SUBTRACT)
    if shooter.incoming is not None:
        blend_points(state, shooter.page.incoming_only, shooter.texels, shooter.incoming,
                     moderngl.FUNC_REVERSE_SUBTRACT)
    emitting, power = shooter.page.emission_left
    if len(emitting):
        flat = shooter.texels[:, 1].astype(np.int64) * state.packed.width + shooter.texels[:, 0]
        where = np.searchsorted(emitting, flat).clip(0, len(emitting) - 1)
        power[where[emitting[where] == flat]] = 0.0


def set_patch_uniforms(state, shooters, views, kinds):
    """The batch's shooters, in the order of their visibility maps' layers, and the views
    those were drawn from (the same but for the eye: every map is a hemicube's, or the batch
    is one shooter's), into the programs ``kinds``."""
    for kind in kinds:
        _set_patch_uniforms(state, state.programs[kind], shooters, views)


def _set_patch_uniforms(state, program, shooters, views):
    views[0].set_uniforms(program, state)
    set_uniform(program, "u_shooter_count", len(shooters))
    _set_array(program, "u_quads", [tuple(corner) for shooter in shooters
                                    for corner in shooter.quad])
    _set_array(program, "u_centres", [tuple(shooter.centre) for shooter in shooters])
    _set_array(program, "u_cell_radiances", [tuple(cell) for shooter in shooters
                                             for cell in shooter.cell_radiance])
    _set_array(program, "u_emits", [int(shooter.emits) for shooter in shooters])
    set_uniform(program, "u_any_emits", int(any(shooter.emits for shooter in shooters)))
    _set_array(program, "u_lobe_shapes", [(shooter.lobe.alpha, shooter.lobe.fresnel_f0)
                                          for shooter in shooters])
    _set_array(program, "u_lobe_shares", [tuple(shooter.lobe.share) for shooter in shooters])
    _set_array(program, "u_cell_lobes", [tuple(cell) for shooter in shooters
                                         for cell in shooter.cell_lobes])
    # An empty rectangle: no texel is across a thin gap from this shooter.
    _set_array(program, "u_surface_extents", [
        NO_SURFACE if shooter.extent is None else tuple(shooter.extent) for shooter in shooters])
    _set_array(program, "u_eyes", [tuple(view.eye) for view in views])
    _set_array(program, "u_frames", [tuple(np.asarray(view.frame, dtype=np.float64).T.ravel())
                                      for view in views])


def _set_array(program, name, values):
    """Set the first len(values) elements of a uniform array (moderngl writes whole arrays:
    the rest, which no shooter reads, repeat the first; an array of one takes its value)."""
    uniform = program.get(name, None)
    if uniform is not None:
        values = list(values) + [values[0]] * (uniform.array_length - len(values))
        if uniform.array_length == 1:
            values = values[0]
    set_uniform(program, name, values)


def light_view(light, bounds):
    """The View a light's visibility is drawn from: a point or spot light's position, or
    the sun's orthographic window over the scene's bounding square, from its far side."""
    if isinstance(light, SunLight):
        n = np.asarray(light.direction, dtype=np.float64)
        n /= np.linalg.norm(n)
        return View(eye=bounds.centre - n * bounds.radius, frame=frame_around(n),
                    orthographic=True)
    return View(eye=np.asarray(light.position, dtype=np.float64), frame=np.eye(3),
                orthographic=False)


def set_light_uniforms(state, lights, views):
    """A pass's lights (suns, or a point or spot light alone), in the order of their
    visibility maps' layers, and the views those were drawn from."""
    program = state.programs["light"]
    views[0].set_uniforms(program, state)
    set_uniform(program, "u_light_count", len(lights))
    _set_array(program, "u_eyes", [tuple(view.eye) for view in views])
    _set_array(program, "u_frames", [tuple(np.asarray(view.frame, dtype=np.float64).T.ravel())
                                      for view in views])
    first = lights[0]
    if isinstance(first, SunLight):
        set_uniform(program, "u_light_kind", SUN_LIGHT)
        _set_array(program, "u_light_values", [tuple(light.irradiance()) for light in lights])
        return
    set_uniform(program, "u_light_kind", POINT_LIGHT)
    _set_array(program, "u_light_values", [tuple(first.intensity())])
    if isinstance(first, SpotLight):
        axis = np.asarray(first.direction, dtype=np.float64)
        set_uniform(program, "u_light_kind", SPOT_LIGHT)
        set_uniform(program, "u_spot_axis", tuple(axis / np.linalg.norm(axis)))
        set_uniform(program, "u_spot_cos_half", first.cos_half_angle())
        set_uniform(program, "u_spot_smooth", first.smooth_width())


def light_power(light, radius):
    """A light's emitted power (W, RGB); a sun's over the scene's bounding square."""
    if isinstance(light, SunLight):
        return light.irradiance() * (2.0 * radius) ** 2
    return light.emitted_power()


def receiving_shooters(tiles, shooters, epsilon):
    """(T,) per tile the bits of the shooters (by their index in the batch) it can receive."""
    bits = np.zeros(len(tiles.page), dtype=np.int64)
    for index, shooter in enumerate(shooters):
        bits |= receiving_tiles(tiles, shooter, epsilon).astype(np.int64) << index
    return bits


def square_tiles(tiles, shooters, receiving):
    """(T,) which tiles hold a texel COARSER times as coarse as a shooter they receive
    (``receiving``: receiving_shooters), which gathers over its square."""
    squares = np.zeros(len(tiles.page), dtype=bool)
    for index, shooter in enumerate(shooters):
        quad = np.asarray(shooter.quad)
        side = 0.5 * (np.linalg.norm(quad[1] - quad[0]) + np.linalg.norm(quad[3] - quad[0]))
        squares |= ((receiving >> index) & 1).astype(bool) & (tiles.largest_side
                                                              > COARSER * side)
    return squares


def unshot_limit(energy, sent):
    """The most unshot power a shot that sent ``sent`` (W, RGB) may add: its power times the
    largest reflectance and the receivers' surplus, at most its power, so that the unshot
    power falls with every shot where surfaces reflect under 1 / (1 + RECEIVED_SURPLUS)."""
    share = np.minimum(1.0, (1.0 + RECEIVED_SURPLUS) * energy.largest_reflectance)
    return np.asarray(sent, dtype=np.float64) * share


def update(state, visibility, kind, sent, unshot_left, shooters=None, squares=None):
    """The receivers take the pass's light (program ``kind``: PATCH_PROGRAMS[False], the
    batch whose uniforms set_patch_uniforms set, or "light"), which sent ``sent`` (W, RGB),
    and may add
    ``unshot_left`` (W, RGB) to the unshot power: the tiles ``shooters`` gives bits of
    (receiving_shooters), or all of them from the one light; the tiles ``squares`` marks
    (square_tiles) gather with PATCH_PROGRAMS[True]. Three passes over those tiles: each texel
    gathers; the power their light brings is summed on the GPU; each adds its light,
    scaled where they took more than was sent or would add more unshot power than is left
    (deliver.frag)."""
    tiles = state.receiver_tiles
    if shooters is None:
        shooters = np.ones(len(tiles.page), dtype=np.int64)
    if squares is None:
        squares = np.zeros(len(tiles.page), dtype=bool)
    chosen = np.flatnonzero(shooters)
    chosen = chosen[np.lexsort((squares[chosen], tiles.page[chosen]))]
    if not len(chosen):
        return
    vertices = np.empty((len(chosen), len(BOX_CORNERS), 3), dtype=np.float32)
    vertices[..., :2] = tiles.boxes[chosen][:, BOX_CORNERS]
    vertices[..., 2] = shooters[chosen, None]
    tiles.vbo.write(vertices.tobytes())
    tiles.power_vbo.write(tiles.boxes[chosen].astype(np.float32).tobytes())
    ends = np.searchsorted(tiles.page[chosen], np.arange(len(state.pages) + 1))
    runs = [(page, int(start), int(end)) for page, start, end
            in zip(state.pages, ends[:-1], ends[1:]) if start < end]

    def draw_tiles(vao, start, end):
        vao.render(moderngl.TRIANGLES, first=start * len(BOX_CORNERS),
                   vertices=(end - start) * len(BOX_CORNERS))

    visibility.texture.use(location=0)
    for page, start, end in runs:
        page.gather.use()
        page.use_maps("position", "normal", "material", "level")
        split = start + int(np.count_nonzero(~squares[chosen[start:end]]))
        draw_tiles(tiles.vaos[kind], start, split)
        if split < end:
            draw_tiles(tiles.vaos[PATCH_PROGRAMS[True]], split, end)
    with render_state(state.ctx, blend=moderngl.FUNC_ADD):
        tiles.totals_framebuffer.clear(0.0, 0.0, 0.0, 0.0)
        tiles.totals_framebuffer.use()
        for page, start, end in runs:
            page.use_maps("gathered", "position", "material", "own_area")
            tiles.vaos["gathered_power"].render(moderngl.POINTS, first=start,
                                                vertices=end - start)
        program = state.programs["deliver"]
        set_uniform(program, "u_received_limit", tuple(
            float(value) for value in (1.0 + RECEIVED_SURPLUS) * np.asarray(sent)))
        set_uniform(program, "u_unshot_limit", tuple(float(value) for value in unshot_left))
        for name, unit in TOTAL_UNITS.items():
            tiles.totals[name].use(location=unit)
        for page, start, end in runs:
            page.receivers.use()
            page.use_maps("position", "material", *(("gathered", "gathered_incoming")
                                                    if state.glossy_lobes else ("gathered",)))
            draw_tiles(tiles.vaos["deliver"], start, end)


def sky_suns(radiance, count):
    """A uniform sky of ``radiance`` as ``count`` suns on a Fibonacci sphere, each carrying the
    irradiance of its 4 pi / count share of directions: radiance * 4 pi / count."""
    radiance = np.asarray(radiance, dtype=np.float64)
    if radiance.max() <= 0.0:
        return []
    index = np.arange(count) + 0.5
    z = 1.0 - 2.0 * index / count
    azimuth = math.pi * (3.0 - math.sqrt(5.0)) * index
    ring = np.sqrt(1.0 - z * z)
    directions = np.stack([ring * np.cos(azimuth), ring * np.sin(azimuth), z], axis=1)
    strength = float(radiance.max()) * 4.0 * math.pi / count
    color = tuple(radiance / radiance.max())
    return [SunLight(tuple(d), strength, color, name="World") for d in directions]
