"""Plots for BENCHMARKS.md from bench/results/*.json, and the paper's Table 2 in Markdown.

    python bench/plot.py        # every plot: bench/results/*.png (equal error: one per run)
    python bench/plot.py --table2 bench/results/projections-llvmpipe.json   # prints Markdown
    python bench/plot.py --table1 bench/results/table1-h100.json           # prints Markdown
"""
import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
PHASES = ("preprocess", "selection", "visibility", "receivers", "postprocess")
PROJECTION_NAMES = {"HEMICUBE": "hemicube", "HEMISPHERE": "hemisphere",
                    "NONLINEAR": "non-linear hemisphere"}
SUBDIVISION_NAMES = {"NONE": "no", "ADAPTIVE": "adapt", "REGULAR": "reg"}   # as in Table 2


def short_device(device):
    return device.split("/")[0].replace("NVIDIA ", "").split("(")[0].strip()


def breakdown():
    runs = [json.loads(path.read_text()) for path in sorted(RESULTS.glob("core-*.json"))]
    if not runs:
        return
    figure, axes = plt.subplots(1, len(runs), figsize=(5.5 * len(runs), 4.2), squeeze=False)
    for axis, run in zip(axes[0], runs):
        labels = [f"{row['texels'] / 1000:.0f} k" for row in run["rows"]]
        bottom = [0.0] * len(labels)
        for phase in PHASES:
            values = [row["phases"][phase] * 1000 for row in run["rows"]]
            axis.bar(labels, values, bottom=bottom, label=phase)
            bottom = [b + v for b, v in zip(bottom, values)]
        axis.set_title(f"{run['device'].split('/')[0].strip()}\n{run['shots']} shots, "
                       f"hemicube {run['hemicube_resolution']}", fontsize=9)
        axis.set_xlabel("lightmap texels (Cornell box)")
        axis.set_ylabel("milliseconds (GPU synced after each phase)")
    axes[0][0].legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(RESULTS / "core-breakdown.png", dpi=110)


def convergence():
    runs = [json.loads(path.read_text()) for path in sorted(RESULTS.glob("convergence-*.json"))]
    if not runs:
        return
    figure, (by_shots, by_seconds) = plt.subplots(1, 2, figsize=(11, 4.2))
    for run in runs:
        device = short_device(run["device"])
        for entry in run["runs"]:
            shots, seconds, unshot = zip(*entry["curve"])
            label = f"{device}, {entry['texels'] / 1000:.0f} k texels, level {entry['level']}"
            by_shots.plot(shots, unshot, label=label)
            by_seconds.plot(seconds, unshot, label=label)
    for axis, xlabel in ((by_shots, "shots"), (by_seconds, "seconds")):
        axis.set_yscale("log")
        axis.set_xscale("log")
        axis.set_xlabel(xlabel)
        axis.set_ylabel("unshot fraction of emitted power")
        axis.grid(True, which="both", alpha=0.3)
    by_seconds.legend(fontsize=7)
    figure.suptitle("Cornell box: unshot energy against shots and time", fontsize=10)
    figure.tight_layout()
    figure.savefig(RESULTS / "convergence.png", dpi=110)


def equal_error():
    """Speed against error of each bench_equal_error.py run with --variant: debiased relative
    RMS against seconds, Cycles and every Luxel variant, one panel per set of objects."""
    for path in sorted(RESULTS.glob("equal-error-*.json")):
        run = json.loads(path.read_text())
        sets = {label: entry for label, entry in run.get("sets", {}).items()
                if "variants" in entry}
        if not sets:
            continue
        figure, axes = plt.subplots(1, len(sets), figsize=(5.5 * len(sets), 4.2), squeeze=False)
        for axis, (label, entry) in zip(axes[0], sets.items()):
            curves = [(f"Cycles ({run['device']['cycles']})", entry["cycles"])]
            curves.append((f"Luxel, defaults ({short_device(run['device']['luxel'])})",
                           entry["luxel"]))
            curves += [(f"Luxel, {spec}", variant["luxel"])
                       for spec, variant in entry["variants"].items()]
            for name, points in curves:
                axis.plot([p["seconds"] for p in points],
                          [max(p["rel_rms_debiased"], 1e-4) for p in points], marker=".",
                          label=name)
            for target in (0.05, 0.02, 0.01):
                axis.axhline(target, color="grey", linewidth=0.6, linestyle=":")
            axis.set_xscale("log")
            axis.set_yscale("log")
            axis.set_xlabel("seconds")
            axis.set_ylabel("relative RMS against the reference (debiased)")
            axis.set_title(f"{run['scene']}, {label}", fontsize=9)
            axis.grid(True, which="both", alpha=0.3)
            axis.legend(fontsize=7)
        figure.tight_layout()
        figure.savefig(path.with_suffix(".png"), dpi=110)


def row_label(row):
    return f"{SUBDIVISION_NAMES[row['subdivision']]} {row['level']}/{row['size']}"


def projections():
    """Table 2 as a figure: RMS against time for every row and hemisphere projection, one panel
    per scene; a second line of panels against Cycles when the run had it."""
    for path in sorted(RESULTS.glob("projections-*.json")):
        run = json.loads(path.read_text())
        scenes = run["scenes"]
        references = [("RMS against the hemicube", "rms", ("HEMISPHERE", "NONLINEAR"))]
        if run["cycles"]:
            references.append(("RMS against Cycles", "cycles_rms",
                               ("HEMICUBE", "HEMISPHERE", "NONLINEAR")))
        figure, axes = plt.subplots(len(references), len(scenes), squeeze=False,
                                    figsize=(6.0 * len(scenes), 4.6 * len(references)))
        markers = {"HEMICUBE": "s", "HEMISPHERE": "o", "NONLINEAR": "^"}
        for column, (name, scene) in enumerate(scenes.items()):
            for line, (ylabel, key, projections_shown) in enumerate(references):
                axis = axes[line][column]
                for index, row in enumerate(scene["rows"]):
                    colour = f"C{index}"
                    for projection in projections_shown:
                        entry = row["runs"][projection]
                        axis.scatter(entry["seconds"], entry[key], color=colour,
                                     marker=markers[projection],
                                     label=row_label(row) if projection == projections_shown[0]
                                     else None)
                for projection in projections_shown:   # marker legend entries
                    axis.scatter([], [], color="black", marker=markers[projection],
                                 label=PROJECTION_NAMES[projection])
                axis.set_xscale("log")
                axis.set_yscale("log", nonpositive="mask")
                axis.set_xlabel("seconds to the threshold (create, shoot, read back)")
                axis.set_ylabel(ylabel)
                axis.set_title(f"{name} (type level/size)", fontsize=9)
                axis.grid(True, which="both", alpha=0.3)
                axis.legend(fontsize=7, ncol=2)
        figure.suptitle(f"{short_device(run['device'])}: Table 2, unshot threshold "
                        f"{run['threshold']}, sizes x {run['size_scale']}", fontsize=10)
        figure.tight_layout()
        figure.savefig(RESULTS / f"{path.stem}.png", dpi=110)


def projection_convergence():
    """Figure 6: unshot fraction against shots, per projection (and device)."""
    runs = [json.loads(path.read_text())
            for path in sorted(RESULTS.glob("projection-convergence-*.json"))]
    if not runs:
        return
    figure, axis = plt.subplots(figsize=(7, 4.4))
    for run in runs:
        for entry in run["runs"]:
            label = (f"{short_device(run['device'])}, {run['scene']}, "
                     f"{PROJECTION_NAMES[entry['projection']]}: {entry['shots']} shots, "
                     f"{entry['seconds']:.1f} s")
            axis.plot(range(len(entry["unshot"])), entry["unshot"], label=label)
    axis.set_yscale("log")
    axis.set_xlabel("shots")
    axis.set_ylabel("unshot fraction of emitted power")
    axis.grid(True, which="both", alpha=0.3)
    axis.legend(fontsize=7)
    axis.set_title("Convergence with the hemicube and the hemisphere projection, "
                   "no subdivision", fontsize=10)
    figure.tight_layout()
    figure.savefig(RESULTS / "projection-convergence.png", dpi=110)


def table2_markdown(path):
    """The paper's Table 2 from one bench_projections.py run, one Markdown table per scene."""
    run = json.loads(Path(path).read_text())
    lines = []

    def rms(entry, key):
        return f"{entry[key]:.4g} ({entry['relative_' + key]:.2%})"

    for name, scene in run["scenes"].items():
        side = scene["reference_quad_side"]
        lines.append(f"**{name}** ({scene['triangles']} triangles; a size s is s x "
                     f"{run['size_scale']:g} texels across the {side:.3g} m reference quad; "
                     f"unshot threshold {run['threshold']:g})")
        lines.append("")
        header = ["type", "level", "size", "texels", "hemicube t [s]", "shots",
                  "hemisphere RMS (rel.)", "t [s]", "shots", "non-linear RMS (rel.)", "t [s]",
                  "shots"]
        if run["cycles"]:
            header.append("RMS vs Cycles: hemicube / hemisphere / non-linear")
        lines.append("| " + " | ".join(header) + " |")
        lines.append("| --- | ---: | ---: |" + " ---: |" * (len(header) - 3))
        for row in scene["rows"]:
            cube, sphere, nonlinear = (row["runs"][p]
                                       for p in ("HEMICUBE", "HEMISPHERE", "NONLINEAR"))
            cells = [SUBDIVISION_NAMES[row["subdivision"]], row["level"], row["size"],
                     f"{cube['texels']:,}", f"{cube['seconds']:.2f}", cube["shots"],
                     rms(sphere, "rms"), f"{sphere['seconds']:.2f}", sphere["shots"],
                     rms(nonlinear, "rms"), f"{nonlinear['seconds']:.2f}", nonlinear["shots"]]
            if run["cycles"]:
                cells.append(" / ".join(f"{entry['cycles_rms']:.4g}"
                                        for entry in (cube, sphere, nonlinear)))
            lines.append("| " + " | ".join(str(cell) for cell in cells) + " |")
        lines.append("")
    print("\n".join(lines))


def table1():
    """The paper's Figure 1 on our scenes: per-step time of every scene and size (hemicube)."""
    for path in sorted(RESULTS.glob("table1-*.json")):
        run = json.loads(path.read_text())
        # Cycles' Table 1 runs (table1-cycles-*) have no projections: not this figure's.
        rows = [row for row in run["rows"] if row.get("projection") == "HEMICUBE"]
        if not rows:
            continue
        figure, axis = plt.subplots(figsize=(10, 4.4))
        labels = [f"{row['scene']}\n{row['size']}\n{row['texels'] / 1e6:.2f} M" for row in rows]
        bottom = [0.0] * len(rows)
        for phase in PHASES:
            values = [row["phases"][phase] for row in rows]
            axis.bar(range(len(rows)), values, bottom=bottom, label=phase)
            bottom = [b + v for b, v in zip(bottom, values)]
        axis.set_xticks(range(len(rows)), labels, fontsize=7)
        axis.set_ylabel("seconds (GPU synced after each phase)")
        axis.set_title(f"{short_device(run['device'])}: per-step time, hemicube "
                       f"{run['hemicube_resolution']}, the paper's shots per scene", fontsize=9)
        axis.legend(fontsize=8)
        figure.tight_layout()
        figure.savefig(RESULTS / f"{path.stem}.png", dpi=110)


def table1_markdown(path):
    run = json.loads(path.read_text())
    print(f"{run['device']}\n")
    print("| scene | size | triangles | texels (paper) | shots | hemicube s | hemisphere s | "
          "non-linear s | of it: atlas s | shots s |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    groups = {}
    for row in run["rows"]:
        groups.setdefault((row["scene"], row["size"]), {})[row["projection"]] = row
    for (scene, size), by_projection in groups.items():
        cube = by_projection["HEMICUBE"]
        solve = sum(cube["phases"][p] for p in ("selection", "visibility", "receivers"))
        cells = [scene, size, f"{cube['triangles']:,}",
                 f"{cube['texels']:,} ({cube['paper_elements']:,})", cube["shots"]]
        cells += [f"{by_projection[p]['seconds']:.3f}" if p in by_projection else ""
                  for p in ("HEMICUBE", "HEMISPHERE", "NONLINEAR")]
        cells.append(f"{cube['atlas_seconds']:.3f}" if "atlas_seconds" in cube else "")
        cells.append(f"{solve:.3f}")
        print("| " + " | ".join(str(c) for c in cells) + " |")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--table2", type=Path, metavar="PROJECTIONS_JSON",
                        help="print this bench_projections.py result as Markdown tables")
    parser.add_argument("--table1", type=Path, metavar="TABLE1_JSON",
                        help="print this bench_table1.py result as a Markdown table")
    args = parser.parse_args()
    if args.table2:
        table2_markdown(args.table2)
    elif args.table1:
        table1_markdown(args.table1)
    else:
        breakdown()
        convergence()
        projections()
        projection_convergence()
        table1()
        equal_error()
