"""The visibility pass drawn two ways, alternated in one process: one geometry-shader pass that
sends each triangle to the cube faces it reaches, and one draw per face of the clusters of
triangles that can reach that face (Settings.visibility_draw). Per scene and path: the
visibility phase's wall-clock and CPU seconds per shot (a GPU sync after every phase), the
median over the repeats, and whether both paths bake the same lightmaps bit for bit.

    python bench/bench_visibility_draw.py --scenes cornell_box living --repeats 3 \\
        --json bench/results/visibility-draw-llvmpipe.json

--draw-clusters N ... times the per-face path with its draws cut at each N clusters
(visibility.PER_FACE_DRAW_CLUSTERS; 0: one draw per run of consecutive clusters).

A scene is a name of native.samples (cornell_box), of bench/scenes/ (living), or the path of
a scene file (bench_charting.py's subdivided interiors: bench/scenes/generated/*.npz). Each
bake stops at --shots shots (threshold 0), at --density texels per metre where given, else at
the scene's own density of DENSITIES.

CPU seconds are the process's (llvmpipe's threads included) while visibility.render and its
GPU sync run: on a CPU shared with other jobs they measure the work, where wall-clock time
measures the neighbours too."""
import argparse
from pathlib import Path
import statistics
import time

import numpy as np

# common also puts the repository on sys.path
from common import device_name, load_scene, save_results
from native import Scene, Settings, Solver, create_context, samples, visibility

# Texels per metre a scene bakes at unless --density says otherwise: the Cornell box at the
# density scaling's lowest, the living room as BENCHMARKS.md's "Triangles" measured it.
DENSITIES = {"cornell_box": 60.0, "living": 4.0}
DEFAULT_DENSITY = 4.0


class CpuTimer:
    """Counts the CPU seconds of every visibility.render and render_batch (a batch of
    shooters' maps) and its GPU sync."""

    def __init__(self):
        self.seconds = 0.0
        self.originals = {name: getattr(visibility, name) for name in ("render", "render_batch")}
        for name, function in self.originals.items():
            setattr(visibility, name, self.timed(function))

    def timed(self, function):
        def call(state, *args, **kwargs):
            started = time.process_time()
            try:
                return function(state, *args, **kwargs)
            finally:
                state.ctx.finish()
                self.seconds += time.process_time() - started
        return call

    def restore(self):
        for name, function in self.originals.items():
            setattr(visibility, name, function)


def scene_named(name):
    if hasattr(samples, name):
        return getattr(samples, name)()
    if Path(name).suffix == ".npz":
        return Scene.load(Path(name))
    return load_scene(name)


def bake(scene, ctx, *, density, shots, path, draw_clusters):
    visibility.PER_FACE_DRAW_CLUSTERS = draw_clusters or None
    timer = CpuTimer()
    solver = Solver(scene, Settings(texel_density=density, threshold=0.0, max_shots=shots,
                                    ambient=False, profile=True, visibility_draw=path),
                    ctx=ctx)
    try:
        solver.run()
        per_shot = max(solver.shots, 1)
        return {"path": path, "draw_clusters": draw_clusters, "shots": solver.shots,
                "texels": solver.texel_count,
                "visibility_seconds_per_shot": solver.timings["visibility"] / per_shot,
                "visibility_cpu_seconds_per_shot": timer.seconds / per_shot,
                "phases": dict(solver.timings)}, solver.result()
    finally:
        timer.restore()
        solver.release()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", nargs="+", default=["cornell_box", "living"])
    parser.add_argument("--density", type=float)
    parser.add_argument("--shots", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--draw-clusters", type=int, nargs="+",
                        default=[visibility.PER_FACE_DRAW_CLUSTERS])
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    ctx = create_context()
    device = device_name(ctx)
    print(f"device: {device}", flush=True)
    results = []
    for name in args.scenes:
        scene = scene_named(name)
        density = args.density or DENSITIES.get(name, DEFAULT_DENSITY)
        variants = [("GEOMETRY_SHADER", None)] + [("PER_FACE", clusters)
                                                  for clusters in args.draw_clusters]
        for path, clusters in variants[:2]:   # compile the shaders before timing
            bake(scene, ctx, density=density, shots=2, path=path, draw_clusters=clusters)
        rows, lightmaps = [], {}
        for repeat in range(args.repeats):
            for path, clusters in variants:
                label = path if clusters is None else f"{path} ({clusters or 'runs'})"
                row, pages = bake(scene, ctx, density=density, shots=args.shots, path=path,
                                  draw_clusters=clusters)
                row.update(repeat=repeat, label=label)
                rows.append(row)
                lightmaps.setdefault(label, pages)
                print(f"{name} {label} #{repeat}: {row['shots']} shots, visibility "
                      f"{1e3 * row['visibility_seconds_per_shot']:.2f} ms per shot "
                      f"({1e3 * row['visibility_cpu_seconds_per_shot']:.2f} CPU ms)",
                      flush=True)
        first = next(iter(lightmaps.values()))
        identical = all(np.array_equal(a, b) for pages in lightmaps.values()
                        for a, b in zip(first, pages))
        summary = {"scene": name, "triangles": int(len(scene.triangles)), "density": density,
                   "shots": args.shots, "identical_lightmaps": identical, "rows": rows,
                   "medians": {}}
        for label in lightmaps:
            mine = [row for row in rows if row["label"] == label]
            wall, cpu = (statistics.median(row[key] for row in mine)
                         for key in ("visibility_seconds_per_shot",
                                     "visibility_cpu_seconds_per_shot"))
            summary["medians"][label] = {"visibility_seconds_per_shot": wall,
                                         "visibility_cpu_seconds_per_shot": cpu}
            print(f"{name} ({summary['triangles']} triangles) {label}: median "
                  f"{1e3 * wall:.2f} ms per shot, {1e3 * cpu:.2f} CPU ms", flush=True)
        print(f"{name}: lightmaps {'identical' if identical else 'DIFFER'}", flush=True)
        results.append(summary)
    ctx.release()
    save_results(args.json, {"device": device, "scenes": results})


if __name__ == "__main__":
    main()
