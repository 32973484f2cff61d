"""The Cornell box at about 50,000 texels (160 texels per metre) with Luxel's default settings,
against a high-sample Cycles DIFFUSE bake into the same lightmap UVs, per object, with a
per-object energy ledger (needs the bpy module):

    python bench/bench_cornell_defaults.py --samples 256 \\
        --json bench/results/cornell-defaults-llvmpipe.json

The light is a black quad (a pure Emission shader: it reflects nothing) emitting from both
faces, 0.1 mm under the ceiling, as bench/cycles_parity.py builds it. The reference is two
Cycles bakes of --samples with different seeds, averaged; the difference of their per-object
means is Cycles' own noise on those means. Luxel runs once per variant (--variant name=value,
...). Compared: texels fully inside a chart, away from the light. Per object: Luxel's mean
over Cycles' (RGB), and the irradiance power each receives (W, pi L / rho times texel area,
summed), which is what the ledger spreads: received = absorbed + reflected."""
import argparse
import math
import time
from pathlib import Path

import numpy as np

from common import save_results  # also puts the repository on sys.path
from cycles_parity import cycles_bake, luxel_scene
from native import Settings, Solver
from native.evaluation.texel_error import lightmap_error
from native.samples import CORNELL_GREEN, CORNELL_RED, CORNELL_WHITE

# Block centres (x, z) in metres: a texel that is on no wall belongs to the nearer block.
BLOCK_CENTRES = {"short block": (0.185, 0.168), "tall block": (0.368, 0.351)}
ALBEDO = {"floor": CORNELL_WHITE, "ceiling": CORNELL_WHITE, "back wall": CORNELL_WHITE,
          "red wall": CORNELL_RED, "green wall": CORNELL_GREEN,
          "short block": CORNELL_WHITE, "tall block": CORNELL_WHITE}


def objects_of(samples):
    """Per object a boolean map of its texels, told apart by position and normal."""
    position, normal = samples["position"], samples["normal"]
    objects = {
        "floor": (position[..., 1] < 1e-4) & (normal[..., 1] > 0.99),
        "ceiling": (position[..., 1] > 0.5487) & (normal[..., 1] < -0.99),
        "back wall": (position[..., 2] > 0.5591) & (normal[..., 2] < -0.99),
        "red wall": (position[..., 0] > 0.5495) & (normal[..., 0] < -0.99),
        "green wall": (position[..., 0] < 1e-4) & (normal[..., 0] > 0.99),
    }
    blocks = ~np.logical_or.reduce(list(objects.values()))
    distance = {name: np.hypot(position[..., 0] - x, position[..., 2] - z)
                for name, (x, z) in BLOCK_CENTRES.items()}
    objects["short block"] = blocks & (distance["short block"] < distance["tall block"])
    objects["tall block"] = blocks & ~objects["short block"]
    return objects


def setting_value(name, text):
    """A --variant value as its setting's kind: "0" and "false" are False for a switch."""
    kind = type(getattr(Settings(), name))
    if kind is bool:
        return text.lower() not in ("0", "false", "no", "off")
    return kind(text)


def luxel_bake(scene, settings):
    start = time.perf_counter()
    with Solver(scene, settings) as solver:
        solver.run()
        result = {"image": solver.result()[0], "samples": solver.texel_samples()[0],
                  "atlas": solver.atlas, "device": solver.ctx.info["GL_RENDERER"],
                  "shots": solver.shots, "ledger": solver.ledger(),
                  "unshot_fraction": solver.progress.unshot_fraction}
    result["seconds"] = time.perf_counter() - start
    return result


def received_power(image, mask, area, albedo):
    """Irradiance power (W, RGB) on the masked texels: pi L / rho times their area."""
    return (math.pi * image[mask][:, :3] / np.asarray(albedo) * area[mask][:, None]).sum(axis=0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--density", type=float, default=160.0)
    parser.add_argument("--samples", type=int, default=256, help="per reference bake (two)")
    parser.add_argument("--bounces", type=int, default=64)
    parser.add_argument("--variant", action="append", default=[], metavar="NAME=VALUE,...",
                        help="also bake Luxel with these settings changed; repeatable")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    scene = luxel_scene(two_sided=True)
    variants = {"defaults": {}}
    for text in args.variant:
        changes = dict(item.split("=") for item in text.split(","))
        variants[text] = {name: setting_value(name, value) for name, value in changes.items()}
    runs = {}
    for name, changes in variants.items():
        runs[name] = luxel_bake(scene, Settings(texel_density=args.density, **changes))
        print(f"Luxel '{name}': {runs[name]['shots']} shots, {runs[name]['seconds']:.0f} s",
              flush=True)
    first = runs["defaults"]
    atlas, samples = first["atlas"], first["samples"]
    bakes = []
    for seed in (1, 2):
        pixels, seconds = cycles_bake(scene, atlas, args.samples, args.bounces, two_sided=True,
                                      seed=seed)
        bakes.append((pixels, seconds))
    cycles = 0.5 * (bakes[0][0] + bakes[1][0])

    occupied, full = samples["occupied"], samples["coverage"] > 0.999
    distance = np.linalg.norm(samples["position"] - np.array([0.278, 0.5487, 0.2795]), axis=2)
    compared = occupied & full & (distance > 0.1)
    objects = {name: mask & compared for name, mask in objects_of(samples).items()}
    area = samples["area"]
    emitted = float(np.mean(first["ledger"].emitted))
    print(f"Cornell box, {int(occupied.sum())} texels ({args.density:g} per metre), "
          f"{int(compared.sum())} compared; Cycles CPU 2 x {args.samples} samples, "
          f"{bakes[0][1] + bakes[1][1]:.0f} s; emitted {emitted:.4f} W (mean RGB)")
    noise = {name: float(np.mean(np.abs(bakes[0][0][mask][:, :3].sum(axis=0)
                                        / bakes[1][0][mask][:, :3].sum(axis=0) - 1.0))) / 2.0
             for name, mask in objects.items()}
    results = {"device": first["device"], "density": args.density, "samples": args.samples,
               "texels": int(occupied.sum()), "compared": int(compared.sum()),
               "cycles_seconds": [seconds for _, seconds in bakes],
               "cycles_noise_of_mean": noise, "emitted_w": emitted, "runs": {}}
    for name, run in runs.items():
        assert run["atlas"].width == atlas.width and run["atlas"].height == atlas.height
        image = run["image"]
        masked = [np.dstack([page[..., :3], compared]) for page in (image, cycles)]
        error = lightmap_error([masked[0]], [masked[1]])
        # The reference's own noise: the average of two bakes has a quarter of the mean
        # squared difference between them as its noise variance.
        difference = (bakes[0][0] - bakes[1][0])[compared][:, :3].astype(np.float64)
        noise_square = float((difference ** 2).sum(axis=1).mean()) / 4.0
        corrected = math.sqrt(max(error.rms ** 2 - noise_square, 0.0)) / error.reference_rms
        ledger = run["ledger"]
        print(f"\nLuxel '{name}' ({run['device']}): {run['shots']} shots, "
              f"{run['seconds']:.1f} s, unshot {run['unshot_fraction']:.4f}, relative RMS "
              f"{error.relative_rms:.2%} (less the reference's noise {corrected:.2%}); ledger (mean RGB, share of emitted): absorbed "
              f"{np.mean(ledger.absorbed) / emitted:.4f}, escaped "
              f"{np.mean(ledger.escaped) / emitted:.4f}, unshot {np.mean(ledger.unshot) / emitted:.4f}")
        print(f"  {'object':>11} {'texels':>6}  {'Luxel/Cycles mean (R, G, B)':>30}  "
              f"{'received W Luxel':>16} {'Cycles':>8} {'diff % of emitted':>17} {'Cycles noise':>12}")
        per_object = {}
        for object_name, mask in objects.items():
            ratio = image[mask][:, :3].sum(axis=0) / cycles[mask][:, :3].sum(axis=0)
            luxel_w = float(np.mean(received_power(image, mask, area, ALBEDO[object_name])))
            cycles_w = float(np.mean(received_power(cycles, mask, area, ALBEDO[object_name])))
            per_object[object_name] = {"mean_ratio_rgb": ratio.tolist(), "texels": int(mask.sum()),
                                       "received_w": luxel_w, "cycles_received_w": cycles_w}
            shown = ", ".join(f"{value:.4f}" for value in ratio)
            print(f"  {object_name:>11} {int(mask.sum()):6d}  {shown:>30}  "
                  f"{luxel_w:16.5f} {cycles_w:8.5f} {100 * (luxel_w - cycles_w) / emitted:16.2f}% "
                  f"{noise[object_name]:12.2%}")
        results["runs"][name] = {
            "settings": variants[name], "shots": run["shots"], "seconds": run["seconds"],
            "relative_rms": error.relative_rms, "relative_rms_less_noise": corrected,
            "reference_noise_relative_rms": math.sqrt(noise_square) / error.reference_rms,
            "unshot_fraction": run["unshot_fraction"],
            "ledger_share": {key: float(np.mean(getattr(ledger, key)) / emitted)
                             for key in ("absorbed", "escaped", "unshot")},
            "objects": per_object}
    save_results(args.json, results)


if __name__ == "__main__":
    main()
