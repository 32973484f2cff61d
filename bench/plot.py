"""Plots for BENCHMARKS.md from bench/results/*.json.

    python bench/plot.py        # writes bench/results/core-breakdown.png
"""
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
PHASES = ("preprocess", "selection", "visibility", "receivers", "postprocess")


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
        device = run["device"].split("/")[0].replace("NVIDIA ", "").split("(")[0].strip()
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


if __name__ == "__main__":
    breakdown()
    convergence()
