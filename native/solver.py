"""Progressive-refinement radiosity on the GPU (Wallner 2008/2009, Section 2 of the
evaluation paper), in lightmap space, with the hemicube for visibility.

    solver = Solver(scene, Settings(texel_density=40))   # create: atlas, preprocess
    while solver.step():                                 # a light, or a batch of suns or patches
        print(solver.progress)                           # shots, unshot fraction, seconds
    pages = solver.result()                              # current lightmaps, any time
    solver.release()                                     # every GL object, in one place

    solver = Solver(scene, settings, staged=True)        # the set-up in pieces, for a UI
    while solver.set_up_step():                          # charting (xatlas), preprocessing
        print(solver.set_up_progress)                    # the next piece's stage, share done

Per texel the maps hold world position and area, normal, reflectance (what the texel
reflects into the room), the receiving surface's number, the subdivision level, the
accumulated irradiance E and the unshot radiance. A lightmap texel is rho * E / pi, rho the
diffuse albedo (kept on the CPU), the reflected diffuse radiance a Cycles DIFFUSE bake
(direct + indirect + colour) writes. Each stage of a shot is a module of its own (preprocess,
selection, shooters, visibility, subdivision, receivers, thin_gaps, postprocess); they share
the records of state.py. set_up.py makes them, in pieces; this module keeps the public API
and the per-shot loop.
"""
from dataclasses import dataclass
import math
import time

import numpy as np

from . import (postprocess, receivers, selection, set_up, shooters, subdivision, thin_gaps,
               visibility)
from .gpu import GLObjects, create_context, using
from .memory import BYTES_PER_TEXEL  # noqa: F401  (the add-on's tests read it here)
from .postprocess import Ledger  # noqa: F401  (native's API)
from .scene import SunLight
from .set_up import SET_UP_STAGES, SetUpProgress
from .settings import Settings, shot_limit
from .state import Shooter, View, read_map

PHASES = ("preprocess", "selection", "visibility", "subdivision", "receivers", "postprocess")


@dataclass
class Progress:
    shots: int
    # Measured at the latest selection of shooters; once finished, after the last shot.
    unshot_fraction: float
    seconds: float
    converged: bool          # the unshot fraction reached the threshold (or nothing is left)
    finished: bool           # converged, stopped at the shot limit, or diverged
    texels: int
    shot_limit: int          # Settings.max_shots, or the automatic limit where it is 0
    # The unshot power rose (shots made light): the bake stopped and went back to the last
    # checkpoint, whose unshot fraction this reports.
    diverged: bool = False

    @property
    def stopped_at_shot_limit(self):
        """Finished at the shot limit with more than the threshold still unshot."""
        return self.finished and not self.converged and not self.diverged


class Solver:
    """GPU progressive radiosity for one scene. Create, step, read progress and results,
    release. Pass ``ctx`` to share an existing moderngl context; every call makes it current
    with ``with ctx:`` and restores the caller's context afterwards."""

    def __init__(self, scene, settings=None, ctx=None, *, staged=False):
        """Chart and preprocess ``scene``; with ``staged`` only make the GL context, and leave
        the set-up to set_up_step(), a piece at a time."""
        self.settings = settings or Settings()
        self.settings.validate()
        self.timings = dict.fromkeys(PHASES, 0.0)
        self.shots = 0
        self.converged = False
        self.finished = False
        self.diverged = False
        self._unshot_fraction = 1.0
        self._least_unshot = math.inf   # W, the mean of RGB: what the rise is measured from
        self._checkpoint = None
        self._owns_context = ctx is None
        self.ctx = None
        self._gl = None
        self._set_up_pieces = None
        self._bake = None       # set_up.Bake, once the set-up is done
        self.set_up_progress = SetUpProgress(stage=SET_UP_STAGES[0], fraction=0.0)
        self._started = time.perf_counter()
        try:
            self.ctx = ctx if ctx is not None else create_context()
            self._gl = GLObjects(self.ctx)
        except BaseException:
            self.release()
            raise
        self._set_up_pieces = set_up.pieces(scene, self.settings, self.ctx, self._gl)
        if not staged:
            while self.set_up_step():
                pass

    # ----------------------------------------------------------------- public API
    def set_up_step(self):
        """Do the next piece of the set-up: True while pieces remain, set_up_progress naming
        the next. A piece is one call that cannot be interrupted: the charting piece is
        xatlas's. A failure releases the solver. Solver(..., staged=True) leaves the whole
        set-up to this; step() finishes what is left of it."""
        if self._set_up_pieces is None:
            return False
        try:
            with using(self.ctx):
                self.set_up_progress = self._timed("preprocess", next, self._set_up_pieces)
        except StopIteration as done:   # the last piece ran: the set-up returned the bake
            self._set_up_pieces, self._bake = None, done.value
            self.set_up_progress = SetUpProgress(stage=SET_UP_STAGES[-1], fraction=1.0)
        except BaseException:
            self.release()
            raise
        return self._set_up_pieces is not None

    def step(self):
        """Shoot once: the pending lights first, a point or spot light alone, suns (the
        sky's) a batch at a time, then the texel patches with the most unshot power, a batch
        of a selection's at a time (memory.receiver_batch; Progress.shots counts each).
        Returns False, shooting nothing, once converged or out of shots."""
        if self.finished or self.ctx is None:
            return False
        while self.set_up_step():
            pass
        if self.shots >= self.shot_limit:
            with using(self.ctx):   # the unshot fraction the bake stops at, measured
                self._measure_unshot()
            self.finished = True
            return False
        with using(self.ctx):
            queue = self._bake.queue
            if not queue.shots and not self._select_shots():
                self.finished = True
                return False
            shot = queue.shots.pop(0)
            # Patches shoot in batches, and suns (the sky's many); a point or spot light alone.
            batched = next((kind for kind in (Shooter, SunLight) if isinstance(shot, kind)),
                           None)
            batch = [shot]
            state = self._bake.state
            most = min(state.sun_batch if batched is SunLight else state.receiver_batch,
                       self.shot_limit - self.shots)
            while (batched is not None and len(batch) < most and queue.shots
                   and isinstance(queue.shots[0], batched)):
                batch.append(queue.shots.pop(0))
            if batched is Shooter:
                self._shoot_patches(batch)
            else:
                self._shoot_lights(batch)
            self.shots += len(batch)
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
                        self.converged, self.finished, self.texel_count, self.shot_limit,
                        diverged=self.diverged)

    def result(self, *, reflected=True):
        """Current lightmaps, one float32 (height, width, 4) array per atlas page, row 0 at
        v = 0 as in Blender images. RGB is reflected radiance, or with ``reflected`` False
        the irradiance that albedo / pi turns into it (three.js's lightMap, glTF's
        MOZ_lightmap); alpha 1 on occupied texels; the gutter around charts is filled with
        the neighbouring values (alpha 0)."""
        ambient = self._ambient if self.settings.ambient else None
        with using(self.ctx):
            return self._timed("postprocess", postprocess.lightmaps, self._bake.state, ambient,
                               reflected=reflected)

    def texel_samples(self):
        """Where each texel samples the surface, per page: a dict of (height, width, ...)
        arrays 'position' (world), 'normal', 'area' (world area the texel covers),
        'coverage' (the share of the texel square on the surface: 1 inside charts, less at
        their borders) and 'occupied' (a receiving texel). Row 0 at v = 0, as in result()."""
        with using(self.ctx):
            return postprocess.texel_samples(self._bake.state)

    def ledger(self):
        """Energy ledger from the GPU maps (read back, summed in double precision)."""
        bake = self._bake
        with using(self.ctx):
            queued = [shot for shot in bake.queue.shots if not isinstance(shot, Shooter)]
            return postprocess.ledger(bake.state, bake.energy, bake.gaps, [
                self._light_power(light) for light in bake.queue.pending + queued])

    def ambient_radiance(self):
        """The unshot light that has bounced at least once, as uniform radiance (Cohen et al.
        1988) on the texels it can reach: the share c of it that lands, spread over their
        area, times 1 / (1 - c * their mean albedo), the sum of its further bounces. Once the
        direct light is shot, c is what the recent reflected shots delivered over what they
        shot (since the unshot fraction was two to four times what it is), and the texels
        are those they reached (what a flat floor reflects into the open escapes; a room
        sealed from the light stays dark); before, c is received / shot of all shots, over
        every lit texel. Emission not yet shot (lights, emitting texels) is
        left out: direct light is far from even, and it shoots first anyway. result() adds
        albedo times this when Settings.ambient is on."""
        with using(self.ctx):
            return self._ambient([read_map(page.textures["irradiance"])
                                  for page in self._bake.state.pages]).radiance

    def _ambient(self, irradiance):
        bake = self._bake
        start = bake.reflected_starts[0] if bake.reflected_starts else None
        return postprocess.ambient_term(bake.state, bake.energy, irradiance,
                                        self._gap_correction(), start)

    def _gap_correction(self):
        return self._bake.gaps.arrived - self._bake.gaps.shown_received

    def release(self):
        """Release every GL object (and the context, if the solver made it). Idempotent."""
        self._set_up_pieces = None
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
    def scene(self):
        """The scene solved: the one given, back faces that receive added as triangles of
        their own (Scene.with_back_faces)."""
        return self._bake.scene

    @property
    def atlas(self):
        """The layout of the lightmaps result() returns."""
        return self._bake.atlas

    @property
    def atlas_seconds(self):
        """Of the set-up's time: xatlas's charting and the tight packing, on the CPU."""
        return self._bake.atlas_seconds

    @property
    def shot_limit(self):
        """Where step() stops above the threshold: Settings.max_shots, or where it is 0 a
        limit that grows with the scene's texels (settings.shot_limit)."""
        return shot_limit(self.settings, self.texel_count)

    @property
    def texel_count(self):
        return self._bake.energy.texel_count

    @property
    def gpu_memory_bytes(self):
        return self._bake.memory_bytes

    @property
    def page_size(self):
        """(width, height) of the lightmap pages result() returns (self.atlas's)."""
        return self.atlas.width, self.atlas.height

    @property
    def gpu_page_size(self):
        """(width, height) of the pages the GPU works on: the charts packed tight."""
        return self._bake.state.packed.width, self._bake.state.packed.height

    def _light_power(self, light):
        return receivers.light_power(light, self._bake.state.bounds.radius)

    # ----------------------------------------------------------------- the shots
    def _select_shots(self):
        """Measure the unshot power and queue the next shots: up to shooters_per_selection
        pending lights, or as many patches. False once converged."""
        bake = self._bake
        queue = bake.queue
        candidates = self._measure_unshot()
        if self.converged or self.diverged:
            return False
        count = min(self.settings.shooters_per_selection, self.shot_limit - self.shots)
        if queue.pending:
            queue.shots, queue.pending = queue.pending[:count], queue.pending[count:]
            return True
        if self._reflected_start_due():
            start = self._timed(
                "selection", postprocess.reflected_start, bake.state, bake.energy,
                [read_map(page.textures["irradiance"]) for page in bake.state.pages],
                self._gap_correction(), self._unshot_fraction)
            bake.reflected_starts = bake.reflected_starts[-1:] + [start]
        queue.shots = self._timed("selection", self._make_shooters, candidates, count)
        # The GPU's float sums saw power the texels do not hold.
        self.converged = not queue.shots
        return not self.converged

    def _measure_unshot(self):
        """Measure the unshot fraction, and whether it converged; returns the candidate
        blocks to shoot. Where it rose (shots made light), go back to the last checkpoint
        and stop: diverged, nothing to shoot."""
        bake = self._bake
        queue, energy = bake.queue, bake.energy
        candidates, total = self._timed("selection", selection.measure, bake.state)
        pending = sum(float(np.mean(self._light_power(light))) for light in queue.pending)
        unshot = total + pending
        # The power, not the fraction: the sun's light that misses the scene leaves the
        # fraction's denominator as it shoots.
        if unshot > (1.0 + postprocess.UNSHOT_RISE) * self._least_unshot:
            self._go_back()
            return []
        self._least_unshot = min(self._least_unshot, unshot)
        self._unshot_fraction = unshot / max(energy.emitted_scalar - energy.sunlight_missed,
                                             1e-30)
        self.converged = (self._unshot_fraction <= self.settings.threshold
                          or (not queue.pending and not candidates))
        kept = self._checkpoint
        if not self.converged and (kept is None or self._unshot_fraction
                                   <= postprocess.CHECKPOINT_FALL * kept.unshot_fraction):
            self._checkpoint = self._timed(
                "selection", postprocess.checkpoint, bake.state, energy, bake.gaps,
                queue.pending, bake.reflected_starts, self.shots, self._unshot_fraction)
        return candidates

    def _go_back(self):
        """Back to the last checkpoint, finished and diverged: its lightmaps, ledger and
        unshot fraction are the bake's."""
        bake = self._bake
        kept = self._checkpoint
        postprocess.restore(bake.state, kept, bake.gaps)
        bake.energy = kept.energy
        bake.queue.pending = list(kept.pending)
        bake.queue.shots = []
        bake.reflected_starts = list(kept.reflected_starts)
        self._unshot_fraction = kept.unshot_fraction
        self.converged = False
        self.diverged = self.finished = True

    def _reflected_start_due(self):
        """Whether to keep a new ReflectedStart: once the emission left unshot is within the
        threshold's share of all emitted (the lights are shot before any patch), then each
        time the unshot fraction has halved. The ambient term measures from the older of the
        latest two: the shots since then are much like those that will shoot what is left
        (dimmer patches in corners, whose light lands more than the floor's did)."""
        bake = self._bake
        if bake.reflected_starts:
            return self._unshot_fraction <= 0.5 * bake.reflected_starts[-1].unshot_fraction
        left = sum(float(np.mean(page.emission_left[1].sum(axis=0)))
                   for page in bake.state.pages)
        return left <= self.settings.threshold * bake.energy.emitted_scalar

    def _make_shooters(self, candidates, count):
        """Shooters of up to ``count`` candidate blocks (or of their finer parts), strongest
        first. Their texels are read back before any of them shoots, all in one wait for the
        GPU."""
        bake = self._bake
        state, caches = bake.state, bake.shooters
        chosen = selection.regions_to_shoot(state, bake.energy, bake.queue, candidates, count)
        made = []
        for (region, finer), maps in zip(chosen, shooters.read_blocks(
                state, caches, [region for region, _ in chosen])):
            finer = thin_gaps.parts_finer(state, bake.gaps, region, maps, finer)
            for part, part_maps, rows in shooters.parts(state, region, maps, finer):
                charts = shooters.charts_of(state, caches, region, maps, rows)
                shooter = shooters.make_shooter(state, caches, part, part_maps, charts)
                if shooter is not None:
                    shooter.extent = thin_gaps.extent(state, bake.gaps, part, part_maps,
                                                      shooter)
                    made.append(shooter)
        return made

    def _shoot_patches(self, batch):
        """Shoot a batch of patches: each one's visibility map, what each takes from its
        texels, each one's thin gaps, then one receiver pass for them all (the texels
        receive the sum, in any order)."""
        bake = self._bake
        state, energy = bake.state, bake.energy
        powers = [math.pi * shooter.area * shooter.radiance for shooter in batch]
        energy.shot_power = energy.shot_power + sum(powers)
        energy.reflected_surplus = energy.reflected_surplus + sum(
            shooter.surplus for shooter in batch)
        # Each shooter looks from just above its surface and clips what lies behind it.
        views = [View(eye=shooter.centre + shooter.frame[:, 2] * state.bounds.epsilon,
                      frame=shooter.frame, orthographic=False) for shooter in batch]
        self._timed("visibility", visibility.render_batch, state, bake.visibility, views)
        for shooter, view, power in zip(batch, views, powers):
            # Adaptive subdivision shoots one at a time (memory.receiver_batch): the map holds
            # this view alone.
            self._maybe_subdivide(view, float(np.mean(power)), clip_below=True)
            receivers.take_unshot(state, shooter)
        # The thin gaps' light first: what leaves them unshot is the batch's too.
        unshot_left = receivers.unshot_limit(energy, sum(powers))
        for shooter, power in zip(batch, powers):
            if shooter.extent is not None:
                unshot_left = unshot_left - self._timed(
                    "receivers", thin_gaps.close, state, bake.gaps, shooter,
                    receivers.unshot_limit(energy, power))
        receiving = receivers.receiving_shooters(state.receiver_tiles, batch,
                                                 state.bounds.epsilon)
        squares = receivers.square_tiles(state.receiver_tiles, batch, receiving)
        programs = receivers.PATCH_PROGRAMS
        receivers.set_patch_uniforms(state, batch, views, kinds=[
            programs[False], *([programs[True]] if squares.any() else [])])
        self._timed("receivers", receivers.update, state, bake.visibility, programs[False],
                    sum(powers), np.maximum(unshot_left, 0.0), receiving, squares)

    def _shoot_lights(self, lights):
        """Shoot a point or spot light, or a batch of suns: each one's visibility map, then
        one receiver pass for them all."""
        bake = self._bake
        state, energy = bake.state, bake.energy
        powers = [self._light_power(light) for light in lights]
        views = [receivers.light_view(light, state.bounds) for light in lights]
        if isinstance(lights[0], SunLight):
            self._timed("visibility", visibility.render_batch, state, bake.visibility, views,
                        faces=state.sun_faces, clip_below=False)
            # The suns' windows: what misses the scene is not left unshot.
            covered = self._timed("visibility", visibility.covered_shares, state,
                                  bake.visibility, len(lights))
            energy.sunlight_missed += sum(float(np.mean(power)) * (1.0 - share)
                                          for power, share in zip(powers, covered))
        else:
            self._timed("visibility", visibility.render, state, bake.visibility, views[0],
                        faces=visibility.ALL_FACES, clip_below=False)
        # Adaptive subdivision shoots one at a time (memory.receiver_batch).
        for view, power in zip(views, powers):
            self._maybe_subdivide(view, float(np.mean(power)), clip_below=False)
        power = sum(powers)
        energy.shot_power = energy.shot_power + power
        receivers.set_light_uniforms(state, lights, views)
        self._timed("receivers", receivers.update, state, bake.visibility, "light", power,
                    receivers.unshot_limit(energy, power))

    def _maybe_subdivide(self, view, power, *, clip_below):
        bake = self._bake
        queue = bake.queue
        queue.strongest_shot = max(queue.strongest_shot, power)
        if (self.settings.subdivision == "ADAPTIVE"
                and power >= subdivision.SUBDIVISION_MIN_SHARE * queue.strongest_shot):
            self._timed("subdivision", subdivision.subdivide_shadowed, bake.state, bake.slots,
                        bake.visibility, view, clip_below=clip_below)

    def _timed(self, phase, function, *args, **kwargs):
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            if self.settings.profile:
                self.ctx.finish()
            self.timings[phase] += time.perf_counter() - start
