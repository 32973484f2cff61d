"""The paper's Table 1 and Figure 1 on our four scenes: a fixed number of shots (32, 24, 96,
32 as the paper) at three texel counts near the paper's element counts, with every
projection; total time, the per-step breakdown, texels and triangles.

    python bench/bench_table1.py --json bench/results/table1-<device>.json [--sizes low]

Scenes come from bench/scenes/*.npz (bench/export_scenes.py), so no Blender is needed. Each
bake runs twice: with a GPU sync after every phase (the breakdown) and without (the time a
user gets, "seconds")."""
import argparse
import math
import time
from pathlib import Path

from common import device_name, load_scene, save_results  # also puts the repo on sys.path
from native import PROJECTIONS, Settings, Solver, create_context
from native.atlas import charted_triangles, clear_cache
from native.gpu import using

# The paper's Table 1: shots, and its GPU element counts per size.
PAPER = {
    "cornell_box": (32, {"low": 11_802, "medium": 94_750, "high": 1_115_126}),
    "temple": (24, {"low": 126_078, "medium": 516_312, "high": 2_074_242}),
    "office": (96, {"low": 254_572, "medium": 854_341, "high": 1_843_771}),
    "living": (32, {"low": 472_317, "medium": 866_330, "high": 1_612_067}),
}
HEMICUBE = 256


def charted_area(scene):
    """Square metres that get texels: receiving and emitting triangles."""
    return float(scene.triangle_area[charted_triangles(scene)].sum())


def bake(scene, ctx, density, shots, projection, profile):
    clear_cache()
    start = time.perf_counter()
    solver = Solver(scene, Settings(texel_density=density, max_shots=shots, threshold=0.0,
                                    hemicube_resolution=HEMICUBE, projection=projection,
                                    profile=profile), ctx=ctx)
    try:
        solver.run()
        solver.result()
        with using(ctx):
            ctx.finish()
        return {"seconds": time.perf_counter() - start, "texels": solver.texel_count,
                "atlas_seconds": solver.atlas_seconds,
                "shots": solver.shots, "phases": dict(solver.timings),
                "gpu_memory_mib": solver.gpu_memory_bytes / 2**20,
                "pages": solver.atlas.page_count}
    finally:
        solver.release()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", nargs="+", default=list(PAPER))
    parser.add_argument("--sizes", nargs="+", default=["low", "medium", "high"])
    parser.add_argument("--projections", nargs="+", default=list(PROJECTIONS))
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    ctx = create_context()
    device = device_name(ctx)
    print(f"device: {device}")
    rows = []
    bake(load_scene("cornell_box"), ctx, 20.0, 2, "HEMICUBE", False)  # compile the shaders
    for name in args.scenes:
        scene = load_scene(name)
        shots, elements = PAPER[name]
        for size in args.sizes:
            density = math.sqrt(elements[size] / charted_area(scene))
            for projection in args.projections:
                profiled = bake(scene, ctx, density, shots, projection, True)
                plain = bake(scene, ctx, density, shots, projection, False)
                row = {"scene": name, "size": size, "projection": projection,
                       "density": density, "triangles": len(scene.triangles),
                       "paper_elements": elements[size], **profiled,
                       "profiled_seconds": profiled["seconds"], "seconds": plain["seconds"]}
                rows.append(row)
                phases = " ".join(f"{p} {1000 * v:.0f}" for p, v in row["phases"].items())
                phases += f", of which atlas {1000 * row['atlas_seconds']:.0f}"
                print(f"{name:12} {size:6} {projection:10} {row['texels']:>9,} texels "
                      f"{shots:3} shots {row['seconds']:7.3f} s ({phases} ms, synced)",
                      flush=True)
    ctx.release()
    save_results(args.json, {"device": device, "hemicube_resolution": HEMICUBE,
                             "rows": rows})


if __name__ == "__main__":
    main()
