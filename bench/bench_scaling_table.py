"""One row of the scaling table: a scene at one texel density (and, for the realistic interior,
its furniture subdivided further), baked once by Luxel through the extension with each phase
timed, then against Cycles: Luxel's and Cycles' times to 2 % and 1 % relative RMS (needs the
bpy module; one row per process, each run capped):

    python bench/bench_scaling_table.py --scene cornell_box --density 60 \
        --reference-samples 1024 --json bench/results/scaling-llvmpipe.json
    python bench/bench_scaling_table.py --scene interior --level 5 --reference-samples 64 \
        --json bench/results/scaling-llvmpipe.json

The row is added to ``--json`` (a row of the same scene, level and density is replaced).
Luxel: `compare.SnapshotBake`'s snapshots at every half doubling of the shots, its seconds
the bake's own (export, materials, charting, preprocess, shots; the snapshots not counted),
Settings.profile on (the GPU waited for after each phase, so the phases add up; with
``--unsynchronised`` off, as a user's bake runs: the curve is then the user's, the phases
overlap); stopped at
the threshold, the shot limit or after ``--luxel-seconds``. The reference is two Cycles bakes
of ``--reference-samples`` with other seeds, averaged, its noise subtracted from every squared
error (bench_equal_error.py); every shown copy counts (instances through stand-ins,
addon/reference.py's copies). Cycles' curve bakes 1, 4, 16, ... samples, each timed, until it
reaches the lowest target, or the next bake (about 4x the last) would end past
``--cycles-seconds`` of curve. ``--level`` (interior only): bench_charting.py's furniture
subdivision. ``--no-cycles``: Luxel's phases and memory only (a scene too slow to compare)."""
import argparse
import dataclasses
import inspect
import json
import math
import os
from pathlib import Path
import resource
import time

from bench_charting import subdivide_furniture
from bench_equal_error import (TARGETS, _average, _debiased, _noise_and_magnitude, _time_to,
                               runner)

UNSHOT_MILESTONE = 0.01     # the "reaches 1 % unshot"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", choices=["cornell_box", "interior"], required=True)
    parser.add_argument("--density", type=float, default=None,
                        help="texels per metre (default: the extension's)")
    parser.add_argument("--level", type=int, default=0,
                        help="furniture subdivision levels added (interior)")
    parser.add_argument("--threshold", type=float, default=0.002)
    parser.add_argument("--luxel-seconds", type=float, default=600.0)
    parser.add_argument("--max-shots", type=int, default=0, help="0: automatic")
    parser.add_argument("--reference-samples", type=int, default=256, help="per reference bake")
    parser.add_argument("--cycles-seconds", type=float, default=600.0)
    parser.add_argument("--no-cycles", action="store_true")
    parser.add_argument("--unsynchronised", action="store_true",
                        help="Settings.profile off: the GPU not waited for after each phase")
    parser.add_argument("--json", type=Path, required=True)
    args = parser.parse_args()

    bpy = runner.start_blender()
    luxel_package = runner.luxel()
    addon = luxel_package.addon
    bpy.ops.wm.open_mainfile(filepath=str(runner.ROOT / "sample_blends" / f"{args.scene}.blend"))
    if args.level:
        subdivide_furniture(bpy, args.level)
    context = bpy.context
    settings = context.scene.luxel
    if args.density is not None:
        settings.texel_density = args.density
    settings.threshold, settings.max_shots = args.threshold, args.max_shots

    luxel, row = luxel_bake(context, luxel_package, args.luxel_seconds,
                            synchronised=not args.unsynchronised)
    row.update(scene=args.scene, level=args.level, density=settings.texel_density,
               threshold=args.threshold, luxel_seconds_cap=args.luxel_seconds,
               synchronised=not args.unsynchronised)
    print(json.dumps({key: value for key, value in row.items() if key != "phases"}), flush=True)
    save_row(args.json, row, luxel.device)     # kept should the comparison fail
    if not args.no_cycles:
        row.update(against_cycles(context, addon, luxel, args))
        save_row(args.json, row, luxel.device)
    os._exit(0)     # bpy's teardown after a bake can crash on some versions


def luxel_bake(context, luxel_package, seconds_limit, *, synchronised):
    """The bake with snapshots, timed per phase (``synchronised``: Settings.profile),
    stopped after ``seconds_limit``; returns the SnapshotBake and the row's Luxel columns."""
    addon, snapshots = luxel_package.addon, luxel_package.native.evaluation.snapshots
    charting = timed_charting(luxel_package.native.solver)
    job = addon.bake.BakeJob(context)
    job.settings = dataclasses.replace(job.settings, profile=synchronised)
    stages = {}
    job.stages = tuple(timed_stage(stage, stages) for stage in job.stages)
    try:
        job.set_up()
        bake = addon.compare.SnapshotBake(job)
        bake.snapshots = snapshots.Snapshots(job.started, per_doubling=2)
        solver = job.solver
        milestone = None
        capped = False
        while solver.step():
            bake.snapshots.after_step(solver)
            seconds = bake.snapshots.elapsed()
            if milestone is None and solver.progress.unshot_fraction <= UNSHOT_MILESTONE:
                milestone = {"shots": solver.shots, "seconds": seconds}
            if seconds > seconds_limit:
                capped = True
                break
        bake.snapshots.take(solver)
        progress = solver.progress
        timings = dict(solver.timings)
        export_stage, materials_stage, solver_stage = (stages[stage.name]
                                                       for stage in job.stages)
        row = {
            "triangles": len(job.export.scene.triangles), "texels": solver.texel_count,
            "shots": progress.shots,
            "unshot_fraction": progress.unshot_fraction,
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
            "gpu_page_size": list(solver.gpu_page_size), "pages": solver.atlas.page_count,
            "gpu_bytes_per_texel": solver.gpu_memory_bytes / solver.texel_count,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        }
    except BaseException:
        job.release()
        raise
    job.finish()
    return bake, row


def timed_charting(solver_module):
    """A list that gets the seconds of each call to build_atlas, through which the add-on's
    and the solver's atlases are made."""
    calls = []
    build_atlas = solver_module.build_atlas

    def timed(*args, **kwargs):
        started = time.perf_counter()
        try:
            return build_atlas(*args, **kwargs)
        finally:
            calls.append(time.perf_counter() - started)
    solver_module.build_atlas = timed
    return calls


def timed_stage(stage, seconds):
    """``stage`` of a BakeJob, its pieces' seconds put into seconds[stage.name]."""
    def run():
        started = time.perf_counter()
        pieces = stage.run()
        if inspect.isgenerator(pieces):
            yield from pieces
        seconds[stage.name] = time.perf_counter() - started
    return dataclasses.replace(stage, run=run)


def against_cycles(context, addon, luxel, args):
    """The reference, Luxel's curve against it, Cycles' curve, and the times to each target."""
    reference_module = addon.reference
    lightmap_error = addon.compare.lightmap_error
    scene = context.scene
    started = time.perf_counter()
    first = reference_module.cycles_reference(context, samples=args.reference_samples,
                                              seed=11, copies=True)
    second = reference_module.cycles_reference(context, samples=args.reference_samples,
                                               seed=12, copies=True)
    reference_seconds = time.perf_counter() - started
    names = sorted(first)
    reference = {name: _average(first[name], second[name]) for name in names}
    noise, magnitude = _noise_and_magnitude(names, first, second)
    page_of = {name: int(reference_module.luxel_page(scene, name)[addon.writeback.PAGE_KEY])
               for name in names}
    snapshots = luxel.snapshots
    luxel_curve = []
    for index, (shots, seconds) in enumerate(zip(snapshots.shots, snapshots.seconds)):
        error = lightmap_error([snapshots.page(index, page_of[name]) for name in names],
                               [reference[name] for name in names])
        luxel_curve.append({"shots": shots, "seconds": seconds, "rms": error.rms,
                            "rel_rms": error.relative_rms})
    _debiased(luxel_curve, noise, magnitude)
    last = len(snapshots.shots) - 1
    # Per object, the reference's noise not taken out; None where no texel is shared.
    luxel_objects = {name: error if math.isfinite(error) else None
                     for name, error in addon.compare._object_rel_rms(
                         names, [snapshots.page(last, page_of[name]) for name in names],
                         reference).items()}
    print(f"reference 2 x {args.reference_samples} samples: {reference_seconds:.1f} s, "
          f"noise {100 * noise ** 0.5 / magnitude:.2f} %; Luxel at the end "
          f"{100 * luxel_curve[-1]['rel_rms_debiased']:.2f} %", flush=True)
    cycles = cycles_curve(context, reference_module, lightmap_error, names, reference,
                          noise, magnitude, args.cycles_seconds)
    times = {}
    for target in TARGETS:
        luxel_time, cycles_time = _time_to(luxel_curve, target), _time_to(cycles, target)
        times[f"{100 * target:g}%"] = {
            "luxel_seconds": luxel_time, "cycles_seconds": cycles_time,
            "cycles_over_luxel": cycles_time / luxel_time if luxel_time and cycles_time
            else None}
        print(f"{100 * target:g} %: Luxel {luxel_time}, Cycles {cycles_time}", flush=True)
    return {"reference_samples": 2 * args.reference_samples,
            "reference_seconds": reference_seconds,
            "reference_noise_rel": noise ** 0.5 / magnitude, "objects": names,
            "times_to": times, "luxel_curve": luxel_curve,
            "luxel_objects_at_end": luxel_objects, "cycles_curve": cycles,
            "cycles_seconds_cap": args.cycles_seconds}


def cycles_curve(context, reference_module, lightmap_error, names, reference, noise,
                 magnitude, seconds_limit):
    """Cycles bakes at 1, 4, 16, ... samples, each timed, with another seed than the
    reference's, until the lowest target is reached or the next bake would pass the cap."""
    points, spent, samples = [], 0.0, 1
    while True:
        started = time.perf_counter()
        bakes = reference_module.cycles_reference(context, samples=samples, seed=1,
                                                  copies=True)
        seconds = time.perf_counter() - started
        spent += seconds
        error = lightmap_error([bakes[name] for name in names],
                               [reference[name] for name in names])
        point = {"samples": samples, "seconds": seconds, "rms": error.rms,
                 "rel_rms": error.relative_rms}
        points.append(_debiased([point], noise, magnitude)[0])
        print(f"Cycles {samples} samples: {seconds:.1f} s, "
              f"{100 * point['rel_rms_debiased']:.2f} %", flush=True)
        if point["rel_rms_debiased"] <= min(TARGETS) or spent + 4 * seconds > seconds_limit:
            return points
        samples *= 4


def save_row(path, row, device):
    results = json.loads(path.read_text()) if path.exists() else {"rows": []}
    results["device"] = {"luxel": device, "cycles": "CPU, the same 2 cores"}
    key = (row["scene"], row["level"], row["density"])
    results["rows"] = [r for r in results["rows"]
                       if (r["scene"], r["level"], r["density"]) != key] + [row]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(results, indent=1, allow_nan=False))


if __name__ == "__main__":
    main()
