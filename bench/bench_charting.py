"""Charting big scenes: xatlas's time and peak memory, the atlas's texels and page sizes, and
the rest of the preprocess, on the realistic interior (sample_blends/interior.blend) with its
furniture subdivided further: every furniture mesh ``level`` more Subdivision Surface levels
(the sofa keeps its one level more), the walls, floor and ceiling as they are.

    python bench/bench_charting.py export 3 4 5 6          # needs the bpy module, once
    python bench/bench_charting.py run 4 5 [--code before=DIR after=DIR] [--repeats N]
        [--timeout S] [--preprocess] [--json PATH]

`export` writes bench/scenes/generated/interior-subdiv<level>.npz (not committed: up to
35 MB). `run` measures each (level, code) pair in a fresh Python process, the codes in
turn, ``--repeats`` times: ``--code`` names checkouts of this repository (label=directory)
whose native/ is timed (default: this one), so that two versions are compared in one job.
A run past ``--timeout`` seconds is recorded as such.
"""
import argparse
import json
import os
from pathlib import Path
import resource
import statistics
import subprocess
import sys
import time

ROOT = Path(__file__).resolve().parent.parent
GENERATED = ROOT / "bench" / "scenes" / "generated"
ROOM = {"walls", "floor", "ceiling", "window_cut"}


def scene_path(level):
    return GENERATED / f"interior-subdiv{level}.npz"


def export(levels):
    sys.path.insert(0, str(ROOT / "tools"))
    import blender  # noqa: E402  (tools/blender.py: bpy with Luxel enabled)
    bpy = blender.start_blender()
    addon = blender.luxel().addon
    GENERATED.mkdir(parents=True, exist_ok=True)
    for level in levels:
        bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / "interior.blend"))
        subdivide_furniture(bpy, level)
        result = addon.export.export_scene(bpy.context)
        result.scene.save(scene_path(level))
        print(f"level {level}: {len(result.scene.triangles)} triangles, "
              f"{len(result.scene.object_names)} objects -> {scene_path(level)}", flush=True)
    os._exit(0)     # bpy's teardown can crash on some versions


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


def measure(level, density, preprocess):
    """One measurement in this process (native/ from the first sys.path entry): prints JSON."""
    from native import Scene
    from native.atlas import build_atlas, clear_cache, tight_packing
    from native.settings import Settings
    settings = Settings(texel_density=density)
    scene = Scene.load(scene_path(level))
    solved = scene.with_back_faces()       # what the solver charts
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    clear_cache()
    started, cpu_started = time.perf_counter(), time.process_time()
    atlas = build_atlas(solved, density, settings.max_atlas_size, settings.padding,
                        align=1 << settings.shoot_level)
    seconds, cpu_seconds = time.perf_counter() - started, time.process_time() - cpu_started
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    packed, _ = tight_packing(atlas, 1 << settings.shoot_level)
    row = {"level": level, "triangles": int(len(scene.triangles)),
           "charted_triangles": int(len(atlas.triangles)), "objects": len(scene.object_names),
           "density": density, "atlas_seconds": seconds, "atlas_cpu_seconds": cpu_seconds,
           "peak_rss_mb": peak / 1024, "atlas_rss_growth_mb": (peak - before) / 1024,
           "pages": atlas.page_count, "page_size": [atlas.width, atlas.height],
           "texels": atlas.page_count * atlas.width * atlas.height,
           "gpu_page_size": [packed.width, packed.height],
           "gpu_texels": packed.page_count * packed.width * packed.height,
           "charts": int(atlas.chart.max()) + 1, "unpacked": int(len(atlas.unpacked))}
    if preprocess:
        from native.solver import Solver
        solver = Solver(scene, settings)      # its atlas comes from the cache: not re-timed
        row["preprocess_seconds"] = solver.timings["preprocess"]
        row["preprocess_atlas_seconds"] = solver.atlas_seconds
        row["peak_rss_with_preprocess_mb"] = (
            resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
        solver.release()
    print(json.dumps(row))


def run(args):
    codes = dict(code.split("=", 1) for code in (args.code or [f"this={ROOT}"]))
    rows = []
    for level in args.levels:
        for repeat in range(args.repeats):
            for label, code in codes.items():
                command = [sys.executable, str(Path(__file__).resolve()), "measure",
                           str(level), "--density", str(args.density)]
                if args.preprocess:
                    command.append("--preprocess")
                environment = dict(os.environ, PYTHONPATH=str(Path(code).resolve()))
                try:
                    output = subprocess.run(command, env=environment, check=True,
                                            capture_output=True, text=True, cwd=code,
                                            timeout=args.timeout).stdout
                    row = json.loads(output.strip().splitlines()[-1])
                except subprocess.TimeoutExpired:
                    row = {"level": level, "timed_out_after_seconds": args.timeout}
                row.update(code=label, repeat=repeat)
                rows.append(row)
                print(json.dumps(row), flush=True)
    summary = []
    for level in args.levels:
        for code in codes:
            mine = [r for r in rows if r["level"] == level and r["code"] == code
                    and "timed_out_after_seconds" not in r]
            if not mine:
                summary.append({"level": level, "code": code,
                                "timed_out_after_seconds": args.timeout})
                print(f"level {level} {code}: over {args.timeout} s")
                continue
            entry = {key: mine[0][key] for key in ("level", "code", "triangles", "pages",
                                                   "page_size", "texels", "gpu_page_size",
                                                   "gpu_texels", "charts", "unpacked")}
            for key in ("atlas_seconds", "atlas_cpu_seconds", "peak_rss_mb", "atlas_rss_growth_mb",
                        "preprocess_seconds", "preprocess_atlas_seconds"):
                if key in mine[0]:
                    entry[f"median_{key}"] = statistics.median(r[key] for r in mine)
            summary.append(entry)
            entry["runs"] = len(mine)
            print(f"level {level} ({entry['triangles']} triangles) {code}: atlas "
                  f"{entry['median_atlas_seconds']:.2f} s (CPU "
                  f"{entry['median_atlas_cpu_seconds']:.2f} s), peak {entry['median_peak_rss_mb']:.0f} MB,"
                  f" {entry['pages']} x {entry['page_size']} = {entry['texels']} texels "
                  f"(GPU {entry['gpu_page_size']}), {entry['charts']} charts")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"device": "Mesa llvmpipe, 2-core CPU, beside other jobs",
                                         "density": args.density, "repeats": args.repeats,
                                         "summary": summary, "runs": rows}, indent=1))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    exporting = commands.add_parser("export", help="write the scenes (needs bpy)")
    exporting.add_argument("levels", type=int, nargs="+")
    running = commands.add_parser("run", help="time the codes on the scenes")
    running.add_argument("levels", type=int, nargs="+")
    running.add_argument("--code", nargs="+", metavar="LABEL=DIR",
                         help="checkouts to time (default: this one)")
    running.add_argument("--timeout", type=float, default=1800.0)
    running.add_argument("--repeats", type=int, default=1)
    running.add_argument("--density", type=float, default=10.0)
    running.add_argument("--preprocess", action="store_true",
                         help="also time the solver's preprocess (needs OpenGL)")
    running.add_argument("--json", type=Path)
    one = commands.add_parser("measure", help="one measurement, in this process")
    one.add_argument("level", type=int)
    one.add_argument("--density", type=float, default=10.0)
    one.add_argument("--preprocess", action="store_true")
    args = parser.parse_args()
    if args.command == "export":
        export(args.levels)
    elif args.command == "run":
        run(args)
    else:
        measure(args.level, args.density, args.preprocess)


if __name__ == "__main__":
    main()
