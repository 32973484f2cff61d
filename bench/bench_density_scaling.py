"""Shots and seconds as the texel density grows: the Cornell box baked to the same unshot
threshold at several densities, each phase timed (a GPU sync after every phase), and the
receiver pass per texel per shot:

    python bench/bench_density_scaling.py --densities 60 120 240 \
        --json bench/results/density-scaling-llvmpipe.json

With ``--furnace`` the closed unit cube of albedo 0.5 (each face emitting) bakes instead, and
the error is measured against its closed form rho / (1 - rho) (an independent truth).

Beside wall-clock seconds it reports the process's CPU seconds (llvmpipe's threads included):
on a CPU shared with other jobs they measure the work, where wall-clock time measures the
neighbours too."""
import argparse
import math
from pathlib import Path
import sys
import time

import numpy as np

from common import device_name, save_results  # also puts the repository on sys.path
from native import Settings, Solver, create_context, receivers
from native.atlas import clear_cache
from native.samples import cornell_box

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import scenes  # noqa: E402  (tests/scenes.py: scenes with closed-form answers)

FURNACE_ALBEDO = 0.5


class CpuTimer:
    """Counts the CPU seconds of every receivers.update (the solver waits for the GPU after
    each phase with Settings.profile)."""

    def __init__(self):
        self.seconds = 0.0
        self.update = receivers.update
        receivers.update = self

    def __call__(self, *args, **kwargs):
        started = time.process_time()
        try:
            return self.update(*args, **kwargs)
        finally:
            args[0].ctx.finish()
            self.seconds += time.process_time() - started


def bake(scene, ctx, density, threshold, max_shots, *, furnace):
    clear_cache()
    timer = CpuTimer()
    started, cpu_started = time.perf_counter(), time.process_time()
    solver = Solver(scene, Settings(texel_density=density, threshold=threshold,
                                    max_shots=max_shots, ambient=False, profile=True), ctx=ctx)
    try:
        solver.run()
        pages = solver.result()
        seconds = time.perf_counter() - started
        shots = max(solver.shots, 1)
        row = {
            "density": density, "texels": solver.texel_count, "shots": solver.shots,
            "unshot_fraction": solver.progress.unshot_fraction, "seconds": seconds,
            "cpu_seconds": time.process_time() - cpu_started, "phases": dict(solver.timings),
            "receiver_ns_per_texel_shot": 1e9 * solver.timings["receivers"]
            / (shots * solver.texel_count),
            "receiver_cpu_ns_per_texel_shot": 1e9 * timer.seconds / (shots * solver.texel_count),
            "gpu_bytes_per_texel": solver.gpu_memory_bytes / solver.texel_count,
        }
        if furnace:
            row["furnace_error"] = _furnace_error(solver, pages)
        return row
    finally:
        receivers.update = timer.update
        solver.release()


def _furnace_error(solver, pages):
    """Relative RMS of the reflected radiance against rho / (1 - rho) (every face emits 1)."""
    samples = solver.texel_samples()
    expected = FURNACE_ALBEDO / (1.0 - FURNACE_ALBEDO)
    values = np.concatenate([page[..., :3][sample["occupied"]].ravel()
                             for page, sample in zip(pages, samples)])
    return float(math.sqrt(np.mean((values - expected) ** 2)) / expected)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--densities", type=float, nargs="+", default=[60.0, 120.0, 240.0])
    parser.add_argument("--threshold", type=float, default=0.003)
    parser.add_argument("--max-shots", type=int, default=10000)
    parser.add_argument("--furnace", action="store_true")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    scene = scenes.furnace_cube(FURNACE_ALBEDO) if args.furnace else cornell_box()
    ctx = create_context()
    device = device_name(ctx)
    print(f"device: {device}", flush=True)
    bake(scene, ctx, min(args.densities), 0.5, 2, furnace=False)   # compile the shaders before timing
    rows = []
    for density in args.densities:
        row = bake(scene, ctx, density, args.threshold, args.max_shots, furnace=args.furnace)
        rows.append(row)
        phases = " ".join(f"{name} {seconds:.2f}" for name, seconds in row["phases"].items())
        error = f", error {100 * row['furnace_error']:.2f} %" if args.furnace else ""
        print(f"{density:g} texels/m: {row['texels']} texels, {row['shots']} shots to "
              f"{100 * row['unshot_fraction']:.2f} % unshot, {row['seconds']:.2f} s "
              f"({row['cpu_seconds']:.2f} CPU s; {phases}), receivers "
              f"{row['receiver_ns_per_texel_shot']:.1f} ns per texel per shot "
              f"({row['receiver_cpu_ns_per_texel_shot']:.1f} CPU){error}", flush=True)
    ctx.release()
    save_results(args.json, {"device": device, "scene": "furnace" if args.furnace
                             else "cornell_box", "threshold": args.threshold, "rows": rows})


if __name__ == "__main__":
    main()
