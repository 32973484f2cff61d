"""The paper's tables and figures on our scenes (bench/common.py has the command line):

    python bench/paper.py table1          # fixed shots on the four scenes, every projection
    python bench/paper.py table1-cycles   # Table 1's CPU column: Cycles in the same texels
    python bench/paper.py figure1         # the per-step breakdown on the Cornell box
    python bench/paper.py table2          # the projections and subdivision, RMS and time
    python bench/paper.py figure6         # unshot energy against shots

Scenes come from bench/scenes/*.npz (bench/export_scenes.py), so only table1-cycles needs
Blender. Timed bakes run twice where phases are reported: with a GPU sync after every phase
(the breakdown, Settings.profile) and without (the time a user gets, "seconds").

- A paper "size" s (Table 2, Figure 6) is s texels across the scene's reference quad (the
  Cornell box's back wall, the columns' floor; bench/common.py): the paper gave each triangle
  an s x s texture, our lightmaps are one atlas at a texel density. The shooting level is the
  coarsest whose blocks fit the scene's narrowest object, the nearest we have to the paper's
  shooting from each triangle's own texture.
- Table 2's RMS is the paper's eq. 1 (the printed one leaves out the square) against the
  hemicube bake of the same row, over the texels occupied in both and outside the emitters'
  near field (emitter_spheres); relative RMS divides it by the reference's RMS. ADAPTIVE: the
  paper gave the hemicube the subdivision the hemisphere run chose; here each projection
  refines where its own visibility finds shadow edges.
"""
import dataclasses
import math
import time

import numpy as np

import common
from common import Study, load_scene
from native import PROJECTIONS, Settings, Solver, create_context
from native.atlas import charted_triangles, clear_cache
from native.evaluation.texel_error import lightmap_error
from native.gpu import using
from native.samples import cornell_box
from native.solver import PHASES

# The paper's Table 1: shots, its GPU element counts per size, its GeForce 8800GTS seconds
# (hemicube, non-linear hemisphere) per size, and its CPU solver's seconds at the low size.
PAPER = {
    "cornell_box": {"shots": 32, "elements": {"low": 11_802, "medium": 94_750,
                                              "high": 1_115_126},
                    "seconds": {"low": (1.15, 0.79), "medium": (1.13, 0.75),
                                "high": (1.48, 1.17)}, "cpu_solver_seconds": 1.97},
    "temple": {"shots": 24, "elements": {"low": 126_078, "medium": 516_312, "high": 2_074_242},
               "seconds": {"low": (12.58, 9.74), "medium": (12.72, 9.92),
                           "high": (13.18, 10.03)}, "cpu_solver_seconds": 5.60},
    "office": {"shots": 96, "elements": {"low": 254_572, "medium": 854_341, "high": 1_843_771},
               "seconds": {"low": (42.46, 18.46), "medium": (42.44, 18.03),
                           "high": (43.03, 18.73)}, "cpu_solver_seconds": 36.17},
    "living": {"shots": 32, "elements": {"low": 472_317, "medium": 866_330, "high": 1_612_067},
               "seconds": {"low": (33.10, 20.18), "medium": (33.24, 20.05),
                           "high": (33.45, 20.61)}, "cpu_solver_seconds": 37.23},
}
TABLE1_HEMICUBE = 256
# Table 2's rows, (subdivision, level, size), in the paper's order.
TABLE2_ROWS = (("NONE", 0, 256), ("ADAPTIVE", 3, 32), ("REGULAR", 3, 32), ("ADAPTIVE", 3, 64),
               ("REGULAR", 3, 64), ("ADAPTIVE", 2, 32), ("REGULAR", 2, 32),
               ("ADAPTIVE", 2, 64), ("REGULAR", 2, 64))
TABLE2_REFERENCE, TABLE2_COMPARED = "HEMICUBE", ("HEMISPHERE", "NONLINEAR")


# ------------------------------------------------------------------------------ Table 1
def charted_area(scene):
    """Square metres that get texels: receiving and emitting triangles."""
    return float(scene.triangle_area[charted_triangles(scene)].sum())


def fixed_shots_bake(scene, ctx, settings):
    """A bake of ``settings``'s max_shots from a cold atlas cache, timed from the solver's
    creation to its read-back."""
    clear_cache()
    start = time.perf_counter()
    with Solver(scene, settings, ctx=ctx) as solver:
        solver.run()
        solver.result()
        with using(ctx):
            ctx.finish()
        return {"seconds": time.perf_counter() - start, "texels": solver.texel_count,
                "atlas": list(solver.page_size), "pages": solver.atlas.page_count,
                "atlas_seconds": solver.atlas_seconds, "shots": solver.shots,
                "unshot_fraction": solver.progress.unshot_fraction,
                "phases": dict(solver.timings),
                "gpu_memory_mib": solver.gpu_memory_bytes / 2**20}


def profiled_and_plain(scene, ctx, settings):
    """The bake synchronised after each phase (its phases), and its plain seconds."""
    profiled = fixed_shots_bake(scene, ctx, dataclasses.replace(settings, profile=True))
    plain = fixed_shots_bake(scene, ctx, dataclasses.replace(settings, profile=False))
    return {**profiled, "profiled_seconds": profiled["seconds"], "seconds": plain["seconds"]}


def table1(scenes, sizes, projections, element_scale):
    """Each scene at the paper's element counts of ``sizes`` times ``element_scale`` in
    texels, its fixed shots with each projection (hemicube faces 256)."""
    ctx = create_context()
    warm_up = Settings(texel_density=20.0, max_shots=2, threshold=0.0)
    fixed_shots_bake(load_scene("cornell_box"), ctx, warm_up)     # compile the shaders
    rows = []
    for name in scenes:
        scene, paper = load_scene(name), PAPER[name]
        for size in sizes:
            density = math.sqrt(element_scale * paper["elements"][size] / charted_area(scene))
            for projection in projections:
                settings = Settings(texel_density=density, max_shots=paper["shots"],
                                    threshold=0.0, hemicube_resolution=TABLE1_HEMICUBE,
                                    projection=projection)
                row = {"scene": name, "size": size, "projection": projection,
                       "density": density, "triangles": len(scene.triangles),
                       "paper_elements": paper["elements"][size],
                       "element_scale": element_scale,
                       "paper_seconds": paper["seconds"][size],
                       **profiled_and_plain(scene, ctx, settings)}
                rows.append(row)
                print(f"{name:12} {size:6} {projection:10} {row['texels']:>9,} texels "
                      f"{row['shots']:3} shots {row['seconds']:7.3f} s", flush=True)
    ctx.release()
    return {"hemicube_resolution": TABLE1_HEMICUBE, "rows": rows}


def table1_cycles(scenes, sizes, samples):
    """Luxel through the extension (whole bake: export, materials, atlas, shots, write-back;
    hemicube, the paper's shots, threshold 0) against Cycles baking the same lightmap texels
    (DIFFUSE, ``samples``, scene sync included), one after the other in one process."""
    bpy, luxel = common.start_blender()
    rows = []
    for name in scenes:
        paper = PAPER[name]
        area = charted_area(load_scene(name))
        for size in sizes:
            common.open_blend(bpy, name)
            settings = bpy.context.scene.luxel
            settings.texel_density = math.sqrt(paper["elements"][size] / area)
            settings.max_shots, settings.threshold = paper["shots"], 0.0
            settings.projection = "HEMICUBE"
            luxel.native.atlas.clear_cache()
            started = time.perf_counter()
            assert bpy.ops.luxel.bake() == {'FINISHED'}
            luxel_seconds = time.perf_counter() - started
            started = time.perf_counter()
            luxel.addon.reference.cycles_reference(bpy.context, samples=samples)
            cycles_seconds = time.perf_counter() - started
            row = {"scene": name, "size": size, "shots": paper["shots"],
                   "texels": settings.stats.texels, "luxel_seconds": luxel_seconds,
                   "cycles_samples": samples, "cycles_seconds": cycles_seconds,
                   "paper_cpu_seconds": paper["cpu_solver_seconds"],
                   "speed_up": cycles_seconds / luxel_seconds}
            rows.append(row)
            print(f"{name:12} {size:6} {row['texels']:>9,} texels: Luxel {luxel_seconds:.2f} s, "
                  f"Cycles {cycles_seconds:.2f} s", flush=True)
    return {"rows": rows}


# ----------------------------------------------------------------------------- Figure 1
def figure1(densities, shots, shooters):
    """The Cornell box at each density, ``shots`` shots of one texel each (shoot level 0,
    hemicube 256): phases synchronised, and the plain bake's shots per second."""
    scene = cornell_box()
    ctx = create_context()

    def settings(density, count, shooters_per_selection):
        return Settings(texel_density=density, max_shots=count, threshold=0.0, shoot_level=0,
                        hemicube_resolution=256, shooters_per_selection=shooters_per_selection)
    fixed_shots_bake(scene, ctx, settings(min(densities), 2, 1))   # compile the shaders
    rows = []
    for density in densities:
        for count in shooters:
            row = {"density": density, "shooters_per_selection": count,
                   "triangles": len(scene.triangles),
                   **profiled_and_plain(scene, ctx, settings(density, shots, count))}
            # Preprocess and postprocess end with a read-back, so their times hold without
            # the syncs; the rest of the plain bake is the solve.
            solve = (row["seconds"] - row["phases"]["preprocess"]
                     - row["phases"]["postprocess"])
            row["shots_per_second"] = row["shots"] / max(solve, 1e-9)
            rows.append(row)
            print(f"{row['texels']:>9,} texels, {count} shooters: {row['seconds']:.3f} s, "
                  f"{row['shots_per_second']:.0f} shots/s", flush=True)
    ctx.release()
    return {"scene": "cornell_box", "shots": shots, "shoot_level": 0,
            "hemicube_resolution": 256, "phases": PHASES, "rows": rows}


# ------------------------------------------------------------------------------ Table 2
def emitter_spheres(scene):
    """(centre, radius) around each emitting object: its bounding box's centre and diagonal.
    Within it a shooter's patch-to-point form factor fails (the Cornell box's ceiling is lit
    from 0.1 mm by the light's back face), so texels there are left out of the RMS."""
    spheres = []
    emitting = scene.emission.max(axis=1) > 0.0
    for index in np.unique(scene.object_index[emitting]):
        corners = scene.vertices[scene.triangles[emitting & (scene.object_index == index)]]
        low, high = corners.reshape(-1, 3).min(axis=0), corners.reshape(-1, 3).max(axis=0)
        spheres.append((0.5 * (low + high), float(np.linalg.norm(high - low))))
    return spheres


def far_from_emitters(scene, positions):
    """1 for texel positions outside every emitter's near field, 0 inside."""
    far = np.ones(positions.shape[:2], dtype=np.float32)
    for centre, radius in emitter_spheres(scene):
        far *= np.linalg.norm(positions - centre, axis=2) >= radius
    return far


def converged_bake(scene, settings, ctx):
    """Create, run to the threshold and read back (timed together); the pages' alpha 0 in
    the emitters' near field."""
    start = time.perf_counter()
    with Solver(scene, settings, ctx=ctx) as solver:
        progress = solver.run()
        pages = solver.result()
        seconds = time.perf_counter() - start
        for page, samples in zip(pages, solver.texel_samples()):
            page[..., 3] *= far_from_emitters(scene, samples["position"])
        return pages, {"seconds": seconds, "shots": progress.shots,
                       "texels": solver.texel_count,
                       "unshot_fraction": progress.unshot_fraction,
                       "converged": progress.converged, "phases": dict(solver.timings)}


def table2(scenes, size_scale, threshold, rows):
    """Each of the first ``rows`` of the paper's Table 2 baked with the three projections
    (hemicube faces 128, hemisphere maps 256 wide), sizes times ``size_scale``."""
    ctx = create_context()
    results = {}
    for name in scenes:
        scene = load_scene(name)

        def settings(projection, subdivision, level, size, max_shots=100_000):
            density = common.texel_density_for_size(scene, name, size)
            return Settings(texel_density=density, threshold=threshold, max_shots=max_shots,
                            shoot_level=common.shoot_level_for(scene, density),
                            hemicube_resolution=128, projection=projection,
                            subdivision=subdivision, subdivision_level=level)
        for projection in (TABLE2_REFERENCE, *TABLE2_COMPARED):    # compile, warm caches
            for subdivision in ("ADAPTIVE", "REGULAR"):
                converged_bake(scene, settings(projection, subdivision, 1, 8.0, max_shots=2),
                               ctx)
        scene_rows = []
        for subdivision, level, size in TABLE2_ROWS[:rows]:
            scaled = size * size_scale
            row = {"subdivision": subdivision, "level": level, "size": size,
                   "scaled_size": scaled,
                   "texel_density": common.texel_density_for_size(scene, name, scaled),
                   "runs": {}}
            reference = None
            for projection in (TABLE2_REFERENCE, *TABLE2_COMPARED):
                pages, run = converged_bake(scene, settings(projection, subdivision, level,
                                                            scaled), ctx)
                if reference is None:
                    reference = pages
                else:
                    error = lightmap_error(pages, reference)
                    run["rms"], run["relative_rms"] = error.rms, error.relative_rms
                row["runs"][projection] = run
                print(f"{name:>11} {subdivision:>8} {level} {scaled:>6.4g} {projection:>10} "
                      f"{run['texels']:>8} texels {run['shots']:>6} shots "
                      f"{run['seconds']:>7.2f} s", flush=True)
            scene_rows.append(row)
        results[name] = {"reference_quad_side": common.reference_side(scene, name),
                         "triangles": len(scene.triangles), "rows": scene_rows}
    ctx.release()
    return {"threshold": threshold, "size_scale": size_scale, "hemicube_resolution": 128,
            "scenes": results}


# ----------------------------------------------------------------------------- Figure 6
def figure6(size, projections, threshold, levels, level_density):
    """The paper's Figure 6: the columns at ``size`` without subdivision, the unshot fraction
    after every shot to ``threshold``, per projection. Beside it, the same axes per shooting
    level: the Cornell box at ``level_density`` texels/m, hemicube 256, to 1 % unshot."""
    ctx = create_context()
    scene = load_scene("columns")
    density = common.texel_density_for_size(scene, "columns", size)
    shoot_level = common.shoot_level_for(scene, density)

    def settings(projection, max_shots):
        return Settings(texel_density=density, shoot_level=shoot_level, threshold=threshold,
                        max_shots=max_shots, hemicube_resolution=128, projection=projection,
                        subdivision="NONE")
    for projection in projections:                   # compile the shaders before timing
        with Solver(scene, settings(projection, 2), ctx=ctx) as warm_up:
            warm_up.run()
    runs = []
    for projection in projections:
        start = time.perf_counter()
        with Solver(scene, settings(projection, 100_000), ctx=ctx) as solver:
            # unshot[k]: the unshot fraction after k shots (a step measures it before its
            # shot, so a callback sees the count before that shot).
            unshot = []
            solver.run(lambda progress: unshot.append(float(f"{progress.unshot_fraction:.5g}")))
            progress = solver.progress
            unshot.append(float(f"{progress.unshot_fraction:.5g}"))
            runs.append({"projection": projection, "texels": solver.texel_count,
                         "shots": progress.shots, "seconds": time.perf_counter() - start,
                         "unshot_fraction": progress.unshot_fraction,
                         "converged": progress.converged, "unshot": unshot})
        print(f"{projection:>10}: {runs[-1]['shots']} shots, {runs[-1]['seconds']:.1f} s",
              flush=True)
    by_level = [unshot_by_level(ctx, level, level_density) for level in levels]
    ctx.release()
    return {"scene": "columns", "size": size, "texel_density": density,
            "shoot_level": shoot_level, "threshold": threshold, "hemicube_resolution": 128,
            "runs": runs, "levels": {"scene": "cornell_box", "density": level_density,
                                     "threshold": 0.01, "runs": by_level}}


def unshot_by_level(ctx, level, density):
    """The Cornell box shot from blocks of 2^level texels to 1 % unshot: (shots, seconds,
    unshot) every 25 shots."""
    curve = []
    start = time.perf_counter()

    def record(progress):
        if progress.shots % 25 == 0:
            curve.append((progress.shots, time.perf_counter() - start,
                          progress.unshot_fraction))
    with Solver(cornell_box(), Settings(texel_density=density, shoot_level=level,
                                        threshold=0.01, max_shots=60_000,
                                        hemicube_resolution=256), ctx=ctx) as solver:
        progress = solver.run(record)
        seconds = time.perf_counter() - start
        curve.append((progress.shots, seconds, progress.unshot_fraction))
        print(f"level {level}: {solver.texel_count} texels, {progress.shots} shots, "
              f"{seconds:.1f} s", flush=True)
        return {"level": level, "texels": solver.texel_count, "shots": progress.shots,
                "seconds": seconds, "unshot_fraction": progress.unshot_fraction,
                "curve": curve}


SCENES = list(PAPER)
STUDIES = (
    Study("table1", table1, {
        "quick": dict(scenes=["cornell_box"], sizes=["low"], projections=["HEMICUBE"],
                      element_scale=0.25),
        "cpu": dict(scenes=SCENES, sizes=["low"], projections=list(PROJECTIONS),
                    element_scale=0.25),
        "gpu": dict(scenes=SCENES, sizes=["low", "medium", "high"],
                    projections=list(PROJECTIONS), element_scale=1.0)}),
    Study("table1-cycles", table1_cycles, {
        "quick": dict(scenes=["cornell_box"], sizes=["low"], samples=4),
        "cpu": dict(scenes=SCENES, sizes=["low"], samples=16),
        "gpu": dict(scenes=SCENES, sizes=["low"], samples=16)}, blender=True),
    Study("figure1", figure1, {
        "quick": dict(densities=[70.0], shots=8, shooters=[8]),
        "cpu": dict(densities=[70.0, 220.0], shots=32, shooters=[8]),
        "gpu": dict(densities=[70.0, 220.0, 700.0, 1000.0, 1400.0], shots=512,
                    shooters=[1, 8])}),
    Study("table2", table2, {
        "quick": dict(scenes=["cornell_box"], size_scale=0.0625, threshold=0.1, rows=2),
        "cpu": dict(scenes=["columns", "cornell_box"], size_scale=0.125, threshold=0.05,
                    rows=len(TABLE2_ROWS)),
        "gpu": dict(scenes=["columns", "cornell_box"], size_scale=1.0, threshold=0.01,
                    rows=len(TABLE2_ROWS))}),
    Study("figure6", figure6, {
        "quick": dict(size=8.0, projections=["HEMICUBE"], threshold=0.1, levels=[3],
                      level_density=40.0),
        "cpu": dict(size=32.0, projections=["HEMICUBE", "HEMISPHERE"], threshold=0.01,
                    levels=[2, 3], level_density=70.0),
        "gpu": dict(size=256.0, projections=list(PROJECTIONS), threshold=0.01,
                    levels=[1, 2, 3], level_density=100.0)}),
)

if __name__ == "__main__":
    common.main(__doc__.split("\n\n")[0], STUDIES)
