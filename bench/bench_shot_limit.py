"""Shots each sample scene needs to reach its threshold at the settings it is saved with (the
defaults unless the file changes them), against its texels and shooting blocks: the measure
behind Max Shots' default. --density-scale multiplies the saved texel density (shots grow
with the blocks, so a coarser bake measures shots per block where the CPU cannot shoot the
full one to the end); the blocks at the saved density are counted too. Each scene shoots
until its threshold or until --seconds have passed; the shots at which the unshot fraction
first fell to 10, 5, 2 and 1 % are recorded.

    python bench/bench_shot_limit.py [SCENE ...] [--density-scale X] [--seconds S] [--json PATH]
"""
import argparse
from dataclasses import replace
from pathlib import Path
import sys
import time

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "bench"))
import blender as runner  # noqa: E402  (tools/blender.py)
from common import device_name, save_results  # noqa: E402

SCENES = ("cornell_box", "columns", "interior", "temple", "office", "living")
MARKS = (0.1, 0.05, 0.02, 0.01)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenes", nargs="*", default=SCENES)
    parser.add_argument("--seconds", type=float, default=300.0)
    parser.add_argument("--density-scale", type=float, default=1.0)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    bpy = runner.start_blender()
    luxel = runner.luxel()
    rows = []
    for name in args.scenes:
        bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / f"{name}.blend"))
        export = luxel.addon.export.export_scene(bpy.context)
        saved = bpy.context.scene.luxel.solver_settings()
        with luxel.native.Solver(export.scene, saved, staged=True) as full:
            while full.set_up_step():
                pass
            blocks_saved = full.texel_count / (1 << saved.shoot_level) ** 2
        settings = replace(saved, max_shots=10 ** 9,
                           texel_density=saved.texel_density * args.density_scale)
        started = time.perf_counter()
        solver = luxel.native.Solver(export.scene, settings)
        set_up = time.perf_counter() - started
        reached = {}
        try:
            while solver.step():
                progress = solver.progress
                for mark in MARKS:
                    if mark not in reached and progress.unshot_fraction <= mark:
                        reached[mark] = progress.shots
                if progress.seconds > args.seconds:
                    break
            progress = solver.progress
            block = 1 << settings.shoot_level
            row = {"scene": name, "triangles": len(export.scene.triangles),
                   "density": settings.texel_density, "threshold": settings.threshold,
                   "shoot_level": settings.shoot_level, "texels": solver.texel_count,
                   "blocks": solver.texel_count / block ** 2, "set_up_s": set_up,
                   "blocks_at_saved_density": blocks_saved,
                   "shots": progress.shots, "unshot": progress.unshot_fraction,
                   "converged": progress.converged, "seconds": progress.seconds,
                   "shots_to": {str(mark): reached.get(mark) for mark in MARKS},
                   "device": device_name(solver.ctx)}
        finally:
            solver.release()
        rows.append(row)
        print(row, flush=True)
    save_results(args.json, {"rows": rows})


if __name__ == "__main__":
    main()
