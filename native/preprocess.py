"""Preprocess (the paper's setup): the scene's surfaces numbered, the programs, each page's
maps allocated, every triangle rasterized into them, each texel's world area and, where its
surface bends within it, its bent normal measured, and the emitted power summed."""
from dataclasses import dataclass
import math

import moderngl
import numpy as np

from . import buried
from .errors import SettingsError
from .geometry import smooth_surfaces, tangents_of
from .gpu import buffer_content, render_state, set_uniform
from .receivers import COARSER, PATCH_PROGRAMS
from .visibility import ALL_FACES, DRAWN_DISTANCE, covered_rows
from .shooters import SHOOTER_CELLS
from .state import (BEND_STEPS, LEAST_SUN_TILES, MAP_UNITS, MOST_SUN_TILES, TOTAL_UNITS,
                    Bounds, Energy, Page, decode_normals, read_map)

RASTER_LAYOUT = (("in_texel", 2), ("in_position", 3), ("in_normal", 3), ("in_tex_uv", 2),
                 ("in_albedo", 3), ("in_reflectance", 3), ("in_emission", 3), ("in_receive", 1),
                 ("in_roughness", 1))
# The textures a triangle's material reads: (Scene's index and list, sampler unit, switch).
MATERIAL_TEXTURES = (("albedo_texture_index", "albedo_textures", 0, "u_use_texture"),
                     ("emission_texture_index", "emission_textures", 1,
                      "u_use_emission_texture"),
                     ("reflectance_texture_index", "reflectance_textures", 2,
                      "u_use_reflectance_texture"))
# The bounding sphere's radius is the bounding box's half diagonal times this, plus
# BOUNDS_MARGIN; the depth tolerance is EPSILON_SHARE of it.
BOUNDS_GROWTH = 1.01
BOUNDS_MARGIN = 1e-6
EPSILON_SHARE = 1e-5
# Surfaces are numbered 1..SURFACE_NUMBERS (the visibility map keeps 12 bits), then again.
SURFACE_NUMBERS = 4095
# A texel whose mean normal (over the surface it covers) is at least this long is flat: it
# gathers at its sample's normal. A shorter one bends within it and gathers at two normals
# (bent_normal_codes, receiver_common.glsl), unless it is shorter than MIN_SPREAD: normals
# that cancel (a whole tube in one texel) leave no mean direction.
FLAT_SPREAD = 0.999
MIN_SPREAD = 1e-3
# Under this sine between a texel's sample normal and its mean normal, the sample is the mean.
BEND_DIRECTION_SINE = math.sin(math.radians(1.0))
# What lets a vertex shader pick the layer it draws into: the cube's faces drawn one by one.
VERTEX_LAYER_EXTENSION = "GL_ARB_shader_viewport_layer_array"
# The selection's arg-max pyramid (selection.measure) stops at the first level with at most
# this many texels: the regions it reads back.
SELECTION_REGIONS = 1024
# Hemisphere maps are twice the hemicube's side: the same texels per radian at the zenith.
HEMISPHERE_MAP_SCALE = 2
# The automatic hemicube resolution's least and most: the old fixed default, and where its
# visibility map (24 B a texel) and render time stay small beside the atlas's
# (docs/how-it-works.md).
AUTOMATIC_HEMICUBE = (128, 512)
# The automatic hemicube resolves at least this many texels per metre at the typical
# distance, however coarse the lightmap: at 4 texels/m a map whose texels spanned 12 cm there
# let light past an office's furniture (docs/benchmarks-log.md, "The visibility map's
# resolution").
LEAST_MAP_DENSITY = 10.0
# The sun's tiled window spans at most this many texels across: covered_share.vert counts a
# row of them per tile in one loop, which llvmpipe ends after 65535 turns.
MOST_SUN_WINDOW = 8192


@dataclass
class RasterVertices:
    """The lightmap vertex buffer, drawn in runs of (page, material textures): per triangle of
    it (a 'slot') the scene triangle and the page."""
    vbo: object
    slot_triangles: np.ndarray
    slot_pages: np.ndarray


def bounds_of(scene):
    lo, hi = scene.bounds()
    radius = 0.5 * float(np.linalg.norm(hi - lo)) * BOUNDS_GROWTH + BOUNDS_MARGIN
    return Bounds(centre=0.5 * (lo + hi), radius=radius, epsilon=EPSILON_SHARE * radius)


def hemicube_resolution(settings, scene):
    """Settings.hemicube_resolution, or where it is 0 (automatic) the least power of two
    at which a face texel at its middle (2 / resolution radians), half the scene's diagonal
    away from a shooter, spans no more than a lightmap texel nor 1 / LEAST_MAP_DENSITY, kept
    within AUTOMATIC_HEMICUBE (its memory and time: docs/how-it-works.md)."""
    if settings.hemicube_resolution:
        return settings.hemicube_resolution
    lo, hi = scene.bounds()
    typical_distance = 0.5 * float(np.linalg.norm(hi - lo))
    density = max(settings.texel_density, LEAST_MAP_DENSITY)
    needed = max(2.0 * typical_distance * density, 1.0)
    least, most = AUTOMATIC_HEMICUBE
    return int(min(max(2 ** math.ceil(math.log2(needed)), least), most))


def sun_tiles(bounds, map_size, layers):
    """Tiles a side of the sun's orthographic window (over the scene's bounding square,
    2 x bounds.radius wide) needs for its texels to span no more than 1 / LEAST_MAP_DENSITY,
    from LEAST_SUN_TILES to MOST_SUN_TILES, at most MOST_SUN_WINDOW texels across and as
    many as one window can take of the map's ``layers``: at 35 cm the sun passed steps and
    roofs of a level (docs/benchmarks-log.md, "Why pandora was too bright")."""
    needed = 2.0 * bounds.radius * LEAST_MAP_DENSITY / map_size
    most = min(MOST_SUN_TILES, MOST_SUN_WINDOW // map_size, math.isqrt(layers))
    return int(max(LEAST_SUN_TILES, min(math.ceil(needed), most)))


def visibility_map_size(settings, scene):
    return hemicube_resolution(settings, scene) * (1 if settings.projection == "HEMICUBE"
                                                   else HEMISPHERE_MAP_SCALE)


def number_surfaces(scene):
    """Per triangle the number of its smooth surface, and how many surfaces emit. Emitting
    surfaces come first, so that they win ties in the visibility map (and are known there by
    their numbers): a lamp drawn in the ceiling's plane covers the ceiling."""
    surfaces = smooth_surfaces(scene)
    emits = np.zeros(surfaces.max() + 1, dtype=bool)
    emits[surfaces[scene.emission.max(axis=1) > 0.0]] = True
    renumber = np.empty_like(emits, dtype=np.int64)
    renumber[np.argsort(~emits, kind="stable")] = np.arange(len(emits))
    emitting = min(int(emits.sum()), SURFACE_NUMBERS)
    # 0 marks texels that do not receive.
    numbers = renumber[surfaces] % SURFACE_NUMBERS + 1
    if scene.back_of is not None:   # a back face is its front's surface: one sheet
        copies = scene.back_of >= 0
        numbers[copies] = numbers[scene.back_of[copies]]
    return numbers, emitting


def create_gpu_state(state):
    """The programs and their constant uniforms, the material textures and the pages' maps."""
    gl = state.gl
    state.per_face_visibility = draws_per_face(state.ctx, state.settings)
    state.programs = create_programs(gl, state.settings, per_face=state.per_face_visibility,
                                     most_faces=max(ALL_FACES, state.sun_faces),
                                     receiver_batch=state.receiver_batch,
                                     glossy_lobes=state.glossy_lobes)
    state.fullscreen = {name: gl.vertex_array(state.programs[name], [])
                        for name in ("block", "argmax")}
    set_constant_uniforms(state)
    state.material_textures = {name: material_textures(gl, getattr(state.scene, name))
                               for _, name, _, _ in MATERIAL_TEXTURES}
    size = (state.packed.width, state.packed.height)
    state.pages = [allocate_page(gl, 1 << state.patch_level, size,
                                 glossy_lobes=state.glossy_lobes)
                   for _ in range(state.packed.page_count)]


def create_programs(gl, settings, *, per_face, most_faces, receiver_batch, glossy_lobes):
    """The programs by name; ``per_face``: the cube's faces drawn one by one
    (draws_per_face), not routed by a geometry shader, which routes a triangle to at most
    ``most_faces`` (the cube's, or a sun's tiles); ``receiver_batch``: the shooters a
    receiver pass gathers (a batch of one compiles to a pass without the loop over them,
    which on llvmpipe cost a shot's pass about a third more); ``glossy_lobes``: the
    receivers keep incoming directions and patches shoot lobes (lobes.py). Patches gather
    with receivers.PATCH_PROGRAMS: the squares' program on the tiles that hold texels
    coarser than a shooter (receivers.square_tiles)."""
    lobes = {"GLOSSY_LOBES": int(glossy_lobes)}
    programs = {
        "attributes": gl.program("raster.vert", "raster_attributes.frag", "raster.geom"),
        "area": gl.program("raster.vert", "raster_area.frag", "raster.geom"),
        "moments": gl.program("raster.vert", "normal_moments.frag", "raster.geom"),
        "block": gl.program("fullscreen.vert", "block_power.frag"),
        "argmax": gl.program("fullscreen.vert", "argmax.frag"),
        "visibility": (gl.program("visibility_face.vert", "visibility.frag") if per_face else
                       gl.program("visibility.vert", "visibility.frag", "visibility.geom",
                                  defines={"MOST_VERTICES": 3 * most_faces})),
        "hemisphere": gl.program("visibility_hemisphere.vert", "visibility_hemisphere.frag",
                                 "visibility_hemisphere.geom"),
        "hemisphere_tessellated": gl.program(
            "visibility_hemisphere.vert", "visibility_hemisphere.frag",
            "visibility_hemisphere_tessellated.geom"),
        "nonlinear": gl.program("visibility.vert", "visibility_nonlinear.frag",
                                "visibility_nonlinear.geom"),
        **{name: gl.program("receiver_boxes.vert", "receive_patch.frag",
                            defines={"MOST_SHOOTERS": receiver_batch,
                                     "SHOOTER_CELLS": SHOOTER_CELLS,
                                     "SQUARE_RECEIVERS": int(squares),
                                     "COARSER": repr(float(COARSER)), **lobes})
           for squares, name in PATCH_PROGRAMS.items()},
        "light": gl.program("receiver_boxes.vert", "receive_light.frag",
                            defines={"MOST_SHOOTERS": receiver_batch, **lobes}),
        "gathered_power": gl.program("gathered_power.vert", "gathered_power.frag"),
        "covered": gl.program("covered_share.vert", "covered_share.frag"),
        "deliver": gl.program("receiver_boxes.vert", "deliver.frag", defines=lobes),
        "take": gl.program("take_unshot.vert", "take_unshot.frag"),
    }
    if settings.subdivision != "NONE":
        programs["count"] = gl.program("raster.vert", "shadow_count.frag", "raster.geom")
        programs["level"] = gl.program("raster.vert", "set_level.frag", "raster.geom")
    return programs


def draws_per_face(ctx, settings):
    """Whether the cube's faces are drawn one by one (Settings.visibility_draw) rather than in
    one geometry-shader pass: AUTO draws per face on llvmpipe, which runs geometry shaders on
    the calling thread (docs/benchmarks-log.md, "All four scenes at equal error")."""
    if settings.visibility_draw == "GEOMETRY_SHADER":
        return False
    supported = VERTEX_LAYER_EXTENSION in ctx.extensions
    if settings.visibility_draw == "PER_FACE" and not supported:
        raise SettingsError(f"visibility_draw PER_FACE needs {VERTEX_LAYER_EXTENSION}, which "
                            f"{ctx.info['GL_RENDERER']} lacks: choose AUTO or GEOMETRY_SHADER")
    return supported and (settings.visibility_draw == "PER_FACE"
                          or "llvmpipe" in ctx.info["GL_RENDERER"])


def set_constant_uniforms(state):
    """Uniforms that stay the same for the whole bake (texture units among them)."""
    size = (float(state.packed.width), float(state.packed.height))
    settings, bounds = state.settings, state.bounds
    receivers = {"u_resolution": float(state.map_size), "u_atlas_size": size,
                 "u_epsilon": bounds.epsilon, "u_ortho_half": bounds.radius,
                 "u_sun_tiles": state.sun_tiles,
                 "u_neighbour_visibility": int(settings.neighbour_visibility),
                 "u_emitting_surfaces": state.emitting_surfaces,
                 "u_visibility": 0, **{f"u_{name}": MAP_UNITS[name]
                                       for name in ("position", "normal", "material", "level")}}
    constants = {
        "attributes": {"u_atlas_size": size, "u_albedo_texture": 0,
                       "u_emission_texture": 1, "u_reflectance_texture": 2},
        "area": {"u_atlas_size": size},
        "moments": {"u_atlas_size": size, "u_normal": 0},
        "block": {"u_block": 1 << state.patch_level, "u_position": 0, "u_unshot": 1},
        "argmax": {"u_source": 0},
        "visibility": {"u_ortho_half": bounds.radius, "u_sun_tiles": state.sun_tiles},
        "covered": {"u_visibility": 0, "u_drawn": DRAWN_DISTANCE,
                    "u_pixels": state.receiver_batch, "u_rows": covered_rows(state),
                    "u_faces": state.sun_faces},
        "nonlinear": {"u_resolution": float(state.map_size)},
        "hemisphere": {"u_resolution": float(state.map_size)},
        "hemisphere_tessellated": {"u_resolution": float(state.map_size)},
        **{name: receivers for name in PATCH_PROGRAMS.values()},
        "light": receivers,
        "take": {"u_atlas_size": size},
        "gathered_power": {f"u_{name}": MAP_UNITS[name]
                           for name in ("gathered", "position", "material", "own_area")},
        "deliver": {"u_atlas_size": size,
                    **{f"u_{name}": unit for name, unit in TOTAL_UNITS.items()},
                    **{f"u_{name}": MAP_UNITS[name]
                       for name in ("gathered", "gathered_incoming", "position", "material")}},
        # The count pass reads no level map.
        "count": {**{name: value for name, value in receivers.items() if name != "u_level"},
                  "u_atlas_size": size},
        "level": {**receivers, "u_atlas_size": size},
    }
    for name, uniforms in constants.items():
        if name not in state.programs:
            continue
        for uniform, value in uniforms.items():
            set_uniform(state.programs[name], uniform, value)


def material_textures(gl, images):
    textures = []
    for image in images:
        image = np.asarray(image, dtype=np.float32)
        rgba = np.ones(image.shape[:2] + (4,), np.float32)
        rgba[..., :image.shape[2]] = image
        texture = gl.texture(image.shape[1::-1], 4, data=rgba.tobytes())
        texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        textures.append(texture)
    return textures


def allocate_page(gl, block, size, *, glossy_lobes):
    """A page's maps but the irradiance, which rasterize makes once its depth is gone; the
    arg-max pyramid starts at blocks of ``block`` texels (the patches); the incoming
    directions with ``glossy_lobes``."""
    textures = {
        "position": gl.texture(size, 4),            # xyz, area
        "normal": gl.texture(size, 4, "nu2"),       # octahedral (texel_maps.glsl), spread
        "material": gl.texture(size, 4, "nu2"),     # albedo, surface number
        "unshot": gl.texture(size, 4),              # radiance, texel size
        "level": gl.texture(size, 1, "nu1"),        # subdivision level
    }
    if glossy_lobes:
        textures["incoming"] = gl.texture(size, 4)  # where the unshot light came from
    page = Page(
        blocks=gl.framebuffer([textures[n] for n in ("position", "normal", "unshot",
                                                    "material", "incoming")
                               if n in textures]),
        unshot_only=gl.framebuffer([textures["unshot"]]),
        incoming_only=gl.framebuffer([textures["incoming"]]) if glossy_lobes else None,
        area_only=gl.framebuffer([textures["position"]]),
        level_only=gl.framebuffer([textures["level"]]),
        textures=textures)
    level = (-(-size[0] // block), -(-size[1] // block))
    # The arg-max pyramid stops at the grid of regions that selection reads back.
    while True:
        texture = gl.texture(level, 4)
        page.pyramid.append((texture, gl.framebuffer([texture])))
        if level[0] * level[1] <= SELECTION_REGIONS:
            break
        level = (-(-level[0] // 2), -(-level[1] // 2))
    return page


def rasterize(state):
    """Every charted triangle into its page's maps: the attributes, and the emission as the
    first unshot radiance; then each texel's area and bent normal (measure_surface) and the
    irradiance maps, cleared. Returns the vertex buffer's RasterVertices."""
    scene, atlas = state.scene, state.packed
    tris = atlas.triangles
    corners = scene.triangles[tris]
    positions = scene.vertices[corners]
    if scene.normals is not None:
        normals = scene.normals[corners]
    else:
        face = np.cross(positions[:, 1] - positions[:, 0], positions[:, 2] - positions[:, 0])
        normals = np.repeat(face[:, None, :], 3, axis=1)
    tex_uv = (scene.albedo_uv[tris] if scene.albedo_uv is not None
              else np.zeros((len(tris), 3, 2)))
    texture_index = np.stack([getattr(scene, index)[tris]
                              for index, _, _, _ in MATERIAL_TEXTURES], axis=1)
    per_corner = lambda values: np.repeat(values[:, None, :], 3, axis=1)
    vertex_data = np.concatenate([
        atlas.texels, positions, normals, tex_uv, per_corner(scene.albedo[tris]),
        per_corner(scene.reflected()[tris]), per_corner(scene.emission[tris]),
        per_corner((scene.receive * state.surfaces)[tris, None].astype(float)),
        per_corner(scene.roughness[tris, None]),
    ], axis=2).astype("f4")
    # Draw in runs of (page, material textures).
    order = np.lexsort((*texture_index.T[::-1], atlas.page))
    vertex_data = vertex_data[order]
    keys = np.column_stack([atlas.page[order], texture_index[order]])
    starts = np.nonzero(np.r_[True, (keys[1:] != keys[:-1]).any(axis=1)])[0]
    ends = np.r_[starts[1:], len(keys)]

    gl, programs, pages = state.gl, state.programs, state.pages
    vbo = gl.buffer(vertex_data.tobytes())
    vaos = {name: gl.vertex_array(programs[name],
                                  [buffer_content(programs[name], vbo, RASTER_LAYOUT)])
            for name in ("attributes", "area", "moments")}
    ctx = state.ctx

    # The attributes, and the emission as the first unshot radiance, with a depth map the
    # pages share in turn (pages are drawn in order). The albedo the lightmaps show goes to
    # the CPU (postprocess.lightmaps): the GPU needs only what the texels reflect.
    depth = gl.depth_texture((atlas.width, atlas.height))
    albedo = gl.texture((atlas.width, atlas.height), 4, "nu2")
    rasters = [gl.framebuffer([page.textures[name] for name in
                               ("position", "normal", "material", "unshot")] + [albedo], depth)
               for page in pages]
    for page in pages:
        page.level_only.clear(0.0, 0.0, 0.0, 0.0)
    with render_state(ctx, depth_test=True):
        program = programs["attributes"]
        rasters[0].clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        for start, end in zip(starts, ends):   # runs are sorted by page
            page_index, *indices = keys[start]
            if start and keys[start - 1][0] != page_index:   # the next page: the depth anew
                _keep_albedo(pages[keys[start - 1][0]], albedo)
                rasters[page_index].clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            rasters[page_index].use()
            for (_, name, unit, uniform), index in zip(MATERIAL_TEXTURES, indices):
                set_uniform(program, uniform, int(index >= 0))
                if index >= 0:
                    state.material_textures[name][index].use(location=unit)
            vaos["attributes"].render(moderngl.TRIANGLES, vertices=3 * (end - start),
                                      first=3 * start)
        _keep_albedo(pages[keys[-1][0]], albedo)
    # moderngl binds the last used framebuffer again after making one: not a released one.
    pages[0].area_only.use()
    gl.release_now(*rasters, depth, albedo)
    # The irradiance takes the depth's memory: the peak stays at BYTES_PER_TEXEL.
    for page in pages:
        irradiance = page.textures["irradiance"] = gl.texture((atlas.width, atlas.height), 4)
        page.receivers = gl.framebuffer([irradiance, page.textures["unshot"]] + (
            [page.textures["incoming"]] if state.glossy_lobes else []))
        gathered = ["gathered"] + (["gathered_incoming"] if state.glossy_lobes else [])
        for name in gathered:
            page.textures[name] = gl.texture((atlas.width, atlas.height), 4)
        page.gather = gl.framebuffer([page.textures[name] for name in gathered])
    measure_surface(state, vaos, keys[starts, 0], starts, ends)
    buried.keep_open_parts(state)
    for page in pages:
        with render_state(ctx, framebuffer=page.receivers,   # the unshot holds emission
                          color_mask=[(True,) * 4, (False,) * 4, (True,) * 4][
                              :len(page.receivers.color_attachments)]):
            page.receivers.clear(0.0, 0.0, 0.0, 0.0)
    return RasterVertices(vbo, tris[order], atlas.page[order])


def _keep_albedo(page, albedo):
    kept = read_map(albedo)
    page.albedo, page.roughness = kept[..., :3], kept[..., 3]


def measure_surface(state, vaos, run_pages, starts, ends):
    """Each texel's world area (the position map's .w) and, where its surface bends within
    it, the spread of its normals (bent_normal_codes): sums over the texel's triangles by
    additive blending, with the irradiance map, not yet in use, holding them in turn."""
    scope = state.gl.temporary_framebuffer
    for page_index, page in enumerate(state.pages):
        runs = list(zip(starts[run_pages == page_index], ends[run_pages == page_index]))
        irradiance, after = page.textures["irradiance"], page.area_only
        with scope([page.textures["position"], irradiance], then=after,
                   color_mask=[(False, False, False, True), (True,) * 4]) as sums:
            sums.clear(0.0, 0.0, 0.0, 0.0)   # the mask keeps the position's xyz
            _add_up(state.ctx, vaos["area"], runs)
        # float32 for the whole page (a 4096 x 4096 page's sums are 268 MB as read), double
        # precision only for the bent texels' codes.
        normal_sum = read_map(irradiance)
        covered = normal_sum[..., 3]
        mean_length = np.linalg.norm(normal_sum[..., :3], axis=-1)
        spread = np.divide(mean_length, covered, out=np.ones_like(covered),
                           where=covered > 0.0)
        bent = (spread < FLAT_SPREAD) & (spread > MIN_SPREAD)
        if not bent.any():
            continue
        normal = page.textures["normal"]
        normal.use(location=0)
        with scope([irradiance], then=after) as moments:
            moments.clear(0.0, 0.0, 0.0, 0.0)
            _add_up(state.ctx, vaos["moments"], runs)
        stored = np.frombuffer(normal.read(), dtype=np.uint16).reshape(
            normal.height, normal.width, 4).copy()
        stored[bent, 2:] = bent_normal_codes(
            normal_sum[bent].astype(np.float64), read_map(irradiance)[bent].astype(np.float64),
            decode_normals(stored[bent] / 65535.0))
        normal.write(stored.tobytes())


def _add_up(ctx, vao, runs):
    """Draw the triangle runs with additive blending into the bound framebuffer."""
    with render_state(ctx, blend=moderngl.FUNC_ADD):
        for start, end in runs:
            vao.render(moderngl.TRIANGLES, vertices=3 * (end - start), first=3 * start)


def bent_normal_codes(normal_sum, moments, sample_normals):
    """The normal map's third and fourth channels (RGBA16) of texels whose surface bends
    within them, from sums over their covered shares c: c n and c (normal_sum), and c tt,
    c bb, c tb (moments), t and b the normal's components along tangent_of(s) and s x
    tangent_of(s) for the sample's normal s. The spread is the mean normal's length; the
    receivers (texel_maps.glsl decode_bend) gather at the mean normal's direction turned by
    acos(spread) each way along the bend, given as the heading of a tangent of s (from
    tangent_of(s) towards s x tangent_of(s)) and the tilt from s along it to the mean. The
    bend runs from s towards the mean, or where s is the mean, along the principal axis of
    the moments: where the normals vary most."""
    covered = normal_sum[:, 3:4]
    mean = normal_sum[:, :3] / covered
    spread = np.linalg.norm(mean, axis=1)
    mean /= spread[:, None]
    tt, bb, tb = (moments[:, i] / covered[:, 0] for i in range(3))
    principal_heading = 0.5 * np.arctan2(2.0 * tb, tt - bb)
    t = tangents_of(sample_normals)
    b = np.cross(sample_normals, t)
    along = (mean * sample_normals).sum(axis=1)
    towards = mean - along[:, None] * sample_normals
    apart = np.linalg.norm(towards, axis=1)
    bends_away = apart > BEND_DIRECTION_SINE
    heading = np.where(bends_away, np.arctan2((towards * b).sum(axis=1),
                                              (towards * t).sum(axis=1)), principal_heading)
    tilt = np.where(bends_away, np.arctan2(apart, along), 0.0)
    heading_code = np.round((heading / (2.0 * math.pi) + 0.5) * BEND_STEPS)
    tilt_code = np.round(np.clip(tilt / (0.5 * math.pi), 0.0, 1.0) * BEND_STEPS)
    return np.stack([np.round(spread * 65535.0),
                     heading_code * (BEND_STEPS + 1) + tilt_code], axis=1).astype(np.uint16)


def measure_emission(state):
    """Emitted power as the texels hold it (the unshot maps start as the emission), summed
    in double precision; the receiving texels, and the patches (blocks at the patch level)
    that hold texels (a mean patch's share of the power, for selection.block_region). Keeps
    each page's areas, atlas layout and emitting texels."""
    energy = Energy(emitted_maps=np.zeros(3), texel_count=0, shooting_blocks=0)
    block = 1 << state.patch_level
    for page_index, page in enumerate(state.pages):
        area = read_map(page.textures["position"])[..., 3:4]
        height, width = area.shape[:2]
        padded = np.zeros((-(-height // block) * block, -(-width // block) * block), bool)
        padded[:height, :width] = area[..., 0] > 0
        energy.shooting_blocks += int(np.count_nonzero(padded.reshape(
            padded.shape[0] // block, block, padded.shape[1] // block, block).any(axis=(1, 3))))
        emission = read_map(page.textures["unshot"])[..., :3]
        material = read_map(page.textures["material"])
        receives = material[..., 3]
        page.area = np.ascontiguousarray(area[..., 0])
        page.textures["own_area"] = state.gl.texture(
            (width, height), 1, data=page.own_area().astype(np.float32).tobytes())
        page.to_atlas = _atlas_texels(state, page_index, area[..., 0] > 0)
        power = math.pi * (emission * area).reshape(-1, 3).astype(np.float64)
        energy.emitted_maps += power.sum(axis=0)
        emitting = np.flatnonzero(power.max(axis=1) > 0)
        page.emission_left = (emitting, power[emitting])
        receiving = (area[..., 0] > 0) & (receives > 0)
        energy.texel_count += int(np.count_nonzero(receiving))
        energy.largest_reflectance = np.maximum(
            energy.largest_reflectance, material[..., :3][receiving].max(axis=0, initial=0.0))
    return energy


def _atlas_texels(state, page_index, holds_surface):
    """(flat indices on the packed page, flat indices on the atlas's page) of the texels
    ``holds_surface`` (H, W) marks: each moves back by its chart's offset."""
    here = np.flatnonzero(holds_surface)
    texel_map = state.texel_map
    if texel_map is None:
        return here, here
    width = state.packed.width
    chart_at = np.full(holds_surface.shape, -1, dtype=np.int64)
    for chart in np.nonzero(texel_map.chart_page == page_index)[0]:
        x0, y0, x1, y1 = texel_map.boxes[chart]
        chart_at[y0:y1, x0:x1] = chart
    here = here[chart_at.ravel()[here] >= 0]   # every texel lies in its chart's box
    offsets = texel_map.offsets[chart_at.ravel()[here]]
    x, y = here % width - offsets[:, 0], here // width - offsets[:, 1]
    return here, y * state.atlas.width + x
