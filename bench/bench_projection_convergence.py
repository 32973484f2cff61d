"""The paper's Figure 6: unshot energy against shots with the hemicube and the hemisphere
projection, without subdivision, recorded at every shot until a convergence threshold.

    python bench/bench_projection_convergence.py \\
        --json bench/results/projection-convergence-<device>.json
    python bench/bench_projection_convergence.py --size 32 \\
        --json bench/results/projection-convergence-llvmpipe.json   # llvmpipe: 1.5 minutes

The default scene is the columns: thin occluders seen near the hemisphere's rim, where its
visibility errors are largest (the paper saw them slow convergence: 3514 hemicube shots
against 4106). Size and shooting level are as in bench_projections.py: size texels across the
reference quad, blocks as wide as the narrowest object."""
import argparse
import time
from pathlib import Path

from common import (REFERENCE_QUAD, device_name, load_scene, save_results,
                    shoot_level_for, texel_density_for_size)  # also puts the repo on sys.path
from native import PROJECTIONS, Settings, Solver, create_context


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scene", choices=sorted(REFERENCE_QUAD), default="columns")
    parser.add_argument("--projections", nargs="+", choices=PROJECTIONS,
                        default=["HEMICUBE", "HEMISPHERE"])
    parser.add_argument("--size", type=float, default=256.0,
                        help="texels across the scene's reference quad")
    parser.add_argument("--shoot-level", type=int, help="mip level shot from (default: "
                        "blocks as wide as the narrowest object)")
    parser.add_argument("--threshold", type=float, default=0.01)
    parser.add_argument("--hemicube", type=int, default=128,
                        help="hemicube face resolution; the hemisphere maps are twice as wide")
    parser.add_argument("--max-shots", type=int, default=100000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    scene = load_scene(args.scene)
    ctx = create_context()
    device = device_name(ctx)
    print(f"device: {device}")
    print(f"{'projection':>10} {'texels':>8} {'shots':>7} {'seconds':>8} {'unshot':>8}")
    density = texel_density_for_size(scene, args.scene, args.size)
    shoot_level = (shoot_level_for(scene, density) if args.shoot_level is None
                   else args.shoot_level)

    def settings(projection, max_shots):
        return Settings(texel_density=density, shoot_level=shoot_level, threshold=args.threshold,
                        max_shots=max_shots, hemicube_resolution=args.hemicube,
                        projection=projection, subdivision="NONE")

    # Run every projection once before anything is timed (shader compilation, driver caches).
    for projection in args.projections:
        with Solver(scene, settings(projection, 2), ctx=ctx) as warm_up:
            warm_up.run()
    runs = []
    for projection in args.projections:
        start = time.perf_counter()
        solver = Solver(scene, settings(projection, args.max_shots), ctx=ctx)
        # unshot[k]: the unshot fraction after k shots. A step measures it before its shot,
        # so the value a callback sees belongs to the count before that shot.
        unshot = []
        solver.run(lambda progress: unshot.append(float(f"{progress.unshot_fraction:.5g}")))
        progress = solver.progress
        seconds = time.perf_counter() - start
        unshot.append(float(f"{progress.unshot_fraction:.5g}"))
        runs.append({"projection": projection, "texels": solver.texel_count,
                     "shots": progress.shots, "seconds": seconds,
                     "unshot_fraction": progress.unshot_fraction,
                     "converged": progress.converged, "unshot": unshot})
        print(f"{projection:>10} {solver.texel_count:>8} {progress.shots:>7} {seconds:>8.2f} "
              f"{progress.unshot_fraction:>8.4f}")
        solver.release()
    ctx.release()
    save_results(args.json, {"device": device, "scene": args.scene, "size": args.size,
                             "texel_density": density, "shoot_level": shoot_level,
                             "threshold": args.threshold, "hemicube_resolution": args.hemicube,
                             "runs": runs})


if __name__ == "__main__":
    main()
