"""Table 1's CPU column on our scenes: each sample scene baked on this machine by Luxel through
the extension (hemicube, the paper's fixed shots, threshold 0) and by Cycles into the same
lightmap texels (DIFFUSE, `--samples`), in the same run. Needs the bpy module:

    python bench/bench_table1_cycles.py --sizes low --samples 16 \
        --json bench/results/table1-cycles-<device>.json

Luxel's time is the whole bake (export, atlas, solve, write-back); Cycles' the bake call
(scene sync included). How far each is from the converged answer is bench_equal_error.py's."""
import argparse
import json
import math
from pathlib import Path
import sys
import time

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tools"))
import blender as runner  # noqa: E402  (tools/blender.py)
from bench_table1 import PAPER, charted_area  # noqa: E402
from common import load_scene  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", nargs="+", default=list(PAPER))
    parser.add_argument("--sizes", nargs="+", default=["low"])
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    bpy = runner.start_blender()
    luxel = runner.luxel()
    atlas = luxel.native.atlas
    reference = luxel.addon.reference
    rows = []
    for name in args.scenes:
        shots, elements = PAPER[name]
        area = charted_area(load_scene(name))
        for size in args.sizes:
            bpy.ops.wm.open_mainfile(filepath=str(runner.ROOT / "sample_blends" /
                                                  f"{name}.blend"))
            settings = bpy.context.scene.luxel
            settings.texel_density = math.sqrt(elements[size] / area)
            settings.max_shots, settings.threshold = shots, 0.0
            settings.projection = "HEMICUBE"
            atlas.clear_cache()
            started = time.perf_counter()
            assert bpy.ops.luxel.bake() == {'FINISHED'}
            luxel_seconds = time.perf_counter() - started
            started = time.perf_counter()
            reference.cycles_reference(bpy.context, samples=args.samples)
            cycles_seconds = time.perf_counter() - started
            row = {"scene": name, "size": size, "shots": shots, "texels": settings.stats.texels,
                   "luxel_seconds": luxel_seconds, "cycles_samples": args.samples,
                   "cycles_seconds": cycles_seconds,
                   "speed_up": cycles_seconds / luxel_seconds}
            rows.append(row)
            print(f"{name:12} {size:6} {row['texels']:>9,} texels: Luxel {shots} shots "
                  f"{luxel_seconds:.2f} s, Cycles {args.samples} samples {cycles_seconds:.2f} s "
                  f"(x{row['speed_up']:.2f})", flush=True)
    if args.json:
        args.json.write_text(json.dumps({"rows": rows}, indent=1))


if __name__ == "__main__":
    main()
