"""Per-step timing of the solver (the paper's Figure 1 breakdown) on the Cornell box at three
texel counts, with a fixed number of shots like the paper's Table 1.

    python bench/bench_core.py --json bench/results/core-llvmpipe.json

Each size is baked twice in the same run: once with a GPU sync after every phase (the
breakdown) and once without (the throughput a user gets). Times are seconds."""
import argparse
import time
from pathlib import Path

from common import device_name, save_results  # also puts the repository on sys.path
from native import Settings, Solver, create_context
from native.atlas import clear_cache
from native.gpu import using
from native.samples import cornell_box
from native.solver import PHASES


def bake(scene, ctx, density, shots, shoot_level, resolution, profile, shooters):
    clear_cache()
    start = time.perf_counter()
    solver = Solver(scene, Settings(texel_density=density, max_shots=shots, threshold=0.0,
                                    shoot_level=shoot_level, hemicube_resolution=resolution,
                                    shooters_per_selection=shooters, profile=profile), ctx=ctx)
    try:
        solver.run()
        solver.result()
        with using(ctx):
            ctx.finish()
        total = time.perf_counter() - start
        return {
            "density": density, "texels": solver.texel_count,
            "atlas": list(solver.page_size), "pages": solver.atlas.page_count,
            "triangles": len(scene.triangles), "gpu_memory_mib": solver.gpu_memory_bytes / 2**20,
            "shots": solver.shots, "unshot_fraction": solver.progress.unshot_fraction,
            "shooters_per_selection": shooters,
            "seconds": total, "phases": dict(solver.timings),
        }
    finally:
        solver.release()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--densities", type=float, nargs="+", default=[70.0, 220.0, 700.0],
                        help="texels per metre (about 10 k, 100 k and 1 M texels)")
    parser.add_argument("--shots", type=int, default=32)
    parser.add_argument("--shoot-level", type=int, default=0, help="0: one texel per shot")
    parser.add_argument("--hemicube", type=int, default=256)
    parser.add_argument("--shooters", type=int, nargs="+",
                        default=[Settings().shooters_per_selection],
                        help="shots per selection read-back (1: one by one, as the paper)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    scene = cornell_box()
    ctx = create_context()
    device = device_name(ctx)
    print(f"device: {device}")
    header = ("texels", "shooters", "pages") + PHASES + ("profiled", "total", "shots/s")
    print(" ".join(f"{h:>11}" for h in header))
    rows = []
    # Compile the shaders once before timing anything.
    bake(scene, ctx, min(args.densities), 2, args.shoot_level, args.hemicube, False, 1)
    for density, shooters in ((d, k) for d in args.densities for k in args.shooters):
        profiled = bake(scene, ctx, density, args.shots, args.shoot_level, args.hemicube, True,
                        shooters)
        plain = bake(scene, ctx, density, args.shots, args.shoot_level, args.hemicube, False,
                     shooters)
        profiled["unprofiled_seconds"] = plain["seconds"]
        rows.append(profiled)
        # Preprocess and postprocess end with a read-back, so their times are real even
        # without profiling; the rest is the solve.
        solve = plain["seconds"] - plain["phases"]["preprocess"] - plain["phases"]["postprocess"]
        profiled["solve_seconds"] = solve
        values = [profiled["texels"], shooters, profiled["pages"]] \
            + [profiled["phases"][p] for p in PHASES] \
            + [profiled["seconds"], plain["seconds"], plain["shots"] / max(solve, 1e-9)]
        print(" ".join(f"{v:>11.4g}" if isinstance(v, float) else f"{v:>11}" for v in values))
    ctx.release()
    save_results(args.json, {"device": device, "scene": "cornell_box",
                             "shots": args.shots, "shoot_level": args.shoot_level,
                             "hemicube_resolution": args.hemicube, "rows": rows})


if __name__ == "__main__":
    main()
