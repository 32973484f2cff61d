"""Luxel's speed-against-error curve on a machine without Blender (a GPU server), measured
against a Cycles reference made elsewhere by `bench_equal_error.py --save-reference`:

    python bench/bench_gpu_curve.py run --scene cornell_box --density 60 --threshold 0.002 \
        --output curve-h100.npz                       # where the GPU is; no Blender needed
    python bench/bench_gpu_curve.py compare --reference reference.npz --snapshots \
        curve-h100.npz --json all.json               # and --exclude ceiling --json without.json
    python bench/bench_gpu_curve.py merge all.json without.json \
        --variant "before=bench/results/equal-error-cornell_box-llvmpipe.json" \
        --output bench/results/equal-error-cornell_box-h100.json   # for bench/plot.py

The bake is the solver's alone on the exported scene (bench/scenes/<scene>.npz: the same
triangles, materials and lights the extension exports), so its seconds exclude Blender's
export; the atlas comes out texel for texel as in Blender (xatlas is deterministic), which
`compare` checks: it measures over the texels both cover, and refuses a reference whose
texels are more than MAX_LEFT_OUT not Luxel's."""
import argparse
import json
import math
from pathlib import Path
import time

import numpy as np

from bench_equal_error import TARGETS, _time_to

# compare refuses a reference whose texels are not Luxel's beyond this share: another atlas.
MAX_LEFT_OUT = 0.2
from common import device_name, load_scene
from native import Settings, Solver, create_context
from native.evaluation.snapshots import Snapshots


def run(args):
    ctx = create_context()
    device = device_name(ctx)
    snapshots = Snapshots(time.perf_counter(), per_doubling=args.per_doubling)
    solver = Solver(load_scene(args.scene), Settings(texel_density=args.density,
                                                     threshold=args.threshold,
                                                     ambient=not args.no_ambient,
                                                     max_shots=1_000_000), ctx=ctx)
    while solver.step():
        snapshots.after_step(solver)
    snapshots.take(solver)
    solver.release()
    ctx.release()
    arrays = {"device": np.array(device), "shots": np.array(snapshots.shots),
              "seconds": np.array(snapshots.seconds)}
    for page, mask in enumerate(snapshots.masks):
        arrays[f"mask{page}"] = mask
        for index, rgb in enumerate(snapshots.rgb):
            arrays[f"rgb{page}_{index}"] = rgb[page]
    np.savez_compressed(args.output, **arrays)
    print(f"{device}: {len(snapshots.shots)} snapshots, {snapshots.shots[-1]} shots in "
          f"{snapshots.seconds[-1]:.3f} s")


def compare(args):
    reference = np.load(args.reference)
    luxel = np.load(args.snapshots)
    names = sorted({key.split("/")[0] for key in reference.files if "/" in key})
    names = [name for name in names if name not in set(args.exclude)]
    pages = {int(key[4:]): luxel[key] for key in luxel.files if key.startswith("mask")}
    # Per page, where each occupied texel's RGB sits in the snapshot rows.
    row_of = {}
    for page, mask in pages.items():
        rows = np.full(mask.shape, -1)
        rows[mask] = np.arange(int(mask.sum()))
        row_of[page] = rows
    lookups, squares, variance, count, left_out = [], 0.0, 0.0, 0, 0
    for name in names:
        page = int(reference[f"{name}/page"])
        texels = reference[f"{name}/texels"]
        rows = row_of[page][texels[:, 0], texels[:, 1]]
        # Over the texels both cover, as the extension's comparison does: where Blender's
        # UVs and the atlas part (faces cut across charts before 3dfb2cf), Cycles bakes
        # texels that hold no surface here.
        shared = rows >= 0
        left_out += int((~shared).sum())
        rgb = reference[f"{name}/rgb"].astype(np.float64)[shared]
        lookups.append((page, rows[shared], rgb))
        squares += float((rgb ** 2).sum())
        variance += float(reference[f"{name}/variance"][shared].sum())
        count += len(rgb)
    if left_out > MAX_LEFT_OUT * (count + left_out):
        raise SystemExit(f"{left_out} of {count + left_out} reference texels are not Luxel's: "
                         "the atlas differs from the one the reference was made on")
    magnitude, noise = math.sqrt(squares / count), variance / count
    curve = []
    for index, (shots, seconds) in enumerate(zip(luxel["shots"], luxel["seconds"])):
        error = sum(float(((luxel[f"rgb{page}_{index}"][rows] - rgb) ** 2).sum())
                    for page, rows, rgb in lookups)
        debiased = math.sqrt(max(error / count - noise, 0.0))
        curve.append({"shots": int(shots), "seconds": float(seconds),
                      "rel_rms": math.sqrt(error / count) / magnitude,
                      "rel_rms_debiased": debiased / magnitude})
    recorded = json.loads(str(reference["result"]))
    label = "all" if not args.exclude else "without " + " ".join(args.exclude)
    cycles = recorded["sets"][label]["cycles"]
    rows = []
    for target in TARGETS:
        luxel_time, cycles_time = _time_to(curve, target), _time_to(cycles, target)
        rows.append({"target": target, "luxel_seconds": luxel_time,
                     "cycles_seconds": cycles_time,
                     "cycles_over_luxel": (cycles_time / luxel_time
                                           if luxel_time and cycles_time else None)})
        print(f"[{label}] {100 * target:.0f} %: Luxel {luxel_time}, Cycles {cycles_time}")
    result = {"scene": recorded["scene"], "device": {"luxel": str(luxel["device"]),
                                                     "cycles": "CPU (the reference's machine)"},
              "set": label, "objects": names, "reference_texels_left_out": left_out,
              "reference_noise_rel": math.sqrt(noise) / magnitude,
              "luxel": curve, "cycles": cycles, "equal_error": rows}
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))


def merge(args):
    """One bench_equal_error.py-style result (what plot.equal_error draws) from compare's
    results per set of objects, with earlier Luxel curves as variants."""
    sets = {}
    for path in args.compared:
        compared = json.loads(path.read_text())
        label = compared["set"]
        sets[label] = {key: compared[key] for key in
                       ("objects", "reference_noise_rel", "cycles", "luxel", "equal_error")}
        sets[label]["variants"] = {}
    for spec in args.variant:
        name, path = spec.split("=", 1)
        earlier = json.loads(Path(path).read_text())
        for label, entry in earlier["sets"].items():
            if label in sets:
                sets[label]["variants"][name] = {"luxel": entry["luxel"]}
    args.output.write_text(json.dumps({"scene": compared["scene"], "device": compared["device"],
                                       "sets": sets}, indent=2))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    bake = commands.add_parser("run")
    bake.add_argument("--scene", required=True)
    bake.add_argument("--density", type=float, required=True)
    bake.add_argument("--threshold", type=float, default=0.002)
    bake.add_argument("--per-doubling", type=int, default=2,
                      help="snapshots per doubling of the shots")
    bake.add_argument("--no-ambient", action="store_true",
                      help="leave out the ambient term (Settings.ambient)")
    bake.add_argument("--output", type=Path, required=True)
    check = commands.add_parser("compare")
    check.add_argument("--reference", type=Path, required=True)
    check.add_argument("--snapshots", type=Path, required=True)
    check.add_argument("--exclude", nargs="*", default=[])
    check.add_argument("--json", type=Path)
    combine = commands.add_parser("merge")
    combine.add_argument("compared", type=Path, nargs="+", help="compare's --json results")
    combine.add_argument("--variant", action="append", default=[],
                         help="LABEL=an earlier equal-error result: its Luxel curves")
    combine.add_argument("--output", type=Path, required=True)
    args = parser.parse_args()
    {"run": run, "compare": compare, "merge": merge}[args.command](args)


if __name__ == "__main__":
    main()
