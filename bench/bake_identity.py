"""Bake identity: the sample scenes' lightmaps and the per-step benchmark, before and after a
change that must not change behaviour (a refactor of the solver).

    python bench/bake_identity.py bake [--checkout PATH] --output DIR
    python bench/bake_identity.py compare BEFORE AFTER
    python bench/bake_identity.py figure1 BEFORE_CHECKOUT AFTER_CHECKOUT [--runs N]

bake runs `blender -b SCENE.blend --command luxel bake` (tools/blender.py, with this
interpreter's bpy) on each scene of sample_blends/ with the fixed settings of SCENES below and
writes each scene's EXR lightmaps into DIR/<scene>/. It bakes the code of --checkout (default:
the checkout this script is in), so that both sides of a comparison are baked with this one
script's settings and scenes; the .blend files are opened, never saved (no --save). About
80 to 110 s on two llvmpipe cores.

compare checks that BEFORE and AFTER hold the same files and every EXR the same pixels, bit
for bit (the pixel data only: header attributes do not count); it prints, per file, identical
or the largest absolute difference and the number of texels that differ, and exits 1 on any
difference.

figure1 runs `bench/paper.py figure1` (the per-step breakdown) of the two checkouts in turn,
A B A B ..., so that a drift of the machine's speed hits both alike, and prints each phase's
median seconds per side and the median of the after/before ratios taken pair by pair.
Options after -- go to both paper.py runs (--quick, --device gpu). A before/after check of a
refactor, from the repository's root:

    git worktree add ../luxel-before main
    .venv/bin/python bench/bake_identity.py bake --checkout ../luxel-before \\
        --output out/identity-before
    .venv/bin/python bench/bake_identity.py bake --output out/identity-after
    .venv/bin/python bench/bake_identity.py compare out/identity-before out/identity-after
    .venv/bin/python bench/bake_identity.py figure1 ../luxel-before . --runs 5
"""
import argparse
import json
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import OpenEXR

ROOT = Path(__file__).resolve().parent.parent
SAMPLE_BLENDS = ROOT / "sample_blends"

# Every bake stops at its shot count: threshold 0 leaves no room for a convergence test that
# a change of rounding could pass one shot earlier. Projection and subdivision are given even
# at their defaults, so that a change of default is not mistaken for a change of the solver;
# the scenes share out the projections, subdivisions and the three switches, so that each
# path through the solver is baked. The switches can only be turned one way from the command
# line (--no-ambient, --no-neighbour-visibility, --adaptive-shoot-level): the scenes without
# one bake at its default. Settings the command line does not offer (hemicube resolution,
# shoot level, image size) are the defaults of native.Settings.
COMMON = ["--threshold", "0", "--shadow-range", "0.02", "0.98", "--subdivision-level", "2"]
SCENES = {
    # The README's scenes; interior.blend came after the first five, and bakes in seconds.
    "cornell_box": ["--density", "60", "--shots", "400", "--projection", "HEMICUBE",
                    "--subdivision", "REGULAR"],
    "columns": ["--density", "10", "--shots", "300", "--projection", "NONLINEAR",
                "--subdivision", "ADAPTIVE"],
    "living": ["--density", "10", "--shots", "500", "--projection", "HEMISPHERE",
               "--subdivision", "NONE"],
    # Its ground plane is large: 3 texels per metre are already 56 k texels.
    "temple": ["--density", "3", "--shots", "400", "--projection", "HEMICUBE",
               "--subdivision", "NONE", "--no-ambient"],
    "office": ["--density", "8", "--shots", "300", "--projection", "HEMICUBE",
               "--subdivision", "NONE", "--adaptive-shoot-level"],
    "interior": ["--density", "10", "--shots", "500", "--projection", "HEMICUBE",
                 "--subdivision", "NONE", "--no-neighbour-visibility"],
}


def bake(checkout, output):
    output = output.resolve()
    if output.is_relative_to(SAMPLE_BLENDS):
        sys.exit(f"bake: {output} is inside sample_blends/: choose another folder")
    if output.exists() and any(output.iterdir()):
        # Files left from another bake would be compared as if this one had written them.
        sys.exit(f"bake: {output} is not empty: choose a new folder")
    started = time.perf_counter()
    for scene, options in SCENES.items():
        command = [sys.executable, str(checkout / "tools" / "blender.py"),
                   "-b", str(SAMPLE_BLENDS / f"{scene}.blend"), "--command", "luxel", "bake",
                   *COMMON, *options, "--output", str(output / scene)]
        scene_started = time.perf_counter()
        run = subprocess.run(command, capture_output=True, text=True)
        seconds = time.perf_counter() - scene_started
        if run.returncode != 0:
            print(run.stdout[-4000:], run.stderr[-4000:], sep="\n", file=sys.stderr)
            sys.exit(f"bake: {scene} failed (exit {run.returncode}): {' '.join(command)}")
        summary = [line for line in run.stdout.splitlines()
                   if line.startswith(("luxel: done", "luxel: warning"))]
        print(f"{scene:12} {seconds:6.1f} s  {' | '.join(summary)}", flush=True)
    print(f"baked {len(SCENES)} scenes with {checkout} into {output} in "
          f"{time.perf_counter() - started:.1f} s")


def exr_channels(path):
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        return {name: np.array(channel.pixels) for name, channel in exr.channels().items()}


def compare_exr(before, after):
    """None when the pixels are the same bits, else a line saying how they differ."""
    before, after = exr_channels(before), exr_channels(after)
    if before.keys() != after.keys():
        return f"channels {sorted(before)} against {sorted(after)}"
    shapes = {(b.shape, b.dtype) for b in before.values()} | {
        (a.shape, a.dtype) for a in after.values()}
    if len(shapes) > 1:
        return f"pixel arrays of different sizes or types: {sorted(map(str, shapes))}"
    names = sorted(before)
    old, new = np.stack([before[n] for n in names], -1), np.stack([after[n] for n in names], -1)
    # Bits, not values: -0 against 0 and NaN against NaN must count as they are stored.
    differs = old.view(f"u{old.itemsize}") != new.view(f"u{new.itemsize}")
    if not differs.any():
        return None
    largest = float(np.nanmax(np.abs(old.astype(np.float64) - new.astype(np.float64)),
                              initial=0.0))
    return (f"max abs difference {largest:.6g}, {int(differs.any(-1).sum()):,} of "
            f"{differs.shape[0] * differs.shape[1]:,} texels differ")


def compare(before, after):
    files = {folder: {path.relative_to(folder) for path in folder.rglob("*") if path.is_file()}
             for folder in (before, after)}
    names = sorted(files[before] | files[after])
    if not names:
        sys.exit("compare: both folders are empty")
    different = 0
    for name in names:
        if name not in files[after] or name not in files[before]:
            print(f"{name}: only in {before if name in files[before] else after}")
            different += 1
            continue
        if name.suffix == ".exr":
            difference = compare_exr(before / name, after / name)
        else:
            difference = (None if (before / name).read_bytes() == (after / name).read_bytes()
                          else "the bytes differ")
        print(f"{name}: {difference or 'identical'}")
        different += difference is not None
    print(f"{different} of {len(names)} files differ")
    return 1 if different else 0


def timed_figures(row):
    """One figure1 size's seconds by name: its phases, profiled total and plain total."""
    return {**row["phases"], "total": row["profiled_seconds"], "unprofiled": row["seconds"]}


def figure1(before, after, runs, bench_options):
    """Medians of figure1's per-phase seconds, the two checkouts run in turn."""
    results = {"before": [], "after": []}
    with tempfile.TemporaryDirectory(prefix="luxel-figure1-") as folder:
        for run in range(runs):
            for side, checkout in (("before", before), ("after", after)):
                out = Path(folder) / f"{side}-{run}"
                command = [sys.executable, str(checkout / "bench" / "paper.py"), "figure1",
                           *bench_options, "--out", str(out)]
                if subprocess.run(command, stdout=subprocess.DEVNULL).returncode != 0:
                    sys.exit(f"figure1: failed: {' '.join(command)}")
                study = json.loads((out / "figure1.json").read_text())
                results[side].append(next(iter(study["runs"].values()))["results"]["rows"])
                print(f"run {run + 1}/{runs}: {side} ({checkout}) done", flush=True)
    print(f"{'texels':>9} {'shooters':>8} {'phase':>12} {'before s':>10} {'after s':>10} "
          f"{'after/before':>12}")
    for size, row in enumerate(results["before"][0]):
        old_runs = [timed_figures(rows[size]) for rows in results["before"]]
        new_runs = [timed_figures(rows[size]) for rows in results["after"]]
        for figure in old_runs[0]:
            old = [figures[figure] for figures in old_runs]
            new = [figures[figure] for figures in new_runs]
            # A phase a size never enters (subdivision without it) takes no time on either side.
            ratios = [n / o for o, n in zip(old, new) if o > 0]
            ratio = f"{statistics.median(ratios):12.3f}" if ratios else f"{'-':>12}"
            print(f"{row['texels']:>9} {row['shooters_per_selection']:>8} {figure:>12} "
                  f"{statistics.median(old):10.4f} {statistics.median(new):10.4f} {ratio}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    bake_parser = commands.add_parser("bake", help="bake the sample scenes with fixed settings")
    bake_parser.add_argument("--checkout", type=Path, default=ROOT, metavar="PATH",
                             help="the checkout whose code bakes (default: this script's)")
    bake_parser.add_argument("--output", type=Path, required=True, metavar="DIR")
    compare_parser = commands.add_parser("compare", help="compare two bakes' lightmaps")
    compare_parser.add_argument("before", type=Path)
    compare_parser.add_argument("after", type=Path)
    bench_parser = commands.add_parser("figure1", help="paper.py figure1 of two checkouts, "
                                       "in turn", usage="%(prog)s [--runs N] BEFORE AFTER "
                                       "[-- PAPER_OPTIONS]")
    bench_parser.add_argument("before", type=Path, help="checkout before the change")
    bench_parser.add_argument("after", type=Path, help="checkout after the change")
    bench_parser.add_argument("--runs", type=int, default=5, help="runs of each checkout")
    # What follows -- goes to paper.py as it is, split off by hand: argparse would read it as
    # this script's own arguments.
    argv = sys.argv[1:]
    ours, bench_options = (argv[:argv.index("--")], argv[argv.index("--") + 1:]) \
        if "--" in argv else (argv, [])
    args = parser.parse_args(ours)
    if args.command == "bake":
        if not (args.checkout / "tools" / "blender.py").is_file():
            parser.error(f"{args.checkout} is not a Luxel checkout (no tools/blender.py)")
        bake(args.checkout.resolve(), args.output)
    elif args.command == "compare":
        for folder in (args.before, args.after):
            if not folder.is_dir():
                parser.error(f"{folder} is not a folder")
        sys.exit(compare(args.before, args.after))
    else:
        if args.runs < 1:
            parser.error("--runs must be 1 or more")
        figure1(args.before.resolve(), args.after.resolve(), args.runs, bench_options)


if __name__ == "__main__":
    main()
