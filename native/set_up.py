"""The solver's set-up, in pieces that a UI can show between (Solver(..., staged=True)):
xatlas charts the surface (one call), the atlas is packed tight and held against the GPU's
memory; then the maps are made on the GPU and rasterized, each stage's records made, and the
emission measured. lightmap_atlas() charts as the set-up does, before any GPU work."""
import dataclasses
from dataclasses import dataclass, field
import math
import time

import numpy as np

from . import (lobes, memory, preprocess, receivers, selection, shooters, subdivision,
               thin_gaps, visibility)
from .atlas import build_atlas
from .packing import tight_packing
from .selection import MAX_COARSER_LEVELS, ShotQueue
from .state import BakeState

# What Solver(..., staged=True).set_up_step() works through, in order: xatlas charts the
# surface (one call, minutes on a million triangles), then the maps are made on the GPU.
SET_UP_STAGES = ("charting", "preprocessing")
# Pieces of the preprocessing stage, each one step of set_up_step().
PREPROCESS_PIECES = 4
# A point of state.blend_points: its texel (2 floats) and value (4 floats).
POINT_BYTES = (2 + 4) * 4


@dataclass
class SetUpProgress:
    stage: str          # what the next set_up_step() works on: one of SET_UP_STAGES
    fraction: float     # the share of the set-up done


@dataclass
class Bake:
    """What the set-up makes and the shots work on: the scene solved, the atlas its lightmaps
    are laid out on, the state the stages share and each stage's own record."""
    scene: object           # the scene given, back faces that receive added
    atlas: object           # the lightmaps' layout (atlas.Atlas)
    atlas_seconds: float    # of the set-up: xatlas and the tight packing, on the CPU
    memory_bytes: int       # what the maps take on the GPU (memory.memory_needed)
    state: BakeState
    slots: object           # subdivision.prepare's
    visibility: object      # visibility.create's
    gaps: object            # thin_gaps.ThinGaps
    shooters: object        # shooters.ShooterCaches
    queue: ShotQueue
    energy: object          # state.Energy
    # postprocess.ReflectedStart: the latest two, from when the direct light was shot on,
    # one more each time the unshot fraction halves.
    reflected_starts: list = field(default_factory=list)


def lightmap_atlas(scene, settings):
    """The atlas a Solver of ``scene`` and ``settings`` lays its lightmaps out on, charted
    before any GPU work (the Solver then finds it in build_atlas's cache): the add-on
    evaluates the materials per texel of it first. Refuses, as the Solver does, a density whose
    surface alone would overflow the memory."""
    scene = scene.with_back_faces()
    settings.validate()

    # No GL context yet: the Solver checks the texture size limit too.
    memory.check_surface_fits(scene, settings, lambda density: _fits_at(
        scene, settings, density, max_texture_size=math.inf))
    return _chart(scene, settings, settings.texel_density)


def pieces(scene, settings, ctx, gl):
    """The set-up's pieces, one per next(): charting, then preprocessing. After each piece
    but the last it yields the progress naming the next; it returns the Bake."""
    # Back faces that receive are solved as triangles of their own, after the scene's.
    scene = scene.with_back_faces()
    surfaces, emitting_surfaces = preprocess.number_surfaces(scene)
    state = BakeState(
        ctx=ctx, gl=gl, scene=scene, settings=settings,
        bounds=preprocess.bounds_of(scene),
        map_size=preprocess.visibility_map_size(settings, scene),
        surfaces=surfaces, emitting_surfaces=emitting_surfaces,
        glossy=lobes.has_glossy(scene), glossy_lobes=lobes.needed(scene))
    memory.check_visibility_map(settings, state.map_size)
    texel_bytes = memory.bytes_per_texel(scene)

    def fits_at(density):
        return _fits_at(scene, settings, density,
                        max_texture_size=ctx.info["GL_MAX_TEXTURE_SIZE"])

    memory.check_surface_fits(scene, settings, fits_at)
    started = time.perf_counter()
    atlas = state.atlas = _chart(scene, settings, settings.texel_density)
    # The GPU works on the charts packed tight; results go back to the atlas's layout.
    state.packed, state.texel_map = tight_packing(atlas, 1 << settings.shoot_level)
    state.patch_level = selection.patch_level(
        settings, float(scene.triangle_area[state.packed.triangles].sum()))
    atlas_seconds = time.perf_counter() - started
    state.receiver_batch = memory.receiver_batch(state.packed, settings, state.map_size,
                                                 texel_bytes=texel_bytes)
    layers = memory.visibility_layers(settings, state.receiver_batch)
    state.sun_tiles = preprocess.sun_tiles(state.bounds, state.map_size, layers)
    state.sun_batch = memory.sun_batch(layers, state.sun_tiles, state.receiver_batch)
    memory_bytes = memory.memory_needed(state.packed, settings, state.map_size,
                                        state.receiver_batch, texel_bytes=texel_bytes)
    fitting = memory.fits(state.packed, settings, state.map_size,
                          ctx.info["GL_MAX_TEXTURE_SIZE"], texel_bytes=texel_bytes)
    memory.check_memory(state.packed, settings, memory_bytes, fitting, fits_at)
    yield _preprocessing(0)

    preprocess.create_gpu_state(state)   # programs, albedo textures, pages
    for kind in receivers.PATCH_PROGRAMS.values():
        thin_gaps.set_constant_uniforms(state.programs[kind])
    yield _preprocessing(1)

    raster = preprocess.rasterize(state)
    slots = subdivision.prepare(state, raster, preprocess.RASTER_LAYOUT)
    if settings.subdivision == "REGULAR":
        subdivision.raise_levels(state, slots, np.nonzero(slots.receives)[0],
                                 settings.subdivision_level)
    yield _preprocessing(2)

    visibility_record = visibility.create(state)
    gaps = thin_gaps.create(state)
    block = 1 << (state.patch_level + (MAX_COARSER_LEVELS if settings.adaptive_shoot_level
                                       else 0))
    # What a shot changes in place (state.blend_points): grows with the largest such set.
    state.points_vbo = gl.buffer(reserve=block * block * POINT_BYTES)
    shooter_caches = shooters.ShooterCaches(
        occluders=visibility_record.occluders,
        staging=gl.buffer(reserve=shooters.staging_bytes(settings, block)))
    state.points_vao = gl.vertex_array(state.programs["take"], [
        (state.points_vbo, "2f 4f", "in_texel", "in_taken")])
    yield _preprocessing(3)

    energy = preprocess.measure_emission(state)
    state.receiver_tiles = receivers.create_tiles(state)
    queue = ShotQueue()
    lights = list(scene.lights) + receivers.sky_suns(scene.sky, settings.sky_directions)
    radius = state.bounds.radius
    queue.pending = [light for light in lights
                     if np.mean(receivers.light_power(light, radius)) > 0]
    energy.emitted = energy.emitted_maps + sum(
        (receivers.light_power(light, radius) for light in queue.pending), np.zeros(3))
    energy.emitted_scalar = float(np.mean(energy.emitted))
    return Bake(scene=scene, atlas=atlas, atlas_seconds=atlas_seconds,
                memory_bytes=memory_bytes, state=state, slots=slots,
                visibility=visibility_record, gaps=gaps, shooters=shooter_caches, queue=queue,
                energy=energy)


def _preprocessing(pieces_done):
    """The progress before the preprocessing stage's piece ``pieces_done`` + 1: charting
    counts as the first half of the set-up."""
    return SetUpProgress(stage=SET_UP_STAGES[1],
                         fraction=0.5 + 0.5 * pieces_done / PREPROCESS_PIECES)


def _chart(scene, settings, density):
    """The one call to build_atlas, so that the add-on's atlas and the Solver's are one."""
    return build_atlas(scene, density, settings.max_atlas_size, settings.padding,
                       align=1 << settings.shoot_level)


def _fits_at(scene, settings, density, max_texture_size):
    """Whether the packed atlas of ``density`` fits (memory's search for one that does); the
    automatic hemicube resolution follows the density too."""
    packed = tight_packing(_chart(scene, settings, density), 1 << settings.shoot_level)[0]
    map_size = preprocess.visibility_map_size(
        dataclasses.replace(settings, texel_density=density), scene)
    return memory.fits(packed, settings, map_size, max_texture_size,
                       texel_bytes=memory.bytes_per_texel(scene))
