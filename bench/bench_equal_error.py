"""Luxel against Cycles at equal error: the time each needs to reach 5 %, 2 % and 1 % relative
RMS against a high-sample Cycles reference, on the sample scenes (needs the bpy module):

    python bench/bench_equal_error.py --scene cornell_box --density 60 --samples 2048 \
        --json bench/results/equal-error-cornell_box-llvmpipe.json

Errors are measured at the same surface points for both: Cycles bakes into Luxel's lightmap
UVs, texel for texel (the paper's eq. 1 over texels both cover). The reference is two Cycles
bakes of `--samples` with different seeds, averaged; half the mean squared difference of the
two estimates its noise variance, which is subtracted from every squared error, so that the
curves measure distance to the converged answer rather than to the reference's noise. Luxel's
seconds are its bake (export, atlas, solve; snapshots excluded), Cycles' each bake call."""
import argparse
import json
import math
from pathlib import Path
import sys
import time

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tools"))
import blender as runner  # noqa: E402  (tools/blender.py)

TARGETS = (0.05, 0.02, 0.01)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default="cornell_box", help="a sample_blends/ name")
    parser.add_argument("--density", type=float, required=True, help="texels per metre")
    parser.add_argument("--threshold", type=float, default=0.002)
    parser.add_argument("--samples", type=int, default=2048, help="per reference bake")
    parser.add_argument("--exclude", nargs="*", default=[],
                        help="objects left out of the second set of numbers")
    parser.add_argument("--variant", action="append", default=[], metavar="NAME=VALUE,...",
                        help="also bake Luxel with these Luxel scene settings changed (say "
                        "ambient=1), against the same reference and Cycles curve; repeatable")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--save-reference", type=Path, metavar="NPZ",
                        help="also save the averaged reference, per object, for "
                        "bench_gpu_curve.py's Luxel runs elsewhere")
    args = parser.parse_args()

    bpy = runner.start_blender()
    luxel = runner.luxel()
    compare = luxel.addon.compare
    reference_module = luxel.addon.reference
    bpy.ops.wm.open_mainfile(filepath=str(runner.ROOT / "sample_blends" / f"{args.scene}.blend"))
    context = bpy.context
    settings = context.scene.luxel
    settings.texel_density = args.density
    settings.threshold = args.threshold
    settings.max_shots = 1_000_000

    bake = compare.bake_with_snapshots(context)
    variants = {spec: _bake_variant(context, compare, spec) for spec in args.variant}
    targets = reference_module.receivers(context.scene)
    started = time.perf_counter()
    first = reference_module.cycles_reference(context, samples=args.samples, seed=11)
    second = reference_module.cycles_reference(context, samples=args.samples, seed=12)
    reference_seconds = time.perf_counter() - started
    # Cycles' curve: 1, 4, 16, ... samples up to half a reference bake's.
    options = compare.CompareOptions(directory="", samples=4 * args.samples)

    result = {"scene": args.scene, "device": {"luxel": bake.device, "cycles": "CPU"},
              "density": args.density, "threshold": args.threshold,
              "reference_samples": 2 * args.samples, "reference_seconds": reference_seconds,
              "texels": context.scene.luxel.stats.texels, "sets": {}}
    for label, excluded in (("all", set()), ("without " + " ".join(args.exclude),
                                            set(args.exclude))):
        if label != "all" and not excluded:
            continue
        names = [obj.name for obj in targets if obj.name in first and obj.name not in excluded]
        reference = {n: _average(first[n], second[n]) for n in names}
        noise, magnitude = _noise_and_magnitude(names, first, second)
        cycles_curve = _debiased(compare.cycles_curve(context, options, names, reference),
                                 noise, magnitude)
        entry = {"objects": names, "reference_noise_rel": noise ** 0.5 / magnitude,
                 "cycles": cycles_curve, "variants": {}}
        for spec, run in [("", bake)] + list(variants.items()):
            luxel_curve = _debiased(run.curve(targets, names, reference), noise, magnitude)
            rows = _equal_error_rows(luxel_curve, cycles_curve,
                                     f"{args.scene} [{label}]{' ' + spec if spec else ''}")
            if spec:
                entry["variants"][spec] = {"luxel": luxel_curve, "equal_error": rows}
            else:
                entry.update(luxel=luxel_curve, equal_error=rows)
        result["sets"][label] = entry
    if args.json:
        args.json.write_text(json.dumps(result, indent=2, allow_nan=False, default=_plain))
    if args.save_reference:
        _save_reference(args.save_reference, targets, first, second, result)


def _bake_variant(context, compare, spec):
    """A Luxel bake with snapshots under the settings ``spec`` names, which are restored."""
    settings = context.scene.luxel
    changed = {}
    for item in spec.split(","):
        name, value = item.split("=", 1)
        current = getattr(settings, name)
        changed[name] = current
        setattr(settings, name, type(current)(float(value)) if not isinstance(current, str)
                else value)
    try:
        return compare.bake_with_snapshots(context)
    finally:
        for name, value in changed.items():
            setattr(settings, name, value)


def _equal_error_rows(luxel_curve, cycles_curve, label):
    rows = []
    for target in TARGETS:
        luxel_time = _time_to(luxel_curve, target)
        cycles_time = _time_to(cycles_curve, target)
        ratio = (cycles_time / luxel_time if luxel_time and cycles_time else None)
        rows.append({"target": target, "luxel_seconds": luxel_time,
                     "cycles_seconds": cycles_time, "cycles_over_luxel": ratio})
        print(f"{label} {100 * target:.0f} %: Luxel {_s(luxel_time)}, "
              f"Cycles {_s(cycles_time)}, ratio {_s(ratio, '')}", flush=True)
    return rows


def _save_reference(path, targets, first, second, result):
    """Per object: its atlas page and the averaged reference over the texels Cycles covered;
    the noise variance of that average per texel; Cycles' curves for the record."""
    arrays = {}
    for obj in targets:
        name = obj.name
        if name not in first:
            continue
        covered = first[name][..., 3] > 0.5
        rows, columns = np.nonzero(covered)
        average = 0.5 * (first[name][covered][:, :3] + second[name][covered][:, :3])
        difference = first[name][covered][:, :3] - second[name][covered][:, :3]
        arrays[f"{name}/page"] = np.array(int(obj.luxel.image["luxel_page"]))
        arrays[f"{name}/texels"] = np.stack([rows, columns], axis=1).astype(np.int32)
        arrays[f"{name}/rgb"] = average.astype(np.float32)
        arrays[f"{name}/variance"] = ((difference ** 2).sum(axis=1) / 4.0).astype(np.float32)
    arrays["result"] = np.array(json.dumps(result, default=_plain))
    np.savez_compressed(path, **arrays)


def _average(a, b):
    mean = 0.5 * (a + b)
    mean[..., 3] = a[..., 3]
    return mean


def _noise_and_magnitude(names, first, second):
    """Variance of the averaged reference per texel (RGB length squared), and its RMS value."""
    squares = difference = count = 0.0
    for name in names:
        covered = first[name][..., 3] > 0.5
        a, b = first[name][covered][:, :3].astype(float), second[name][covered][:, :3]
        difference += float(((a - b) ** 2).sum())
        squares += float((((a + b) / 2) ** 2).sum())
        count += int(covered.sum())
    # var(a - b) = 2 s^2 per texel; the average's variance is s^2 / 2.
    return difference / count / 4.0, math.sqrt(squares / count)


def _debiased(points, noise, magnitude):
    """Adds the debiased errors; per-object errors stay on the last point only (where each
    curve ends), not on every point."""
    for index, point in enumerate(points):
        point["rms_debiased"] = math.sqrt(max(point["rms"] ** 2 - noise, 0.0))
        point["rel_rms_debiased"] = point["rms_debiased"] / magnitude
        if index < len(points) - 1:
            point.pop("objects", None)
    return points


def _time_to(points, target):
    """Seconds at which a curve first reaches ``target`` (log-log interpolation between the
    points around it), or None."""
    previous = None
    for point in points:
        error, seconds = point["rel_rms_debiased"], point["seconds"]
        if error <= target:
            if previous is None or previous[0] <= 0 or error <= 0:
                return seconds
            (e0, t0), (e1, t1) = previous, (error, seconds)
            share = math.log(e0 / target) / math.log(e0 / e1) if e0 != e1 else 1.0
            return math.exp(math.log(t0) + share * (math.log(t1) - math.log(t0)))
        previous = (error, seconds)
    return None


def _s(value, unit=" s"):
    return "not reached" if value is None else f"{value:.3g}{unit}"


def _plain(value):
    return float(value)


if __name__ == "__main__":
    main()
