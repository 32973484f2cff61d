"""How long the UI waits between two chances to take Esc during a bake's set-up: a BakeJob on
each sample scene at its saved settings, stepped as the modal operator steps it but with no
time budget (one piece per step), each step timed. Before the set-up ran in the modal loop,
the whole set-up was one wait.

    python bench/bench_set_up_pieces.py [SCENE ...] [--json PATH]
"""
import argparse
from collections import defaultdict
from pathlib import Path
import sys
import time

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "bench"))
import blender as runner  # noqa: E402  (tools/blender.py)
from common import device_name, save_results  # noqa: E402

SCENES = ("interior", "temple", "office", "living")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenes", nargs="*", default=SCENES)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    bpy = runner.start_blender()
    luxel = runner.luxel()
    rows = []
    for name in args.scenes:
        bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / f"{name}.blend"))
        started = time.perf_counter()
        job = luxel.addon.bake.BakeJob(bpy.context)
        stages = defaultdict(list)   # stage: seconds of each of its pieces
        try:
            while not job.is_set_up:
                stage = job.set_up_progress.stage
                before = time.perf_counter()
                job.step(0.0)
                stages[stage].append(time.perf_counter() - before)
            whole = time.perf_counter() - started
            row = {"scene": name, "triangles": len(job.export.scene.triangles),
                   "texels": job.solver.texel_count, "set_up_s": whole,
                   "longest_piece_s": max(max(pieces) for pieces in stages.values()),
                   "stages": {stage: {"pieces": len(pieces), "seconds": sum(pieces),
                                      "longest_s": max(pieces),
                                      "each_s": pieces if len(pieces) <= 8 else None}
                              for stage, pieces in stages.items()},
                   "device": device_name(job.solver.ctx)}
        finally:
            job.release()
        rows.append(row)
        print(row, flush=True)
    save_results(args.json, {"rows": rows})


if __name__ == "__main__":
    main()
