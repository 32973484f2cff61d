"""How Luxel's time, shots and memory grow with the scene (bench/common.py has the command
line):

    python bench/scaling.py scaling           # texels and triangles: phases, memory, Cycles
    python bench/scaling.py density-scaling   # shots and seconds as the texel density grows
    python bench/scaling.py visibility-draw   # the visibility pass: geometry shader, per face
    python bench/scaling.py charting          # xatlas on the interior subdivided further
    python bench/scaling.py receiver-batch    # the receiver pass over a batch of shooters
    python bench/scaling.py set-up            # the longest wait for Esc in a bake's set-up
    python bench/scaling.py shot-limit        # the shots each sample scene needs

scaling, charting, set-up and shot-limit go through Blender (the bpy module); the others
bake the Cornell box of native.samples and bench/scenes/*.npz with the solver alone. Where
CPU seconds are given they are the process's (llvmpipe's threads included): on a CPU shared
with other jobs they measure the work, where wall-clock seconds measure the neighbours too."""
from collections import defaultdict
import dataclasses
import inspect
import math
import resource
import statistics
import time

import numpy as np

import accuracy
import common
from common import Study

UNSHOT_MILESTONE = 0.01     # the "reaches 1 % unshot" of the interior's target
# The realistic interior's room, left as it is when its furniture is subdivided further.
ROOM = {"walls", "floor", "ceiling", "window_cut"}


# ------------------------------------------------------------------------------ scaling
def scaling(rows, threshold):
    """Each row (scene, density or None for the file's, level: the interior's furniture
    subdivided that many levels more, luxel_seconds: Luxel's time cap, reference_samples: 0
    for no comparison, cycles_seconds: the cap on Cycles' curve) baked once through the
    extension with the GPU waited for after every phase (Settings.profile), its lightmaps
    snapshot at every half doubling of the shots; then, where asked, against Cycles: the
    times both take to 5, 2 and 1 % relative RMS (accuracy.py's debiased error, every shown
    copy counted). The rows run in one process in the order given, small to large, so that
    its peak resident memory after a row is that row's."""
    bpy, luxel = common.start_blender()
    results = []
    for spec in rows:
        common.open_blend(bpy, spec["scene"])
        if spec["level"]:
            subdivide_furniture(bpy, spec["level"])
        settings = bpy.context.scene.luxel
        if spec["density"] is not None:
            settings.texel_density = spec["density"]
        settings.threshold, settings.max_shots = threshold, 0
        bake, row = timed_bake(bpy.context, luxel, spec["luxel_seconds"])
        row.update(spec, density=settings.texel_density)
        print(f"{spec['scene']} +{spec['level']} at {row['density']:g} texels/m: "
              f"{row['triangles']:,} triangles, {row['texels']:,} texels, {row['shots']} shots "
              f"({row['stopped']}), {row['bake_seconds']:.1f} s", flush=True)
        if spec["reference_samples"]:
            row.update(against_cycles(bpy.context, luxel.addon, bake, spec))
        results.append(row)
    return {"threshold": threshold, "rows": results}


def subdivide_furniture(bpy, level):
    """Every furniture mesh of the open interior.blend ``level`` more Subdivision Surface
    levels (the sofa keeps its one level more); the walls, floor and ceiling as they are."""
    for obj in bpy.data.objects:
        if obj.type != 'MESH' or obj.name in ROOM:
            continue
        subdivision = next((m for m in obj.modifiers if m.type == 'SUBSURF'), None)
        if subdivision is None:
            subdivision = obj.modifiers.new("Subdivision", 'SUBSURF')
            subdivision.levels = 0
        subdivision.levels = subdivision.render_levels = subdivision.levels + level


def timed_bake(context, luxel, seconds_limit):
    """The bake with snapshots, each phase timed, stopped after ``seconds_limit``; returns the
    SnapshotBake and the row's Luxel columns."""
    addon, set_up_module = luxel.addon, luxel.native.set_up
    # The add-on's atlas and the solver's are both made through the set-up's build_atlas
    # (the second call finds the first's in the cache).
    charting, build_atlas = [], set_up_module.build_atlas
    set_up_module.build_atlas = timed_calls(build_atlas, charting)
    job = addon.bake.BakeJob(context)
    job.settings = dataclasses.replace(job.settings, profile=True)
    stages = {}
    job.stages = tuple(timed_stage(stage, stages) for stage in job.stages)
    try:
        job.set_up()
        bake = addon.compare.SnapshotBake(job)
        bake.snapshots = luxel.native.evaluation.snapshots.Snapshots(job.started,
                                                                     per_doubling=2)
        solver = job.solver
        milestone, capped = None, False
        while solver.step():
            bake.snapshots.after_step(solver)
            seconds = bake.snapshots.elapsed()
            if milestone is None and solver.progress.unshot_fraction <= UNSHOT_MILESTONE:
                milestone = {"shots": solver.shots, "seconds": seconds}
            if seconds > seconds_limit:
                capped = True
                break
        bake.snapshots.take(solver)
        progress, timings = solver.progress, dict(solver.timings)
        export_stage, materials_stage, solver_stage = (stages[stage.name]
                                                       for stage in job.stages)
        row = {
            "triangles": len(job.export.scene.triangles), "texels": solver.texel_count,
            "shots": progress.shots, "unshot_fraction": progress.unshot_fraction,
            "stopped": ("time cap" if capped else "shot limit" if progress.stopped_at_shot_limit
                        else "threshold"),
            "unshot_1_percent": milestone,
            "bake_seconds": bake.snapshots.seconds[-1],
            # The materials stage charts the atlas; the solver's call finds it in the cache.
            "export_seconds": export_stage,
            "materials_seconds": materials_stage - charting[0],
            "charting_seconds": sum(charting),
            "preprocess_seconds": solver_stage - sum(charting[1:]),
            "phases": timings,
            "visibility_ms_per_shot": 1e3 * timings["visibility"] / max(progress.shots, 1),
            "gpu_memory_bytes": solver.gpu_memory_bytes,
            "gpu_bytes_per_texel": solver.gpu_memory_bytes / solver.texel_count,
            "pages": solver.atlas.page_count, "gpu_page_size": list(solver.gpu_page_size),
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        }
    except BaseException:
        job.release()
        raise
    finally:
        set_up_module.build_atlas = build_atlas
    job.finish()
    return bake, row


def timed_calls(function, seconds):
    """``function``, each call's seconds appended to ``seconds``."""
    def timed(*args, **kwargs):
        started = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            seconds.append(time.perf_counter() - started)
    return timed


def timed_stage(stage, seconds):
    """``stage`` of a BakeJob, its pieces' seconds put into seconds[stage.name]."""
    def run():
        started = time.perf_counter()
        pieces = stage.run()
        if inspect.isgenerator(pieces):
            yield from pieces
        seconds[stage.name] = time.perf_counter() - started
    return dataclasses.replace(stage, run=run)


def against_cycles(context, addon, bake, spec):
    """The reference (two bakes of spec's reference_samples, averaged), Luxel's curve against
    it, Cycles' curve at 1, 4, 16, ... samples until the lowest target or until its next bake
    (about 4x the last) would end past spec's cycles_seconds, and the times to each target."""
    reference_module = addon.reference
    lightmap_error = addon.compare.lightmap_error
    started = time.perf_counter()
    first, second = (reference_module.cycles_reference(
        context, samples=spec["reference_samples"], seed=seed, copies=True) for seed in (11, 12))
    reference_seconds = time.perf_counter() - started
    names = sorted(first)
    reference = {name: accuracy.averaged(first[name], second[name]) for name in names}
    noise, magnitude = accuracy.noise_and_magnitude(names, first, second)
    page_of = {name: int(reference_module.luxel_page(context.scene, name)[
        addon.writeback.PAGE_KEY]) for name in names}
    snapshots = bake.snapshots
    luxel_curve = []
    for index, (shots, seconds) in enumerate(zip(snapshots.shots, snapshots.seconds)):
        error = lightmap_error([snapshots.page(index, page_of[name]) for name in names],
                               [reference[name] for name in names])
        luxel_curve.append({"shots": shots, "seconds": seconds, "rms": error.rms,
                            "rel_rms": error.relative_rms})
    accuracy.debiased(luxel_curve, noise, magnitude)
    cycles, spent, samples = [], 0.0, 1
    while True:
        started = time.perf_counter()
        bakes = reference_module.cycles_reference(context, samples=samples, seed=1, copies=True)
        seconds = time.perf_counter() - started
        spent += seconds
        error = lightmap_error([bakes[name] for name in names],
                               [reference[name] for name in names])
        cycles.append(accuracy.debiased([{"samples": samples, "seconds": seconds,
                                          "rms": error.rms, "rel_rms": error.relative_rms}],
                                        noise, magnitude)[0])
        if (cycles[-1]["rel_rms_debiased"] <= min(accuracy.TARGETS)
                or spent + 4 * seconds > spec["cycles_seconds"]):
            break
        samples *= 4
    times = accuracy.times_to(luxel_curve, cycles)
    for entry in times:
        print(f"{100 * entry['target']:g} %: Luxel {entry['luxel_seconds']}, "
              f"Cycles {entry['cycles_seconds']}", flush=True)
    return {"reference_seconds": reference_seconds,
            "reference_noise_rel": math.sqrt(noise) / magnitude, "objects": names,
            "luxel_curve": luxel_curve, "cycles_curve": cycles, "times_to": times}


# ------------------------------------------------------------------------------ charting
def charting(levels, density):
    """xatlas on the realistic interior with its furniture subdivided ``levels`` more (the
    walls, floor and ceiling as they are), exported through Blender, at ``density``: the
    solver's charting (Scene.with_back_faces(), the settings' page size, padding and block
    alignment) from an empty atlas cache, wall and CPU seconds (every thread), the growth of
    the process's peak resident memory, the atlas's texels and the GPU's tightly packed pages.
    Levels in rising order: each one's peak is its own."""
    bpy, luxel = common.start_blender()
    atlas_module, packing = luxel.native.atlas, luxel.native.packing
    rows = []
    for level in levels:
        common.open_blend(bpy, "interior")
        subdivide_furniture(bpy, level)
        scene = luxel.addon.export.export_scene(bpy.context).scene
        settings = luxel.native.Settings(texel_density=density)
        solved = scene.with_back_faces()
        atlas_module.clear_cache()
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        started, cpu_started = time.perf_counter(), time.process_time()
        atlas = atlas_module.build_atlas(solved, density, settings.max_atlas_size,
                                         settings.padding, align=1 << settings.shoot_level)
        seconds, cpu = time.perf_counter() - started, time.process_time() - cpu_started
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        packed, _ = packing.tight_packing(atlas, 1 << settings.shoot_level)
        rows.append({"level": level, "triangles": len(scene.triangles),
                     "charted_triangles": len(atlas.triangles), "atlas_seconds": seconds,
                     "atlas_cpu_seconds": cpu, "peak_rss_mb": peak / 1024,
                     "atlas_rss_growth_mb": (peak - before) / 1024, "pages": atlas.page_count,
                     "page_size": [atlas.width, atlas.height],
                     "texels": atlas.page_count * atlas.width * atlas.height,
                     "gpu_page_size": [packed.width, packed.height],
                     "charts": int(atlas.chart.max()) + 1, "unpacked": len(atlas.unpacked)})
        print(f"level {level}: {rows[-1]['triangles']:,} triangles, atlas {seconds:.1f} s "
              f"({cpu:.1f} s CPU), {rows[-1]['texels']:,} texels", flush=True)
    return {"density": density, "rows": rows}


# ----------------------------------------------------------------------- density scaling
def density_scaling(densities, threshold, max_shots):
    """The Cornell box baked to ``threshold`` at each density (no ambient term), each phase
    timed with a GPU sync after it: shots, wall and CPU seconds, the receiver pass per
    receiving texel per shot, and the GPU memory per texel."""
    from native import Settings, create_context
    from native.samples import cornell_box
    scene, ctx = cornell_box(), create_context()
    counted_bake(scene, Settings(texel_density=min(densities), threshold=0.5, max_shots=2),
                 ctx)       # compile the shaders before timing
    rows = []
    for density in densities:
        settings = Settings(texel_density=density, threshold=threshold, max_shots=max_shots,
                            ambient=False, profile=True)
        rows.append({"density": density, **counted_bake(scene, settings, ctx)})
        row = rows[-1]
        print(f"{density:g} texels/m: {row['texels']:,} texels, {row['shots']} shots, "
              f"{row['seconds']:.1f} s ({row['cpu_seconds']:.1f} CPU s)", flush=True)
    ctx.release()
    return {"scene": "cornell_box", "threshold": threshold, "rows": rows}


# ----------------------------------------------------------------------- visibility draw
VISIBILITY_PATHS = ("GEOMETRY_SHADER", "PER_FACE")     # Settings.visibility_draw


def visibility_draw(scenes, shots, repeats):
    """The visibility pass drawn both ways (Settings.visibility_draw: one geometry-shader pass
    that sends each triangle to the cube faces it reaches, or one draw per face of the
    clusters that can reach it), alternated, ``shots`` shots each (threshold 0, no ambient
    term, a GPU sync after every phase): the visibility phase's wall and CPU seconds per
    shot, medians of ``repeats``, and whether both bake the same lightmaps bit for bit.
    A scene is a dict of scene (native.samples' cornell_box or a bench/scenes name) and
    density."""
    from native import Settings, Solver, create_context, samples, visibility
    ctx = create_context()
    results = []
    for spec in scenes:
        name = spec["scene"]
        scene = getattr(samples, name)() if hasattr(samples, name) else common.load_scene(name)

        def bake(path, count):
            seconds = [0.0]
            originals = {key: getattr(visibility, key) for key in ("render", "render_batch")}
            for key, function in originals.items():
                setattr(visibility, key, cpu_timed(function, seconds))
            settings = Settings(texel_density=spec["density"], threshold=0.0, max_shots=count,
                                ambient=False, profile=True, visibility_draw=path)
            try:
                with Solver(scene, settings, ctx=ctx) as solver:
                    solver.run()
                    per_shot = max(solver.shots, 1)
                    return ({"wall": solver.timings["visibility"] / per_shot,
                             "cpu": seconds[0] / per_shot}, solver.result())
            finally:
                for key, function in originals.items():
                    setattr(visibility, key, function)
        for path in VISIBILITY_PATHS:           # compile the shaders before timing
            bake(path, 2)
        timings, lightmaps = {path: [] for path in VISIBILITY_PATHS}, {}
        for _ in range(repeats):
            for path in VISIBILITY_PATHS:
                timing, pages = bake(path, shots)
                timings[path].append(timing)
                lightmaps.setdefault(path, pages)
        first = lightmaps[VISIBILITY_PATHS[0]]
        identical = all(np.array_equal(a, b) for pages in lightmaps.values()
                        for a, b in zip(first, pages))
        medians = {path: {"visibility_seconds_per_shot": statistics.median(
                              t["wall"] for t in timings[path]),
                          "visibility_cpu_seconds_per_shot": statistics.median(
                              t["cpu"] for t in timings[path])}
                   for path in VISIBILITY_PATHS}
        results.append({**spec, "triangles": len(scene.triangles), "shots": shots,
                        "identical_lightmaps": identical, "medians": medians})
        print(f"{name}: " + ", ".join(
            f"{path} {1e3 * m['visibility_seconds_per_shot']:.2f} ms per shot"
            for path, m in medians.items()), flush=True)
    ctx.release()
    return {"scenes": results}


def cpu_timed(function, seconds):
    """``function`` (a visibility or receiver pass), its CPU seconds and its GPU sync's added
    to seconds[0]."""
    def call(state, *args, **kwargs):
        started = time.process_time()
        try:
            return function(state, *args, **kwargs)
        finally:
            state.ctx.finish()
            seconds[0] += time.process_time() - started
    return call


# ------------------------------------------------------------------------ receiver batch
VARIANTS = {"one by one": False, "batched": True}     # Settings.batched_receivers


def receiver_batch(scenes, runs):
    """Each scene (scene, density) baked to the default threshold once per variant and run,
    the variants alternated: the receiver pass one shooter at a time against over a batch of
    a selection's shooters. Per bake: nanoseconds per receiving texel per shot (the receiver
    passes over the sum, over the shots, of the texels of the tiles each shot draws:
    receivers.receiving_tiles, the same count for both), wall and CPU."""
    from native import Settings, create_context
    ctx = create_context()
    bakes = []
    for spec in scenes:
        scene = common.load_scene(spec["scene"])
        for run in range(runs):
            for variant, batched in VARIANTS.items():
                settings = Settings(profile=True, texel_density=spec["density"],
                                    batched_receivers=batched)
                row = {**spec, "variant": variant, "run": run,
                       **counted_bake(scene, settings, ctx)}
                bakes.append(row)
                print(f"{spec['scene']} run {run} {variant}: {row['shots']} shots, "
                      f"{row['seconds']:.1f} s, {row['ns_per_texel_per_shot']:.0f} ns per "
                      f"texel per shot ({row['cpu_ns_per_texel_per_shot']:.0f} CPU)",
                      flush=True)
    ctx.release()
    return {"bakes": bakes}


def counted_bake(scene, settings, ctx):
    """A bake to the threshold, its receiver passes counted (the texels of the tiles each
    shot draws) and their CPU seconds timed."""
    from native import Solver, receivers
    from native.gpu import using
    receiving, receiver_cpu = [0], [0.0]
    receiving_tiles, update = receivers.receiving_tiles, receivers.update

    def counted(tiles, shooter, epsilon):
        chosen = receiving_tiles(tiles, shooter, epsilon)
        boxes = tiles.boxes[chosen]
        receiving[0] += int(((boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])).sum())
        return chosen
    receivers.receiving_tiles, receivers.update = counted, cpu_timed(update, receiver_cpu)
    start, start_cpu = time.perf_counter(), time.process_time()
    try:
        with Solver(scene, settings, ctx=ctx) as solver:
            solver.run()
            solver.result()
            with using(ctx):
                ctx.finish()
            receiver_seconds = solver.timings["receivers"]
            return {"texels": solver.texel_count, "shots": solver.shots,
                    "unshot_fraction": solver.progress.unshot_fraction,
                    "gpu_memory_mib": solver.gpu_memory_bytes / 2**20,
                    "gpu_bytes_per_texel": solver.gpu_memory_bytes / solver.texel_count,
                    "receiving_texels": receiving[0],
                    "ns_per_texel_per_shot": 1e9 * receiver_seconds / max(receiving[0], 1),
                    "cpu_ns_per_texel_per_shot": 1e9 * receiver_cpu[0] / max(receiving[0], 1),
                    "seconds": time.perf_counter() - start,
                    "cpu_seconds": time.process_time() - start_cpu,
                    "phases": dict(solver.timings)}
    finally:
        receivers.receiving_tiles, receivers.update = receiving_tiles, update


# -------------------------------------------------------------------------------- set-up
SHOT_MARKS = (0.1, 0.05, 0.02, 0.01)


def set_up(scenes):
    """How long Esc waits during a bake's set-up: a BakeJob on each scene at its saved
    settings, stepped one piece at a time as the modal operator steps it, each piece timed."""
    bpy, luxel = common.start_blender()
    return {"pieces": [set_up_pieces(bpy, luxel, name) for name in scenes]}


def shot_limit(scenes, density_scale, seconds):
    """The shots each scene needs to reach its threshold at its saved settings, its texel
    density times ``density_scale`` (shots grow with the shooting blocks, so shots per block
    carry over to the saved density), within ``seconds``: the measure behind Max Shots'
    automatic limit."""
    bpy, luxel = common.start_blender()
    return {"density_scale": density_scale, "seconds": seconds,
            "rows": [shots_needed(bpy, luxel, name, density_scale, seconds)
                     for name in scenes]}


def set_up_pieces(bpy, luxel, name):
    common.open_blend(bpy, name)
    started = time.perf_counter()
    job = luxel.addon.bake.BakeJob(bpy.context)
    stages = defaultdict(list)   # stage: seconds of each of its pieces
    try:
        while not job.is_set_up:
            stage = job.set_up_progress.stage
            before = time.perf_counter()
            job.step(0.0)
            stages[stage].append(time.perf_counter() - before)
        row = {"scene": name, "triangles": len(job.export.scene.triangles),
               "texels": job.solver.texel_count, "set_up_seconds": time.perf_counter() - started,
               "longest_piece_seconds": max(max(each) for each in stages.values()),
               "stages": {stage: {"pieces": len(each), "seconds": sum(each),
                                  "longest_seconds": max(each)}
                          for stage, each in stages.items()}}
    finally:
        job.release()
    print(f"{name}: set-up {row['set_up_seconds']:.1f} s, longest piece "
          f"{row['longest_piece_seconds']:.2f} s", flush=True)
    return row


def shots_needed(bpy, luxel, name, density_scale, seconds):
    common.open_blend(bpy, name)
    export = luxel.addon.export.export_scene(bpy.context)
    saved = bpy.context.scene.luxel.solver_settings()
    settings = dataclasses.replace(saved, max_shots=10 ** 9,
                                   texel_density=saved.texel_density * density_scale)
    block = 1 << settings.shoot_level
    reached = {}
    with luxel.native.Solver(export.scene, settings) as solver:
        while solver.step():
            for mark in SHOT_MARKS:
                if mark not in reached and solver.progress.unshot_fraction <= mark:
                    reached[mark] = solver.progress.shots
            if solver.progress.seconds > seconds:
                break
        progress = solver.progress
        row = {"scene": name, "triangles": len(export.scene.triangles),
               "density": settings.texel_density, "threshold": settings.threshold,
               "shoot_level": settings.shoot_level, "texels": solver.texel_count,
               "blocks": solver.texel_count / block ** 2, "shots": progress.shots,
               "unshot": progress.unshot_fraction, "converged": progress.converged,
               "seconds": progress.seconds,
               "shots_to": {str(mark): reached.get(mark) for mark in SHOT_MARKS}}
    print(f"{name} at {row['density']:g} texels/m: {row['shots']} shots, "
          f"{100 * row['unshot']:.2f} % unshot, {row['blocks']:.0f} blocks", flush=True)
    return row


def scaling_row(scene, density, *, level=0, luxel_seconds=600.0, reference_samples=0,
                cycles_seconds=0.0):
    return {"scene": scene, "density": density, "level": level, "luxel_seconds": luxel_seconds,
            "reference_samples": reference_samples, "cycles_seconds": cycles_seconds}


STUDIES = (
    Study("scaling", scaling, {
        "quick": dict(threshold=0.05, rows=[
            scaling_row("cornell_box", 20.0, reference_samples=16, cycles_seconds=5.0)]),
        "cpu": dict(threshold=0.002, rows=[
            scaling_row("cornell_box", 60.0, luxel_seconds=60.0, reference_samples=256,
                        cycles_seconds=60.0),
            scaling_row("cornell_box", 120.0, luxel_seconds=60.0, reference_samples=128,
                        cycles_seconds=90.0),
            scaling_row("interior", None, luxel_seconds=120.0),
            scaling_row("interior", None, level=4, luxel_seconds=30.0)]),
        "gpu": dict(threshold=0.002, rows=[
            scaling_row("cornell_box", 60.0, reference_samples=1024, cycles_seconds=400.0),
            scaling_row("cornell_box", 120.0, reference_samples=256, cycles_seconds=400.0),
            scaling_row("cornell_box", 240.0, reference_samples=128, cycles_seconds=450.0),
            scaling_row("cornell_box", 480.0, reference_samples=64, cycles_seconds=450.0),
            scaling_row("interior", None, reference_samples=128, cycles_seconds=600.0),
            scaling_row("interior", None, level=4, luxel_seconds=300.0),
            scaling_row("interior", None, level=5, luxel_seconds=300.0),
            scaling_row("interior", None, level=6, luxel_seconds=400.0)])}, blender=True),
    Study("density-scaling", density_scaling, {
        "quick": dict(densities=[20.0], threshold=0.05, max_shots=200),
        "cpu": dict(densities=[60.0, 120.0], threshold=0.003, max_shots=10_000),
        "gpu": dict(densities=[60.0, 120.0, 240.0, 480.0], threshold=0.003,
                    max_shots=20_000)}),
    Study("visibility-draw", visibility_draw, {
        "quick": dict(scenes=[{"scene": "cornell_box", "density": 20.0}], shots=10, repeats=1),
        "cpu": dict(scenes=[{"scene": "cornell_box", "density": 60.0},
                            {"scene": "living", "density": 4.0}], shots=200, repeats=1),
        "gpu": dict(scenes=[{"scene": "cornell_box", "density": 60.0},
                            {"scene": "living", "density": 4.0}], shots=200, repeats=3)}),
    Study("charting", charting, {
        "quick": dict(levels=[0], density=10.0), "cpu": dict(levels=[3, 4], density=10.0),
        "gpu": dict(levels=[3, 4, 5, 6], density=10.0)}, blender=True),
    Study("receiver-batch", receiver_batch, {
        "quick": dict(scenes=[{"scene": "cornell_box", "density": 20.0}], runs=1),
        "cpu": dict(scenes=[{"scene": "cornell_box", "density": 60.0},
                            {"scene": "interior", "density": 10.0}], runs=1),
        "gpu": dict(scenes=[{"scene": "cornell_box", "density": 160.0},
                            {"scene": "interior", "density": 20.0}], runs=2)}),
    Study("set-up", set_up, {
        "quick": dict(scenes=["cornell_box"]), "cpu": dict(scenes=["interior", "office"]),
        "gpu": dict(scenes=["interior", "temple", "office", "living"])}, blender=True),
    Study("shot-limit", shot_limit, {
        "quick": dict(scenes=["cornell_box"], density_scale=0.25, seconds=5.0),
        "cpu": dict(scenes=["cornell_box", "interior", "living"], density_scale=0.25,
                    seconds=30.0),
        "gpu": dict(scenes=["cornell_box", "columns", "interior", "temple", "office",
                            "living"], density_scale=1.0, seconds=300.0)}, blender=True),
)

if __name__ == "__main__":
    common.main(__doc__.split("\n\n")[0], STUDIES)
