"""Progressive-refinement radiosity on the GPU (Wallner 2008/2009, Section 2 of the
evaluation paper), in lightmap space, with the hemicube for visibility.

    solver = Solver(scene, Settings(texel_density=40))   # create: atlas, preprocess
    while solver.step():                                 # one shot at a time
        print(solver.progress)                           # shots, unshot fraction, seconds
    pages = solver.result()                              # current lightmaps, any time
    solver.release()                                     # every GL object, in one place

Per texel the maps hold world position and area, normal, albedo, the receiving surface's
number, the subdivision level, the accumulated irradiance E and the unshot radiance. A
lightmap texel is rho * E / pi, the reflected diffuse radiance a Cycles DIFFUSE bake (direct
+ indirect + colour) writes. Each stage of a shot is a module of its own (preprocess,
selection, shooters, visibility, subdivision, receivers, thin_gaps, postprocess); they share
the records of state.py. This module keeps the public API and the per-shot loop.
"""
from dataclasses import dataclass
import math
import time

import numpy as np

from . import (memory, postprocess, preprocess, receivers, selection, shooters, subdivision,
               thin_gaps, visibility)
from .atlas import build_atlas, tight_packing
from .gpu import GLObjects, create_context, using
from .memory import BYTES_PER_TEXEL  # noqa: F401  (the add-on's tests read it here)
from .postprocess import Ledger  # noqa: F401  (native's API)
from .selection import MAX_COARSER_LEVELS, ShotQueue
from .settings import Settings
from .state import BakeState, Shooter, View, read_map

PHASES = ("preprocess", "selection", "visibility", "subdivision", "receivers", "postprocess")
# A point of state.blend_points: its texel (2 floats) and value (4 floats).
POINT_BYTES = (2 + 4) * 4


@dataclass
class Progress:
    shots: int
    unshot_fraction: float   # measured before the latest shot
    seconds: float
    converged: bool          # the unshot fraction reached the threshold (or nothing is left)
    finished: bool           # converged, or stopped at max_shots
    texels: int


class Solver:
    """GPU progressive radiosity for one scene. Create, step, read progress and results,
    release. Pass ``ctx`` to share an existing moderngl context; every call makes it current
    with ``with ctx:`` and restores the caller's context afterwards."""

    def __init__(self, scene, settings=None, ctx=None):
        # Back faces that receive are solved as triangles of their own, after the scene's.
        self.scene = scene.with_back_faces()
        self.settings = settings or Settings()
        self.settings.validate()
        self.timings = dict.fromkeys(PHASES, 0.0)
        self.shots = 0
        self.converged = False
        self.finished = False
        self._unshot_fraction = 1.0
        self._owns_context = ctx is None
        self.ctx = None
        self._gl = None
        self._started = time.perf_counter()
        try:
            self.ctx = ctx if ctx is not None else create_context()
            self._gl = GLObjects(self.ctx)
            with using(self.ctx):
                self._timed("preprocess", self._preprocess)
        except BaseException:
            self.release()
            raise

    # ----------------------------------------------------------------- public API
    def step(self):
        """Shoot once: the pending lights first, then the texel patches with the most unshot
        power. Returns False, shooting nothing, once converged or out of shots."""
        if self.finished or self.ctx is None:
            return False
        if self.shots >= self.settings.max_shots:
            self.finished = True
            return False
        with using(self.ctx):
            if not self._queue.shots and not self._select_shots():
                self.finished = True
                return False
            shot = self._queue.shots.pop(0)
            if isinstance(shot, Shooter):
                self._shoot_patch(shot)
            else:
                self._shoot_light(shot)
            self.shots += 1
        return True

    def run(self, callback=None):
        """Step until finished; ``callback(progress)`` after each shot may return False to stop."""
        while self.step():
            if callback is not None and callback(self.progress) is False:
                break
        return self.progress

    @property
    def progress(self):
        return Progress(self.shots, self._unshot_fraction, time.perf_counter() - self._started,
                        self.converged, self.finished, self.texel_count)

    def result(self):
        """Current lightmaps, one float32 (height, width, 4) array per atlas page, row 0 at
        v = 0 as in Blender images. RGB is reflected radiance, alpha 1 on occupied texels;
        the gutter around charts is filled with the neighbouring values (alpha 0)."""
        ambient = self._ambient if self.settings.ambient else None
        with using(self.ctx):
            return self._timed("postprocess", postprocess.lightmaps, self._state, ambient)

    def texel_samples(self):
        """Where each texel samples the surface, per page: a dict of (height, width, ...)
        arrays 'position' (world), 'normal', 'area' (world area the texel covers),
        'coverage' (the share of the texel square on the surface: 1 inside charts, less at
        their borders) and 'occupied' (a receiving texel). Row 0 at v = 0, as in result()."""
        with using(self.ctx):
            return postprocess.texel_samples(self._state)

    def ledger(self):
        """Energy ledger from the GPU maps (read back, summed in double precision)."""
        with using(self.ctx):
            queued = [shot for shot in self._queue.shots if not isinstance(shot, Shooter)]
            return postprocess.ledger(self._state, self._energy, self._gaps, [
                self._light_power(light) for light in self._queue.pending + queued])

    def ambient_radiance(self):
        """The unshot light that has bounced at least once, as uniform radiance (Cohen et al.
        1988): the share c of it that lands (c = received / shot so far: 1 in a closed
        room), spread over the area, times 1 / (1 - c * mean albedo), the sum of its further
        bounces. Emission not yet shot (lights, emitting texels) is left out: direct light
        is far from even, and it shoots first anyway. result() adds albedo times this when
        Settings.ambient is on."""
        with using(self.ctx):
            return self._ambient([read_map(page.textures["irradiance"])
                                  for page in self._state.pages])

    def _ambient(self, irradiance):
        return postprocess.ambient_radiance(self._state, self._energy, irradiance,
                                            self._gaps.arrived - self._gaps.shown_received)

    def release(self):
        """Release every GL object (and the context, if the solver made it). Idempotent."""
        if self._gl is not None:
            with using(self.ctx):
                self._gl.release()
            self._gl = None
        if self.ctx is not None and self._owns_context:
            self.ctx.release()
        self.ctx = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()

    @property
    def gl_object_count(self):
        return 0 if self._gl is None else len(self._gl)

    @property
    def texel_count(self):
        return self._energy.texel_count

    @property
    def gpu_memory_bytes(self):
        return self._memory_bytes

    @property
    def page_size(self):
        """(width, height) of the lightmap pages result() returns (self.atlas's)."""
        return self.atlas.width, self.atlas.height

    @property
    def gpu_page_size(self):
        """(width, height) of the pages the GPU works on: the charts packed tight."""
        return self._state.packed.width, self._state.packed.height

    # ----------------------------------------------------------------- preprocess
    def _preprocess(self):
        settings, scene, gl = self.settings, self.scene, self._gl
        surfaces, emitting_surfaces = preprocess.number_surfaces(scene)
        state = self._state = BakeState(
            ctx=self.ctx, gl=gl, scene=scene, settings=settings,
            bounds=preprocess.bounds_of(scene), map_size=preprocess.visibility_map_size(settings),
            surfaces=surfaces, emitting_surfaces=emitting_surfaces)
        memory.check_surface_fits(scene, settings, self._fits_at)
        started = time.perf_counter()
        self.atlas = state.atlas = self._chart(settings.texel_density)
        # The GPU works on the charts packed tight; results go back to self.atlas's layout.
        state.packed, state.texel_map = tight_packing(self.atlas, 1 << settings.shoot_level)
        state.patch_level = selection.patch_level(
            settings, float(scene.triangle_area[state.packed.triangles].sum()))
        self.atlas_seconds = time.perf_counter() - started   # of preprocess: xatlas, on the CPU
        self._memory_bytes = memory.memory_needed(state.packed, settings, state.map_size)
        memory.check_memory(state.packed, settings, self._memory_bytes,
                            self._fits(state.packed), self._fits_at)

        preprocess.create_gpu_state(state)   # programs, albedo textures, pages
        thin_gaps.set_constant_uniforms(state.programs["patch"])
        raster = preprocess.rasterize(state)
        self._slots = subdivision.prepare(state, raster, preprocess.RASTER_LAYOUT)
        if settings.subdivision == "REGULAR":
            subdivision.raise_levels(state, self._slots, np.nonzero(self._slots.receives)[0],
                                     settings.subdivision_level)
        self._visibility = visibility.create(state)
        self._gaps = thin_gaps.create(state)
        block = 1 << (state.patch_level + (MAX_COARSER_LEVELS if settings.adaptive_shoot_level
                                           else 0))
        # What a shot changes in place (state.blend_points): grows with the largest such set.
        state.points_vbo = gl.buffer(reserve=block * block * POINT_BYTES)
        self._shooters = shooters.ShooterCaches(
            occluders=self._visibility.occluders,
            staging=gl.buffer(reserve=shooters.staging_bytes(settings, block)))
        state.points_vao = gl.vertex_array(state.programs["take"], [
            (state.points_vbo, "2f 4f", "in_texel", "in_taken")])
        self._queue = ShotQueue()

        self._measure_emission()
        lights = list(scene.lights) + receivers.sky_suns(scene.sky, settings.sky_directions)
        pending = self._queue.pending = [light for light in lights
                                         if np.mean(self._light_power(light)) > 0]
        energy = self._energy
        energy.emitted = energy.emitted_maps + sum((self._light_power(l) for l in pending),
                                                   np.zeros(3))
        energy.emitted_scalar = float(np.mean(energy.emitted))

    def _measure_emission(self):
        self._energy = preprocess.measure_emission(self._state)
        self._state.receiver_tiles = receivers.create_tiles(self._state)

    def _chart(self, density):
        return build_atlas(self.scene, density, self.settings.max_atlas_size,
                           self.settings.padding, align=1 << self.settings.shoot_level)

    def _fits(self, atlas):
        return memory.fits(atlas, self.settings, self._state.map_size,
                           self.ctx.info["GL_MAX_TEXTURE_SIZE"])

    def _fits_at(self, density):
        """Whether the packed atlas of ``density`` fits (memory's search for one that does)."""
        return self._fits(tight_packing(self._chart(density), 1 << self.settings.shoot_level)[0])

    def _light_power(self, light):
        return receivers.light_power(light, self._state.bounds.radius)

    # ----------------------------------------------------------------- the shots
    def _select_shots(self):
        """Measure the unshot power and queue the next shots: up to shooters_per_selection
        pending lights, or as many patches. False once converged."""
        queue, energy = self._queue, self._energy
        candidates, total = self._timed("selection", selection.measure, self._state)
        pending = sum(float(np.mean(self._light_power(light))) for light in queue.pending)
        self._unshot_fraction = (total + pending) / max(
            energy.emitted_scalar - energy.sunlight_missed, 1e-30)
        self.converged = (self._unshot_fraction <= self.settings.threshold
                          or (not queue.pending and not candidates))
        if self.converged:
            return False
        count = min(self.settings.shooters_per_selection, self.settings.max_shots - self.shots)
        if queue.pending:
            queue.shots, queue.pending = queue.pending[:count], queue.pending[count:]
            return True
        queue.shots = self._timed("selection", self._make_shooters, candidates, count)
        # The GPU's float sums saw power the texels do not hold.
        self.converged = not queue.shots
        return not self.converged

    def _make_shooters(self, candidates, count):
        """Shooters of up to ``count`` candidate blocks (or of their finer parts), strongest
        first. Their texels are read back before any of them shoots, all in one wait for the
        GPU."""
        state, caches = self._state, self._shooters
        chosen = selection.regions_to_shoot(state, self._energy, self._queue, candidates, count)
        made = []
        for (region, finer), maps in zip(chosen, shooters.read_blocks(
                state, caches, [region for region, _ in chosen])):
            for part, part_maps, rows in shooters.parts(state, region, maps, finer):
                charts = shooters.charts_of(state, caches, region, maps, rows)
                shooter = shooters.make_shooter(state, caches, part, part_maps, charts)
                if shooter is not None:
                    shooter.extent = thin_gaps.extent(state, self._gaps, part, part_maps,
                                                      shooter)
                    made.append(shooter)
        return made

    def _shoot_patch(self, shooter):
        state, energy = self._state, self._energy
        shot_power = math.pi * shooter.area * shooter.radiance
        energy.shot_power = energy.shot_power + shot_power
        # The shooter looks from just above its surface and clips what lies behind it.
        view = View(eye=shooter.centre + shooter.frame[:, 2] * state.bounds.epsilon,
                    frame=shooter.frame, orthographic=False)
        self._timed("visibility", visibility.render, state, self._visibility, view,
                    faces=visibility.FRONT_FACES, clip_below=True)
        self._maybe_subdivide(view, float(np.mean(shot_power)), clip_below=True)
        receivers.take_unshot(state, shooter)
        receivers.set_patch_uniforms(state, shooter)
        receiving = receivers.receiving_tiles(state.receiver_tiles, shooter, state.bounds.epsilon)
        self._timed("receivers", receivers.update, state, self._visibility, view, "patch",
                    receiving)
        if shooter.extent is not None:
            self._timed("receivers", thin_gaps.close, state, self._gaps, shooter)

    def _shoot_light(self, light):
        state, energy = self._state, self._energy
        power = self._light_power(light)
        view = receivers.light_view(light, state.bounds)
        receivers.set_light_uniforms(state, light)
        faces = visibility.SUN_FACES if view.orthographic else visibility.ALL_FACES
        self._timed("visibility", visibility.render, state, self._visibility, view,
                    faces=faces, clip_below=False)
        if view.orthographic:   # the sun's window: what misses the scene is not left unshot
            energy.sunlight_missed += float(np.mean(power)) * (
                1.0 - visibility.covered_share(state, self._visibility))
        self._maybe_subdivide(view, float(np.mean(power)), clip_below=False)
        energy.shot_power = energy.shot_power + power
        self._timed("receivers", receivers.update, state, self._visibility, view, "light")

    def _maybe_subdivide(self, view, power, *, clip_below):
        queue = self._queue
        queue.strongest_shot = max(queue.strongest_shot, power)
        if (self.settings.subdivision == "ADAPTIVE"
                and power >= subdivision.SUBDIVISION_MIN_SHARE * queue.strongest_shot):
            self._timed("subdivision", subdivision.subdivide_shadowed, self._state, self._slots,
                        self._visibility, view, clip_below=clip_below)

    def _timed(self, phase, function, *args, **kwargs):
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            if self.settings.profile:
                self.ctx.finish()
            self.timings[phase] += time.perf_counter() - start
