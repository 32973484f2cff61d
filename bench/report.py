"""BENCHMARKS.md's tables and bench/results/STUDY.png from bench/results/STUDY.json:

    python bench/report.py [--results DIR] [--markdown FILE]

Every table sits in the Markdown between `<!-- bench:STUDY begin -->` and
`<!-- bench:STUDY end -->`, each on a line of its own; the lines between them are replaced,
everything else is left as it is. A marker whose study has no result file is left alone, with
a warning. The summary (`bench:summary`) is built from the other studies' files. A study's
table shows each device's run, the GPU's first, under a line naming the device, date, commit
and command."""
import argparse
import json
from pathlib import Path
import re
import sys

import common  # puts the repository on the path
from native.memory import BYTES_PER_TEXEL  # noqa: E402

RESULTS = common.RESULTS
MARKDOWN = common.ROOT / "BENCHMARKS.md"
MARKER = re.compile(r"^<!-- bench:(?P<study>[\w-]+) (?P<end>begin|end) -->$")
DEVICE_ORDER = ("gpu", "cpu")
PROJECTIONS = {"HEMICUBE": "hemicube", "HEMISPHERE": "hemisphere",
               "NONLINEAR": "non-linear"}
SUBDIVISIONS = {"NONE": "no", "ADAPTIVE": "adapt", "REGULAR": "reg"}    # as in Table 2
SHOWN_PHASES = ("preprocess", "selection", "visibility", "receivers", "postprocess")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--results", type=Path, default=RESULTS)
    parser.add_argument("--markdown", type=Path, default=MARKDOWN)
    args = parser.parse_args()
    studies = read_studies(args.results)
    text = args.markdown.read_text()
    args.markdown.write_text(fill_markers(text, studies))
    print(f"wrote {args.markdown}")
    plot_all(studies, args.results)


def read_studies(folder):
    """{study: {device: run}} from every STUDY.json written by bench/common.py."""
    studies = {}
    for path in sorted(folder.glob("*.json")):
        data = json.loads(path.read_text())
        if isinstance(data, dict) and "runs" in data and "study" in data:
            studies[path.stem] = {device: data["runs"][device] for device in DEVICE_ORDER
                                  if device in data["runs"]}
        else:
            warn(f"{path.name} is not a study's result file: skipped")
    return studies


def warn(message):
    print(f"report: warning: {message}", file=sys.stderr)


def fill_markers(text, studies):
    """The Markdown with the lines between each study's markers made again."""
    lines, out, open_study = text.split("\n"), [], None
    for number, line in enumerate(lines, 1):
        marker = MARKER.match(line.strip())
        if marker and marker["end"] == "begin":
            if open_study is not None:
                raise SystemExit(f"line {number}: bench:{marker['study']} begins inside "
                                 f"bench:{open_study}")
            open_study, kept = marker["study"], []
            out.append(line)
            continue
        if marker and marker["end"] == "end":
            if marker["study"] != open_study:
                raise SystemExit(f"line {number}: bench:{marker['study']} ends, "
                                 f"bench:{open_study} was open")
            made = study_block(open_study, studies)
            out.extend(kept if made is None else made)
            out.append(line)
            open_study = None
            continue
        (kept if open_study is not None else out).append(line)
    if open_study is not None:
        raise SystemExit(f"bench:{open_study} never ends")
    return "\n".join(out)


def study_block(study, studies):
    """The Markdown lines of one study's marker pair, or None to keep what is there."""
    if study == "summary":
        return summary_lines(studies)
    if study not in TABLES:
        warn(f"bench:{study}: no table is made for this study; left as it is")
        return None
    if study not in studies:
        warn(f"bench:{study}: no {study}.json among the results; left as it is")
        return None
    lines = []
    for run in studies[study].values():
        try:
            made = TABLES[study](run["results"])
        except (KeyError, TypeError, ValueError, ZeroDivisionError) as error:
            warn(f"bench:{study}: its {short_device(run)} results do not make a table "
                 f"({error!r}); left as it is")
            return None
        lines += ([""] if lines else []) + [caption(run), ""] + made
    return lines


def caption(run):
    """The line over a run's table: device, date, commit, minutes taken, command."""
    minutes = f", {run['wall_seconds'] / 60:.1f} min" if run.get("wall_seconds") else ""
    quick = ", quick sizes" if run.get("quick") else ""
    return (f"**{short_device(run)}**, {run['date']}, {run['commit']}{minutes}{quick} "
            f"(`{run['command']}`):")


def short_device(run):
    device = run["device"]
    if "llvmpipe" in device:
        return f"llvmpipe, {run.get('cpu_cores', 2)}-core CPU"
    return device.split("/")[0].strip()


# ------------------------------------------------------------------------ formatting
def table(header, rows, align=None):
    """A Markdown table; ``align`` a string of "l" and "r" per column (default: the first
    left, the rest right)."""
    align = align or "l" + "r" * (len(header) - 1)
    assert len(align) == len(header), (header, align)
    rule = ["---" if a == "l" else "---:" for a in align]
    return ["| " + " | ".join(header) + " |", "| " + " | ".join(rule) + " |"] + [
        "| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]


def count(value):
    """A count with thousands separators."""
    return "" if value is None else f"{int(round(value)):,}"


def in_seconds(value, digits=3):
    """Seconds, ``digits`` significant figures."""
    return "" if value is None else f"{value:.{digits}g} s" if value < 1000 else f"{value:,.0f} s"


def rounded(texels):
    """A texel count to two figures: 12 k, 1.1 M."""
    value, unit = (texels / 1e6, "M") if texels >= 1e6 else (texels / 1e3, "k")
    return f"{float(f'{value:.2g}'):g} {unit}"


def percent(value, digits=2):
    return "" if value is None else f"{100 * value:.{digits}f} %"


def times(value, digits=3):
    return "" if value is None else f"{value:.{digits}g}x"


# ------------------------------------------------------------------------ the paper's
def table1_lines(results):
    groups = {}
    for row in results["rows"]:
        groups.setdefault((row["scene"], row["size"]), {})[row["projection"]] = row
    rows = []
    for (scene, size), by_projection in groups.items():
        first = by_projection.get("HEMICUBE") or next(iter(by_projection.values()))
        shots_seconds = sum(first["phases"][p] for p in ("selection", "visibility", "receivers"))
        paper = first.get("paper_seconds")
        scale = first.get("element_scale", 1.0)
        elements = count(first["paper_elements"]) + (f" x {scale:g}" if scale != 1.0 else "")
        rows.append([scene, size, count(first["triangles"]),
                     f"{count(first['texels'])} ({elements})", first["shots"],
                     *(f"{by_projection[p]['seconds']:.3f}" if p in by_projection else ""
                       for p in PROJECTIONS),
                     f"{first['atlas_seconds']:.3f}", f"{shots_seconds:.3f}",
                     f"{paper[0]} / {paper[1]}" if paper else ""])
    return table(["scene", "size", "triangles", "texels (paper's elements)", "shots",
                  "hemicube s", "hemisphere s", "non-linear s", "of it: atlas s",
                  "shots s (synced)", "paper, GeForce 8800GTS: cube / non-linear s"], rows,
                 "llrrrrrrrrr")


def table1_cycles_lines(results):
    rows = [[f"{row['scene']}, {row['size']}", count(row["texels"]), row["shots"],
             f"{row['luxel_seconds']:.2f}", f"{row['cycles_seconds']:.2f}",
             f"{row['speed_up']:.2f}", f"{row['paper_cpu_seconds']}"]
            for row in results["rows"]]
    samples = results["rows"][0]["cycles_samples"] if results["rows"] else ""
    return table(["scene, size", "texels", "Luxel's shots", "Luxel s (whole bake)",
                  f"Cycles s ({samples} samples)", "Cycles / Luxel",
                  "paper's CPU solver s"], rows)


def figure1_lines(results):
    rows = []
    for row in results["rows"]:
        rows.append([count(row["texels"]), row["shooters_per_selection"],
                     "x".join(map(str, row["atlas"])), f"{row['gpu_memory_mib']:.0f}",
                     *(f"{1000 * row['phases'][p]:.1f}" for p in SHOWN_PHASES),
                     f"{1000 * row['profiled_seconds']:.0f}", f"{1000 * row['seconds']:.0f}",
                     f"{row['shots_per_second']:,.0f}"])
    return table(["texels", "shooters per selection", "atlas", "GPU MiB",
                  *(f"{p} ms" for p in SHOWN_PHASES), "synced ms", "plain ms", "shots/s"],
                 rows, "r" * 12)


def table2_lines(results):
    lines = []
    for name, scene in results["scenes"].items():
        threshold = scene.get("threshold", results["threshold"])
        lines += [f"**{name}** ({count(scene['triangles'])} triangles; a size s is s x "
                  f"{results['size_scale']:g} texels across the {scene['reference_quad_side']:.3g}"
                  f" m reference quad; unshot threshold {threshold:g})", ""]
        rows = []
        for row in scene["rows"]:
            cells = [SUBDIVISIONS[row["subdivision"]], row["level"], row["size"],
                     count(row["runs"]["HEMICUBE"]["texels"])]
            for projection in PROJECTIONS:
                run = row["runs"].get(projection)
                if run is None:
                    cells += ["", "", ""] if projection != "HEMICUBE" else ["", ""]
                    continue
                if projection != "HEMICUBE":
                    cells.append(f"{run['rms']:.4g} ({percent(run['relative_rms'])})")
                cells += [f"{run['seconds']:.2f}", count(run["shots"])]
            rows.append(cells)
        lines += table(["type", "level", "size", "texels", "hemicube s", "shots",
                        "hemisphere RMS (rel.)", "s", "shots", "non-linear RMS (rel.)", "s",
                        "shots"], rows, "lrrrrrrrrrrr") + [""]
    return lines[:-1]


def figure6_lines(results):
    rows = [[PROJECTIONS[run["projection"]], count(run["texels"]), count(run["shots"]),
             f"{run['seconds']:.1f}", percent(run["unshot_fraction"])]
            for run in results["runs"]]
    lines = table(["projection", "texels", "shots", "seconds",
                   "unshot at the end"], rows, "lrrrr")
    levels = results.get("levels")
    if levels:
        rows = [[level["level"], count(level["texels"]), count(level["shots"]),
                 f"{level['seconds']:.2f}"] for level in levels["runs"]]
        lines += ["", f"Per shooting level, the Cornell box at {levels['density']:g} texels/m "
                  f"to {percent(levels['threshold'], 0)} unshot:", ""]
        lines += table(["shooting level", "texels", "shots", "seconds"], rows, "rrrr")
    return lines


# ---------------------------------------------------------------- against Cycles
def curve_end(points, unit):
    last = points[-1]
    return (f"{percent(last['rel_rms_debiased'])} at {count(last[unit])} {unit} "
            f"({last['seconds']:.1f} s)")


def equal_error_lines(results):
    rows = []
    for scene in results["scenes"]:
        reached = {entry["target"]: entry for entry in scene["times_to"]}
        cells = [scene["scene"], f"{scene['density']:g}", count(scene["texels"])]
        cells += [in_seconds(reached[t]["luxel_seconds"]) or "not reached"
                  for t in results["targets"]]
        cells.append(curve_end(scene["luxel"], "shots"))
        cells += [in_seconds(reached[t]["cycles_seconds"]) or "not reached"
                  for t in results["targets"]]
        cells.append(curve_end(scene["cycles"], "samples"))
        speed_up = reached[0.02]["cycles_over_luxel"]
        cells.append(times(speed_up) if speed_up else "-")
        rows.append(cells)
    lines = table(["scene", "texels/m", "texels", "Luxel 5 %", "Luxel 2 %", "Luxel 1 %",
                   "Luxel at the end", "Cycles 5 %", "Cycles 2 %", "Cycles 1 %",
                   "Cycles at the end", "2 %: Cycles / Luxel"], rows, "lrrrrrlrrrlr")
    surface_rows = []
    for scene in results["scenes"]:
        if "times_to_surface" not in scene:
            continue
        reached = {entry["target"]: entry for entry in scene["times_to_surface"]}
        cells = [scene["scene"], f"{scene['density']:g}", count(scene["surface_points"])]
        for who in ("luxel", "cycles"):
            cells += [in_seconds(reached[t][f"{who}_seconds"]) or "not reached"
                      for t in results["targets"]]
            cells.append(percent(scene[who][-1]["surface_rel_rms_debiased"], 1))
        speed_up = reached[0.02]["cycles_over_luxel"]
        cells.append(times(speed_up) if speed_up else "-")
        surface_rows.append(cells)
    if surface_rows:
        lines += ["", f"At points on the surfaces, {surface_inset(results)} or more inside "
                  "their charts' borders, each lightmap filtered as a renderer reads it:", ""]
        lines += table(["scene", "texels/m", "points", "Luxel 5 %", "Luxel 2 %", "Luxel 1 %",
                        "Luxel at the end", "Cycles 5 %", "Cycles 2 %", "Cycles 1 %",
                        "Cycles at the end", "2 %: Cycles / Luxel"], surface_rows,
                       "lrrrrrrrrrrr")
    return lines


def surface_inset(results):
    return f"{100 * results['scenes'][0]['surface_inset']:g} cm"


def cornell_defaults_lines(results):
    rows = []
    for name, run in results["runs"].items():
        ratios = [v for entry in run["objects"].values() for v in entry["mean_ratio_rgb"]]
        ledger = run["ledger_share"]
        rows.append([name, count(run["shots"]), f"{run['seconds']:.1f}",
                     percent(run["relative_rms_less_noise"]),
                     f"{min(ratios):.4f}-{max(ratios):.4f}",
                     f"{ledger['absorbed']:.3f}, {ledger['escaped']:.3f}, "
                     f"{ledger['unshot']:.3f}"])
    lines = [f"{count(results['texels'])} texels at {results['density']:g} texels/m, "
             f"{count(results['compared'])} compared; Cycles 2 x {results['samples']} samples, "
             f"{sum(results['cycles_seconds']):.1f} s.", ""]
    return lines + table(["run", "shots", "seconds", "relative RMS less Cycles' noise",
                          "objects' means / Cycles', all channels",
                          "ledger: absorbed, escaped, unshot"], rows, "lrrrll")


def interior_lines(results):
    rows = []
    for run in results["runs"]:
        worst = max((entry for entry in run["objects"] if entry["ratio"] is not None),
                    key=lambda entry: abs(entry["ratio"] - 1.0))
        rows.append([f"{run['blend']}, {run['materials']} materials", f"{run['density']:g}",
                     count(run["triangles"]), count(run["texels"]), count(run["shots"]),
                     f"{run['bake_seconds']:.1f}",
                     f"{run['within_3_percent']} / {run['within_5_percent']} of {run['copies']}",
                     f"{worst['object']} {worst['ratio']:.3f}", percent(run["area_shown"], 1),
                     f"{run['cycles_seconds']:.0f}"])
    return table(["scene, materials", "texels/m", "triangles", "texels", "shots", "bake s",
                  "copies within 3 % / 5 % of Cycles' mean", "farthest copy: Luxel / Cycles",
                  "rendered area with a lightmap",
                  f"Cycles s ({results['cycles_samples']} samples, "
                  f"{results['cycles_supersample']}^2 sub-texels)"], rows, "lrrrrrrlrr")


def materials_lines(results):
    rows = [[row["scene"], count(row["triangles"]), f"{row['density']:g}",
             count(row["page_texels"]),
             row["mesh_copies"], f"{row['median_seconds']:.2f}"] for row in results["scenes"]]
    repeats = len(results["scenes"][0]["seconds"]) if results["scenes"] else 0
    return table(["scene", "triangles", "texels/m", "page texels", "mesh copies",
                  f"seconds (median of {repeats})"], rows)


def glossy_furnace_lines(results):
    rows = []
    for row in results["rows"]:
        rows.append([row["material"],
                     f"{row['diffuse_normal']:.4f} + {row['glossy_normal']:.4f} = "
                     f"{row['luxel']:.4f}",
                     f"{row['diffuse_white_sky']:.4f} + {row['glossy_white_sky']:.4f} = "
                     f"{row['white_sky']:.4f}", f"{row['luxel'] / row['white_sky']:.4f}",
                     " / ".join(f"{value:.3f}" for value in row["glossy_at"].values())])
    return table(["Principled BSDF (base 0.8, Specular IOR Level 0.5, roughness 0.5 unless "
                  "said)", "diffuse + glossy, normal (Luxel)", "white sky",
                  "Luxel / white sky", "glossy at cos " + " / ".join(
                      results["rows"][0]["glossy_at"]) if results["rows"] else ""], rows,
                 "lrrrl")


# ------------------------------------------------------------------------ scaling
def scaling_lines(results):
    rows = []
    for row in results["rows"]:
        label = f"{row['scene']}, {row['density']:g}" + (
            f", furniture +{row['level']} levels" if row["level"] else "")
        set_up = (row["export_seconds"] + row["materials_seconds"] + row["charting_seconds"]
                  + row["preprocess_seconds"])
        milestone = row.get("unshot_1_percent")
        times = {entry["target"]: entry for entry in row.get("times_to", [])}

        def time_cell(target, who):
            if not times:
                return "not compared"
            seconds = times[target][f"{who}_seconds"]
            return in_seconds(seconds) if seconds else "not reached"
        rows.append([label, count(row["triangles"]), count(row["texels"]),
                     f"{count(row['shots'])} ({row['stopped']})", f"{set_up:.2f}",
                     f"{row['charting_seconds']:.2f}",
                     f"{row['visibility_ms_per_shot']:.2f}",
                     f"{row['phases']['receivers']:.1f}", f"{row['bake_seconds']:.1f}",
                     in_seconds(milestone["seconds"]) if milestone else "not reached",
                     f"{row['gpu_bytes_per_texel']:.0f}", f"{row['peak_rss_mb'] / 1024:.2f}",
                     time_cell(0.02, "luxel"), time_cell(0.02, "cycles"),
                     time_cell(0.01, "luxel"), time_cell(0.01, "cycles")])
    return table(["scene, texels/m", "triangles", "texels", "shots (stopped by)", "set-up s",
                  "of it: charting s", "visibility ms per shot", "receivers s", "bake s",
                  "1 % unshot at", "GPU bytes per texel", "peak GB", "Luxel 2 %",
                  "Cycles 2 %", "Luxel 1 %", "Cycles 1 %"], rows, "lrrlrrrrrrrrrrrr")


def density_scaling_lines(results):
    rows = [[f"{row['density']:g}", count(row["texels"]), count(row["shots"]),
             percent(row["unshot_fraction"]), f"{row['seconds']:.1f}", f"{row['cpu_seconds']:.1f}",
             *(f"{row['phases'][p]:.2f}" for p in ("selection", "visibility", "receivers")),
             f"{row['cpu_ns_per_texel_per_shot']:.0f}",
             f"{row['gpu_bytes_per_texel']:.0f}"] for row in results["rows"]]
    return table(["texels/m", "texels", f"shots to {percent(results['threshold'], 1)}",
                  "unshot at the end", "wall s", "CPU s", "selection s", "visibility s",
                  "receivers s", "receivers, CPU ns per texel per shot",
                  "GPU bytes per texel"], rows)


def visibility_draw_lines(results):
    paths = {"GEOMETRY_SHADER": "geometry shader", "PER_FACE": "per face"}
    rows = []
    for scene in results["scenes"]:
        rows.append([scene["scene"], count(scene["triangles"]), f"{scene['density']:g}",
                     *(f"{1e3 * scene['medians'][path]['visibility_seconds_per_shot']:.2f} / "
                       f"{1e3 * scene['medians'][path]['visibility_cpu_seconds_per_shot']:.2f}"
                       for path in paths),
                     "yes" if scene["identical_lightmaps"] else "no"])
    return table(["scene", "triangles", "texels/m",
                  *(f"{name}: wall / CPU ms per shot" for name in paths.values()),
                  "identical lightmaps"], rows, "lrrrrl")


def charting_lines(results):
    rows = [[f"{row['level']}: {count(row['triangles'])}",
             f"{row['atlas_seconds']:.1f} / {row['atlas_cpu_seconds']:.1f}",
             f"{row['peak_rss_mb']:.0f} ({row['atlas_rss_growth_mb']:+.0f})",
             f"{count(row['texels'])} ({row['pages']} x {row['page_size'][0]} x "
             f"{row['page_size'][1]})",
             f"{row['gpu_page_size'][0]} x {row['gpu_page_size'][1]}", count(row["charts"])]
            for row in results["rows"]]
    return table(["furniture levels: triangles", "atlas s, wall / CPU",
                  "peak MB (growth in the atlas)", "texels (pages)", "GPU page", "charts"],
                 rows, "lrrrrr")


def receiver_batch_lines(results):
    groups = {}
    for bake in results["bakes"]:
        groups.setdefault((bake["scene"], bake["density"], bake["variant"]), []).append(bake)
    rows = []
    for (scene, density, variant), bakes in groups.items():
        first = bakes[0]

        def each(key, form):
            return " / ".join(form.format(bake[key]) for bake in bakes)
        rows.append([f"{scene}, {density:g}", variant, count(first["texels"]),
                     count(first["shots"]),
                     each("ns_per_texel_per_shot", "{:.0f}"),
                     each("cpu_ns_per_texel_per_shot", "{:.0f}"), each("seconds", "{:.1f}"),
                     each("cpu_seconds", "{:.1f}"), f"{first['gpu_memory_mib']:.1f}"])
    return table(["scene, texels/m", "variant", "texels", "shots",
                  "receivers ns per texel per shot, wall (each run)", "the same, CPU",
                  "bake s, wall", "bake s, CPU", "GPU MiB"], rows, "llrrrrrrr")


def set_up_lines(results):
    rows = []
    for row in results["pieces"]:
        stages = "; ".join(f"{stage}: {entry['pieces']}, {entry['longest_seconds']:.2f} s"
                           for stage, entry in row["stages"].items())
        rows.append([row["scene"], count(row["triangles"]), count(row["texels"]),
                     f"{row['set_up_seconds']:.1f}", stages,
                     f"{row['longest_piece_seconds']:.2f}"])
    return table(["scene", "triangles", "texels", "set-up s",
                  "stage: pieces, longest s", "longest wait for Esc s"], rows, "lrrrlr")


def shot_limit_lines(results):
    rows = []
    for row in results["rows"]:
        marks = row["shots_to"]
        to_one = marks.get("0.01")
        rows.append([row["scene"], f"{row['density']:g}", f"{row['blocks']:,.1f}",
                     " / ".join(count(marks.get(mark)) or "-" for mark in ("0.1", "0.05", "0.02")),
                     count(to_one) if to_one else
                     f"not in {row['seconds']:.0f} s ({count(row['shots'])} shots, "
                     f"{percent(row['unshot'], 1)})",
                     f"{to_one / row['blocks']:.1f}" if to_one else
                     f"> {row['shots'] / row['blocks']:.1f}"])
    return table(["scene", "texels/m", "blocks", "shots to 10 / 5 / 2 %", "shots to 1 %",
                  "per block"], rows, "lrrrrr")


# ------------------------------------------------------------------------ levels
def levels_lines(results):
    rows = []
    for row in results["rows"]:
        phases = row["phases"]
        solve = sum(phases[p] for p in ("receivers", "visibility", "selection")) or 1.0
        rows.append([row["level"], count(row["triangles"]), count(row["texels"]),
                     count(row["shots"]),
                     percent(row["unshot"]), f"{row['seconds']:.0f}",
                     f"{row['set_up_seconds']:.1f}",
                     " / ".join(f"{100 * phases[p] / solve:.0f}"
                                for p in ("receivers", "visibility", "selection")),
                     "yes" if row["diverged"] else "no"])
    return [f"{results['density']:g} texels/m, threshold {results['threshold']:g}:", ""] + table(
        ["level", "triangles", "texels", "shots", "unshot", "seconds", "set-up s",
         "receivers / visibility / selection %", "diverged"], rows, "lrrrrrrrl")


def level_views_lines(results):
    def shown(views):
        return "; ".join(f"{view['mean_ratio']:.3f}, {percent(view['within_10_percent'], 0)}"
                         for view in views)
    rows = []
    for row in results["rows"]:
        best = [view.get("cycles_lightmap") for view in row["views"]]
        views, best = shown(row["views"]), "-" if None in best else shown(best)
        rows.append([row["level"], count(row["texels"]), count(row["shots"]),
                     percent(row["unshot"]), f"{row['bake_seconds']:.0f}", views, best])
    lightmap = results.get("lightmap_samples", results["cycles_samples"])
    return [f"{results['density']:g} texels/m; Cycles {results['cycles_samples']} samples a "
            f"pixel at {results['resolution'][0]} x {results['resolution'][1]}, its lightmap "
            f"{lightmap} a sub-texel:", ""] + table(
        ["level", "texels", "shots", "unshot", "bake s",
         "each view: Luxel / Cycles mean, pixels within 10 %",
         "the same for Cycles' own lightmap"], rows, "lrrrrll")


TABLES = {
    "table1": table1_lines, "table1-cycles": table1_cycles_lines, "figure1": figure1_lines,
    "table2": table2_lines, "figure6": figure6_lines, "equal-error": equal_error_lines,
    "cornell-defaults": cornell_defaults_lines, "interior": interior_lines,
    "materials": materials_lines, "glossy-furnace": glossy_furnace_lines,
    "scaling": scaling_lines, "density-scaling": density_scaling_lines,
    "visibility-draw": visibility_draw_lines, "charting": charting_lines,
    "receiver-batch": receiver_batch_lines, "set-up": set_up_lines,
    "shot-limit": shot_limit_lines, "levels": levels_lines,
    "level-views": level_views_lines,
}


# ------------------------------------------------------------------------ summary
def summary_lines(studies):
    """One row per SUMMARY_ROWS entry, from the newest run of its study that has what the row
    needs (the GPU's first on a tie): rows measured on one commit when make benchmarks made
    them all."""
    rows = []
    for study, cells in SUMMARY_ROWS:
        runs = sorted(studies.get(study, {}).items(), reverse=True,
                      key=lambda item: (item[1]["date"], item[0] == "gpu"))
        made = ((row_cells(study, cells, run), run) for _, run in runs)
        made, run = next(((made, run) for made, run in made if made is not None),
                         (None, None))
        if made is not None:
            rows.append([*made, short_device(run), run["date"], run["commit"]])
    if not rows:
        warn("bench:summary: no study's results: left as it is")
        return None
    return table(["what", "number", "ratio to the anchor", "device", "date", "commit"], rows,
                 "llllll")


def row_cells(study, cells, run):
    """``cells`` of ``run``'s results, or None (with a warning where they do not fit)."""
    try:
        return cells(run["results"])
    except (KeyError, TypeError, ValueError, ZeroDivisionError, StopIteration) as error:
        warn(f"bench:summary: {study}'s {short_device(run)} results do not make "
             f"{cells.__qualname__}'s row ({error!r})")
        return None


def equal_error_row(scene_name, label, density=None):
    """The summary's row of a scene of the equal-error study (at ``density`` where it is
    measured at several)."""
    def cells(results):
        scene = next((entry for entry in results["scenes"] if entry["scene"] == scene_name
                      and density in (None, entry["density"])), None)
        if scene is None:
            return None
        # At surface points, as a renderer shows the lightmaps, where the run measured them.
        at_points = "times_to_surface" in scene
        key = "surface_rel_rms_debiased" if at_points else "rel_rms_debiased"
        times = {entry["target"]: entry
                 for entry in scene["times_to_surface" if at_points else "times_to"]}
        two = times[0.02]
        what = (f"{label}, {scene['density']:g} texels/m: time to 2 % relative RMS against "
                f"Cycles{' at surface points' if at_points else ''}")
        luxel = (in_seconds(two["luxel_seconds"]) if two["luxel_seconds"] else
                 f"not reached ({percent(scene['luxel'][-1][key], 1)} at the end)")
        cycles = (in_seconds(two["cycles_seconds"]) if two["cycles_seconds"] else
                  f"not reached ({percent(scene['cycles'][-1][key], 1)} at "
                  f"{count(scene['cycles'][-1]['samples'])} samples)")
        if two["cycles_over_luxel"]:
            anchor = f"{two['cycles_over_luxel']:.1f}x sooner than Cycles"
        elif (two["luxel_seconds"] and not two["cycles_seconds"]
              and scene["cycles"][-1]["seconds"] > two["luxel_seconds"]):
            anchor = (f"over {scene['cycles'][-1]['seconds'] / two['luxel_seconds']:.1f}x "
                      "sooner than Cycles")
        else:
            anchor = "-"
        return what, f"Luxel {luxel}, Cycles {cycles}", anchor
    return cells


def cornell_defaults_row(results):
    run = results["runs"]["defaults"]
    ratios = [v for entry in run["objects"].values() for v in entry["mean_ratio_rgb"]]
    within = sum(abs(v - 1.0) <= 0.01 for v in ratios)
    return (f"Cornell box at the defaults, {results['density']:g} texels/m: objects' means "
            "over Cycles', per channel",
            f"{min(ratios):.3f}-{max(ratios):.3f}; relative RMS "
            f"{percent(run['relative_rms_less_noise'])}",
            f"{within} of {len(ratios)} within the 1 % target")


def interior_row(materials):
    def cells(results):
        run = next((entry for entry in results["runs"] if entry["materials"] == materials
                    and entry["blend"] == "interior"), None)
        if run is None:
            return None
        kind = ("the file's materials" if materials == "file"
                else "Blender's default Principled BSDF")
        return (f"Realistic interior, {kind}: copies within 3 % of Cycles' mean",
                f"{run['within_3_percent']} of {run['copies']} (largest "
                f"{percent(run['largest_deviation'], 1)}); bake {run['bake_seconds']:.1f} s",
                f"{run['copies'] - run['within_3_percent']} copies outside the 3 % target")
    return cells


def table1_row(results):
    largest = {}
    for row in results["rows"]:
        if row["projection"] == "HEMICUBE" and row["scene"] in ("cornell_box", "office"):
            if row["texels"] > largest.get(row["scene"], {"texels": 0})["texels"]:
                largest[row["scene"]] = row
    if len(largest) < 2:
        return None
    box, office = largest["cornell_box"], largest["office"]
    return ("The paper's Table 1, whole bake at its shots: Cornell box "
            f"{rounded(box['texels'])} texels / office {rounded(office['texels'])}",
            f"{in_seconds(box['seconds'])} / {in_seconds(office['seconds'])}",
            f"{box['paper_seconds'][0] / box['seconds']:.1f}x / "
            f"{office['paper_seconds'][0] / office['seconds']:.1f}x faster than the paper's "
            "GeForce 8800GTS")


def table1_cycles_row(results):
    rows = results["rows"]
    if not rows:
        return None
    speed_ups = [row["speed_up"] for row in rows]
    return ("The paper's Table 1 at its low sizes, whole bakes through the extension",
            f"Luxel {min(row['luxel_seconds'] for row in rows):.2f} s to "
            f"{max(row['luxel_seconds'] for row in rows):.2f} s",
            f"Cycles at {rows[0]['cycles_samples']} samples takes {min(speed_ups):.2f}x to "
            f"{max(speed_ups):.2f}x as long")


def figure1_row(results):
    rows = [row for row in results["rows"]
            if row["shooters_per_selection"] == max(r["shooters_per_selection"]
                                                    for r in results["rows"])]
    small, large = rows[0], rows[-1]
    return (f"Shots per second, Cornell box, one texel a shot, {small['shooters_per_selection']}"
            " shooters per selection",
            f"{small['shots_per_second']:,.0f} at {count(small['texels'])} texels; "
            f"{large['shots_per_second']:,.0f} at {count(large['texels'])}",
            f"{small['shots_per_second'] / large['shots_per_second']:.1f}x fewer for "
            f"{large['texels'] / small['texels']:.0f}x the texels")


def table2_row(results):
    scene = results["scenes"].get("cornell_box")
    if not scene:
        return None
    row = scene["rows"][0]
    sphere, nonlinear = row["runs"]["HEMISPHERE"], row["runs"]["NONLINEAR"]
    return ("The paper's Table 2, Cornell box, no subdivision: relative RMS against the "
            "hemicube",
            f"non-linear {percent(nonlinear['relative_rms'])}, per-vertex hemisphere "
            f"{percent(sphere['relative_rms'])}",
            f"{sphere['relative_rms'] / max(nonlinear['relative_rms'], 1e-12):.1f}x lower with "
            "the non-linear projection")


def scaling_row(results):
    rows = [row for row in results["rows"] if row["scene"] == "cornell_box"
            and row.get("times_to")]
    if len(rows) < 2:
        return None
    times = [next(e for e in row["times_to"] if e["target"] == 0.02)["luxel_seconds"]
             for row in rows]
    if None in times:
        return None
    steps = [later / earlier for earlier, later in zip(times, times[1:])]
    densities = " -> ".join(f"{row['density']:g}" for row in rows)
    return (f"Cornell box, {densities} texels/m: Luxel's time to 2 %",
            " -> ".join(in_seconds(t) for t in times),
            " and ".join(f"{step:.2f}x" for step in steps)
            + " per doubling (target: at most 4.4x)")


def interior_unshot_row(results):
    row = next((row for row in results["rows"] if row["scene"] == "interior"
                and not row["level"]), None)
    if row is None:
        return None
    milestone = row["unshot_1_percent"]
    return (f"Realistic interior at its defaults ({count(row['texels'])} texels): 1 % unshot",
            f"{in_seconds(milestone['seconds'])}, {count(milestone['shots'])} shots" if milestone
            else f"not reached: {percent(row['unshot_fraction'])} after "
                 f"{row['bake_seconds']:.0f} s",
            f"visibility {row['visibility_ms_per_shot']:.2f} ms a shot")


def memory_row(results):
    """GPU memory per atlas texel: the slope between figure1's smallest and largest bakes,
    so that what does not grow with the texels (the batch's visibility map) is left out."""
    rows = sorted(results["rows"], key=lambda row: row["texels"])
    small, large = rows[0], rows[-1]
    if large["texels"] == small["texels"]:
        return None
    slope = ((large["gpu_memory_mib"] - small["gpu_memory_mib"]) * 2**20
             / (large["texels"] - small["texels"]))
    return (f"GPU memory per texel: Solver.gpu_memory_bytes' slope from {count(small['texels'])} "
            f"to {count(large['texels'])} texels",
            f"{slope:.0f} bytes ({large['gpu_memory_mib']:.0f} MiB in all at "
            f"{count(large['texels'])})",
            f"{slope / BYTES_PER_TEXEL:.2f}x the maps' {BYTES_PER_TEXEL} bytes a page "
            "texel: pages hold gutters and empty texels too")


def levels_row(results):
    rows = results["rows"]
    if not rows:
        return None
    return (f"Real levels at {results['density']:g} texels/m: unshot power left",
            "; ".join(f"{row['level']} {percent(row['unshot'])} after {count(row['shots'])} shots, "
                      f"{row['seconds']:.0f} s" for row in rows), "-")


def set_up_row(results):
    longest = max(results["pieces"], key=lambda row: row["longest_piece_seconds"])
    return ("Longest wait for Esc during a bake's set-up",
            f"{longest['longest_piece_seconds']:.1f} s ({longest['scene']}, set-up "
            f"{longest['set_up_seconds']:.1f} s)",
            f"{longest['longest_piece_seconds'] / longest['set_up_seconds']:.2f} of the "
            "whole set-up")


# (study, the function that makes the row's what, number and ratio to the anchor from its
# results, or None), at most 20.
SUMMARY_ROWS = (
    ("equal-error", equal_error_row("cornell_box", "Cornell box", density=60.0)),
    ("equal-error", equal_error_row("cornell_box", "Cornell box", density=160.0)),
    ("equal-error", equal_error_row("cornell_primitives", "Box from primitives", density=60.0)),
    ("equal-error", equal_error_row("cornell_primitives", "Box from primitives",
                                    density=160.0)),
    ("equal-error", equal_error_row("office", "Office")),
    ("equal-error", equal_error_row("living", "Living room")),
    ("cornell-defaults", cornell_defaults_row),
    ("interior", interior_row("default")),
    ("table1", table1_row),
    ("table1-cycles", table1_cycles_row),
    ("figure1", figure1_row),
    ("figure1", memory_row),
    ("table2", table2_row),
    ("scaling", scaling_row),
    ("scaling", interior_unshot_row),
    ("levels", levels_row),
    ("set-up", set_up_row),
)


# ------------------------------------------------------------------------ plots
def plot_all(studies, folder):
    try:
        import matplotlib
    except ImportError:
        warn("no matplotlib (requirements-bench.txt): no plots made")
        return
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    for study, plot in PLOTS.items():
        if study not in studies:
            continue
        figure = plot(plt, studies[study])
        path = folder / f"{study}.png"
        figure.tight_layout()
        figure.savefig(path, dpi=100)
        plt.close(figure)
        print(f"wrote {path}")


def device_axes(plt, runs, width=6.0, height=4.2):
    figure, axes = plt.subplots(1, len(runs), figsize=(width * len(runs), height),
                                squeeze=False)
    return figure, list(zip(axes[0], runs.values()))


def log_axes(axis, *, x_label, y_label, log_x=False, legend_size=7, legend_columns=1):
    """A log-scaled axis with its labels, grid and legend, as every plot here draws them."""
    if log_x:
        axis.set_xscale("log")
    axis.set_yscale("log", nonpositive="mask")
    axis.set_xlabel(x_label)
    axis.set_ylabel(y_label)
    axis.grid(True, which="both", alpha=0.3)
    axis.legend(fontsize=legend_size, ncol=legend_columns)


def stacked_phases(axis, labels, rows, scale):
    bottom = [0.0] * len(rows)
    for phase in SHOWN_PHASES:
        values = [row["phases"][phase] * scale for row in rows]
        axis.bar(range(len(rows)), values, bottom=bottom, label=phase)
        bottom = [b + v for b, v in zip(bottom, values)]
    axis.set_xticks(range(len(rows)), labels, fontsize=7)
    axis.legend(fontsize=7)


def plot_table1(plt, runs):
    figure, panels = device_axes(plt, runs, width=8.0)
    for axis, run in panels:
        rows = [row for row in run["results"]["rows"] if row["projection"] == "HEMICUBE"]
        stacked_phases(axis, [f"{r['scene']}\n{r['size']}\n{r['texels'] / 1e6:.2f} M"
                              for r in rows], rows, 1.0)
        axis.set_ylabel("seconds (GPU synced after each phase)")
        axis.set_title(f"{short_device(run)}: Table 1 per step, hemicube", fontsize=9)
    return figure


def plot_figure1(plt, runs):
    figure, panels = device_axes(plt, runs)
    for axis, run in panels:
        rows = run["results"]["rows"]
        stacked_phases(axis, [f"{r['texels'] / 1000:,.0f} k\n{r['shooters_per_selection']} "
                              "shooters" for r in rows], rows, 1000.0)
        axis.set_ylabel("milliseconds (GPU synced after each phase)")
        axis.set_title(f"{short_device(run)}: Cornell box, {run['results']['shots']} shots",
                       fontsize=9)
    return figure


def plot_table2(plt, runs):
    scenes = max((run["results"]["scenes"] for run in runs.values()), key=len)
    figure, axes = plt.subplots(len(runs), len(scenes), squeeze=False,
                                figsize=(6.0 * len(scenes), 4.4 * len(runs)))
    markers = {"HEMISPHERE": "o", "NONLINEAR": "^"}
    for line, run in enumerate(runs.values()):
        for column, (name, scene) in enumerate(run["results"]["scenes"].items()):
            axis = axes[line][column]
            for index, row in enumerate(scene["rows"]):
                for projection, marker in markers.items():
                    entry = row["runs"][projection]
                    axis.scatter(entry["seconds"], entry["relative_rms"], color=f"C{index}",
                                 marker=marker, label=(
                                     f"{SUBDIVISIONS[row['subdivision']]} {row['level']}/"
                                     f"{row['size']}" if projection == "HEMISPHERE" else None))
            for projection, marker in markers.items():
                axis.scatter([], [], color="black", marker=marker,
                             label=PROJECTIONS[projection])
            axis.set_title(f"{short_device(run)}: {name} (type level/size)", fontsize=9)
            log_axes(axis, x_label="seconds to the threshold",
                     y_label="relative RMS against the hemicube", log_x=True, legend_size=6,
                     legend_columns=2)
    return figure


def plot_figure6(plt, runs):
    figure, (by_projection, by_level) = plt.subplots(1, 2, figsize=(12, 4.4))
    for run in runs.values():
        results = run["results"]
        for entry in results["runs"]:
            by_projection.plot(range(len(entry["unshot"])), entry["unshot"],
                               label=f"{short_device(run)}, {PROJECTIONS[entry['projection']]}")
        for entry in results.get("levels", {}).get("runs", []):
            shots, _, unshot = zip(*entry["curve"])
            by_level.plot(shots, unshot, label=f"{short_device(run)}, "
                          f"{entry['texels'] / 1000:.0f} k texels, level {entry['level']}")
    by_projection.set_title("columns: unshot energy per shot (the paper's Figure 6)",
                            fontsize=9)
    by_level.set_title("Cornell box: per shooting level", fontsize=9)
    for axis in (by_projection, by_level):
        log_axes(axis, x_label="shots", y_label="unshot fraction of the emitted power")
    return figure


def plot_equal_error(plt, runs):
    names = []
    for run in runs.values():
        names += [(scene["scene"], scene["density"]) for scene in run["results"]["scenes"]
                  if (scene["scene"], scene["density"]) not in names]
    figure, axes = plt.subplots(1, len(names), figsize=(5.0 * len(names), 4.2), squeeze=False)
    for run in runs.values():
        for scene in run["results"]["scenes"]:
            axis = axes[0][names.index((scene["scene"], scene["density"]))]
            for who in ("luxel", "cycles"):
                points = scene[who]
                for key, way, style in (("rel_rms_debiased", "per texel", "-"),
                                        ("surface_rel_rms_debiased", "at points", "--")):
                    if key not in points[0]:
                        continue
                    axis.plot([p["seconds"] for p in points],
                              [max(p[key], 1e-4) for p in points], marker=".",
                              linestyle=style, color="C0" if who == "luxel" else "C1",
                              label=f"{'Luxel' if who == 'luxel' else 'Cycles'} {way}, "
                              f"{short_device(run)}")
            axis.set_title(f"{scene['scene']}, {scene['density']:g} texels/m", fontsize=9)
    for axis in axes[0]:
        for target in (0.05, 0.02, 0.01):
            axis.axhline(target, color="grey", linewidth=0.6, linestyle=":")
        log_axes(axis, x_label="seconds",
                 y_label="relative RMS against the reference (debiased)", log_x=True)
    return figure


def plot_scaling(plt, runs):
    figure, (times, visibility) = plt.subplots(1, 2, figsize=(12, 4.4))
    for run in runs.values():
        rows = run["results"]["rows"]
        compared = [row for row in rows if row.get("times_to")]
        for who in ("luxel", "cycles"):
            points = [(row["texels"], next(e for e in row["times_to"]
                                           if e["target"] == 0.02)[f"{who}_seconds"])
                      for row in compared]
            points = [(texels, seconds) for texels, seconds in points if seconds]
            if points:
                times.plot(*zip(*points), marker="o",
                           label=f"{'Luxel' if who == 'luxel' else 'Cycles'}, "
                           f"{short_device(run)}")
        visibility.plot([row["triangles"] for row in rows],
                        [row["visibility_ms_per_shot"] for row in rows], marker="o",
                        linestyle="none", label=short_device(run))
    log_axes(times, x_label="texels", y_label="seconds to 2 % relative RMS against Cycles",
             log_x=True)
    log_axes(visibility, x_label="triangles", y_label="visibility ms per shot", log_x=True)
    return figure


def plot_levels(plt, runs):
    figure, axis = plt.subplots(figsize=(7, 4.4))
    for run in runs.values():
        for row in run["results"]["rows"]:
            trace = row["trace"] + [{"shots": row["shots"], "unshot": row["unshot"]}]
            axis.plot([p["shots"] for p in trace], [p["unshot"] for p in trace],
                      label=f"{row['level']}, {short_device(run)}")
    log_axes(axis, x_label="shots", y_label="unshot fraction of the emitted power")
    return figure


PLOTS = {"table1": plot_table1, "figure1": plot_figure1, "table2": plot_table2,
         "figure6": plot_figure6, "equal-error": plot_equal_error, "scaling": plot_scaling,
         "levels": plot_levels}

if __name__ == "__main__":
    main()
