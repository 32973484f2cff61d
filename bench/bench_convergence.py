"""Unshot energy against shots and seconds (the paper's Figure 6 axes) for the Cornell box
at each shooting level, run to an unshot threshold.

    python bench/bench_convergence.py --density 100 --json bench/results/convergence-llvmpipe.json
"""
import argparse
import time
from pathlib import Path

from common import device_name, save_results  # also puts the repository on sys.path
from native import Settings, Solver, create_context
from native.samples import cornell_box


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--density", type=float, default=100.0)
    parser.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--threshold", type=float, default=0.01)
    parser.add_argument("--hemicube", type=int, default=256)
    parser.add_argument("--max-shots", type=int, default=60000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    scene = cornell_box()
    ctx = create_context()
    device = device_name(ctx)
    print(f"device: {device}")
    print(f"{'level':>6} {'texels':>8} {'shots':>7} {'seconds':>8} {'unshot':>8}")
    runs = []
    for level in args.levels:
        solver = Solver(scene, Settings(texel_density=args.density, shoot_level=level,
                                        threshold=args.threshold, max_shots=args.max_shots,
                                        hemicube_resolution=args.hemicube), ctx=ctx)
        curve = []
        start = time.perf_counter()

        def record(progress):
            if progress.shots % 25 == 0:
                curve.append((progress.shots, time.perf_counter() - start,
                              progress.unshot_fraction))
        progress = solver.run(record)
        seconds = time.perf_counter() - start
        curve.append((progress.shots, seconds, progress.unshot_fraction))
        runs.append({"level": level, "texels": solver.texel_count, "shots": progress.shots,
                     "seconds": seconds, "unshot_fraction": progress.unshot_fraction,
                     "curve": curve})
        print(f"{level:>6} {solver.texel_count:>8} {progress.shots:>7} {seconds:>8.2f} "
              f"{progress.unshot_fraction:>8.4f}")
        solver.release()
    ctx.release()
    save_results(args.json, {"device": device, "scene": "cornell_box",
                             "density": args.density, "threshold": args.threshold,
                             "hemicube_resolution": args.hemicube, "runs": runs})


if __name__ == "__main__":
    main()
