"""Real game levels (OBJ, one object of many material groups, no UV map) baked at level
densities: shots, phases and time to the threshold, the unshot fraction where the bake
stopped, and whether it diverged. The levels are read from a folder given on the command
line (the project does not ship them); each is lit by a sun and a uniform sky, grey 0.8
everywhere, as a level imported without its textures bakes.

    python bench/bench_levels.py --levels DIR --level pandora --density 0.5 \\
        --json bench/results/levels-pandora-0.5-llvmpipe.json

No Cycles comparison yet: that needs the levels imported through Blender (docs/
benchmarks-log.md, "Real levels")."""
import argparse
import dataclasses
from pathlib import Path
import time

import numpy as np

from common import add_level_arguments, device_name, save_results
from native import Scene, Settings, Solver, SunLight, create_context
from native.scene import triangle_areas

# One unit of Cube 2 and Tesseract maps is about 0.1 m (a player stands about 15 units).
GAME_UNIT = 0.1
SUN_DIRECTION = (0.3, 0.2, -0.9)
SUN_STRENGTH = 3.0
SKY = 0.5
ALBEDO = 0.8


def read_obj(path, scale):
    """Vertices (Z up, metres) and triangles of an OBJ file, its polygons fanned, as
    Blender's importer reads it with its default axes (Y up, -Z forward); zero-area
    triangles dropped, as the add-on skips them. Returns (vertices, triangles, dropped)."""
    vertices, triangles = [], []
    with open(path) as lines:
        for line in lines:
            if line.startswith("v "):
                vertices.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                corners = [int(token.split("/")[0]) for token in line.split()[1:]]
                corners = [c - 1 if c > 0 else len(vertices) + c for c in corners]
                triangles += [[corners[0], corners[k], corners[k + 1]]
                              for k in range(1, len(corners) - 1)]
    v = np.asarray(vertices, dtype=np.float64) * scale
    v = np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1)
    t = np.asarray(triangles, dtype=np.int64)
    _, degenerate = triangle_areas(v[t])
    return v, t[~degenerate], int(degenerate.sum())


def level_scene(path):
    vertices, triangles, dropped = read_obj(path, GAME_UNIT)
    direction = np.asarray(SUN_DIRECTION) / np.linalg.norm(SUN_DIRECTION)
    scene = Scene(vertices=vertices, triangles=triangles,
                  albedo=np.full((len(triangles), 3), ALBEDO),
                  lights=[SunLight(direction=tuple(direction), strength=SUN_STRENGTH)],
                  sky=(SKY,) * 3)
    return scene, dropped


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_level_arguments(parser, density=1.0)
    parser.add_argument("--back-faces", action="store_true",
                        help="every face's back receives on texels of its own")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    scene, dropped = level_scene(args.levels / f"{args.level}.obj")
    if args.back_faces:
        scene = dataclasses.replace(scene, receive_back=np.ones(len(scene.triangles), bool))
    ctx = create_context()
    started = time.perf_counter()
    solver = Solver(scene, Settings(texel_density=args.density, threshold=args.threshold,
                                    max_shots=args.shots, profile=True), ctx=ctx)
    set_up = time.perf_counter() - started
    trace = []
    while solver.step():
        progress = solver.progress
        if not trace or progress.shots >= trace[-1]["shots"] + 500:
            trace.append({"shots": progress.shots, "unshot": progress.unshot_fraction,
                          "seconds": progress.seconds})
            print(f"{progress.shots} shots, {100 * progress.unshot_fraction:.2f} % unshot, "
                  f"{progress.seconds:.0f} s", flush=True)
    progress = solver.progress
    ledger = solver.ledger()
    result = {
        "level": args.level, "density": args.density, "threshold": args.threshold,
        "back_faces": args.back_faces,
        "device": device_name(ctx), "triangles": len(scene.triangles),
        "zero_area_dropped": dropped, "texels": solver.texel_count,
        "set_up_seconds": set_up, "seconds": progress.seconds, "shots": progress.shots,
        "shot_limit": progress.shot_limit, "unshot": progress.unshot_fraction,
        "converged": progress.converged, "diverged": progress.diverged,
        "phases": dict(solver.timings), "ledger_imbalance": ledger.imbalance(),
        "trace": trace,
    }
    solver.release()
    ctx.release()
    print({key: value for key, value in result.items() if key != "trace"})
    save_results(args.json, result)


if __name__ == "__main__":
    main()
