"""Compare with Cycles: bake with Luxel (keeping snapshots of the lightmaps at doubling shot
counts), bake a Cycles reference into the same lightmap UVs, measure the lightmap error per
object and over all (the paper's eq. 1 over occupied texels, relative RMS, maximum error),
render views both ways for Yee's metric and FLIP, time Cycles at increasing samples for its
speed-against-error curve, and write report.json, report.html and their images into a folder.

The lightmaps, UV maps and stats are written exactly as a bake writes them; everything else the
comparison changes (render settings, materials, cameras) comes back afterwards."""
from dataclasses import asdict, dataclass
import datetime
import os
import platform
import time
import tomllib

import bpy
import numpy as np

from ..native import SettingsError, write_png
from ..native.evaluation.texel_error import error_map, lightmap_error, texel_noise
from ..native.evaluation.report import speed_error_svg, write_report
from ..native.evaluation.snapshots import Snapshots
from ..native.evaluation.view_difference import compare_views, failure_image
from .bake import BakeJob
from .reference import cycles_reference, luxel_lightmap, receivers
from .views import LUXEL_VIEW_SAMPLES, render_views
from .writeback import PAGE_KEY

FOV_DEGREES = 37.0        # the paper's viewing condition for the perceptual metric
YEE_PIXEL_THRESHOLD = 0.012
ERROR_MAP_SCALE = 0.25    # white on an error map: this share of the reference's RMS radiance
CURVE_SAMPLES_STEP = 4    # Cycles' curve: 1, 4, 16, ... samples below the reference's


@dataclass
class CompareOptions:
    directory: str
    samples: int = 256            # the Cycles reference bake
    view_samples: int = 128       # the Cycles view renders
    resolution: tuple = (320, 240)
    views: int = 5
    bounces: int = 32


def compare_with_cycles(context, options, progress=None):
    """Run the comparison; returns the report (also written to options.directory).
    ``progress(fraction, text)`` is called between stages."""
    progress = progress or (lambda fraction, text: None)
    directory = _output_directory(options.directory)
    scene = context.scene

    progress(0.0, "Luxel bake")
    bake = bake_with_snapshots(context)
    targets = receivers(scene)

    progress(0.3, f"Cycles reference, {options.samples} samples")
    started = time.perf_counter()
    reference = cycles_reference(context, samples=options.samples, bounces=options.bounces)
    reference_seconds = time.perf_counter() - started
    names = [obj.name for obj in targets if obj.name in reference]
    luxel_pages = {obj.name: luxel_lightmap(obj) for obj in targets}
    overall = lightmap_error([luxel_pages[n] for n in names], [reference[n] for n in names])
    scale = ERROR_MAP_SCALE * overall.reference_rms
    objects = _object_entries(names, luxel_pages, reference, scale, directory)
    # The reference's own noise is part of any error measured against it: its floor.
    noise_squares = [(o["texels"], o["reference_noise_rms"] ** 2) for o in objects
                     if np.isfinite(o["reference_noise_rms"])]
    reference_noise = (sum(n * v for n, v in noise_squares)
                       / max(sum(n for n, _ in noise_squares), 1)) ** 0.5

    progress(0.5, "Cycles at increasing samples")
    cycles_points = cycles_curve(context, options, names, reference)
    luxel_points = bake.curve(targets, names, reference)

    progress(0.7, f"{options.views} views")
    views = render_views(context, options.views, tuple(options.resolution),
                         options.view_samples, options.bounces)
    view_entries = [_view_entry(index, view, directory) for index, view in enumerate(views)]

    progress(0.95, "report")
    curves = {"luxel": luxel_points, "cycles": cycles_points}
    # report.html draws the plot inline; the file is for taking the figure elsewhere.
    with open(os.path.join(directory, "speed_error.svg"), "w", encoding="utf-8") as figure:
        figure.write(speed_error_svg(curves))
    stats = scene.luxel.stats
    report = {
        "title": f"Luxel against Cycles: {_scene_label(scene)}",
        "scene": _scene_label(scene),
        "created": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "luxel_version": _luxel_version(),
        "blender_version": bpy.app.version_string,
        "device": {"luxel": bake.device, "cycles": f"CPU: {_cpu_name()}"},
        "settings": {"luxel": bake.settings, "cycles_samples": options.samples,
                     "view_samples": options.view_samples,
                     "luxel_view_samples": min(options.view_samples, LUXEL_VIEW_SAMPLES),
                     "resolution": list(options.resolution), "fov_degrees": FOV_DEGREES,
                     "yee_pixel_threshold": YEE_PIXEL_THRESHOLD, "error_map_scale": scale,
                     "bounces": options.bounces},
        "rms": overall.rms, "rel_rms": overall.relative_rms, "max_error": overall.max_error,
        "texels": overall.texels,
        "reference_noise_rms": reference_noise,
        "reference_noise_rel": reference_noise / overall.reference_rms,
        "flip_mean": _mean([v["flip_mean"] for v in view_entries]),
        "yee_fraction": _mean([float(v["yee_different"]) for v in view_entries]),
        "cycles_samples": options.samples, "cycles_seconds": reference_seconds,
        "luxel": {"seconds": stats.seconds, "shots": stats.shots, "texels": stats.texels,
                  "unshot": stats.unshot},
        "objects": objects,
        "views": view_entries,
        "curves": curves,
        "curve_plot": "speed_error.svg",
    }
    write_report(directory, report)
    _store_summary(scene, report, directory)
    progress(1.0, "done")
    return report


def summary_lines(report):
    """The headline numbers, as the panel and the command line show them."""
    return [f"Relative RMS {100.0 * report['rel_rms']:.2f} % (RMS {report['rms']:.4g}, "
            f"max {report['max_error']:.4g}) over {report['texels']:,} texels; the "
            f"reference's own noise {100.0 * report['reference_noise_rel']:.2f} %",
            f"FLIP mean {report['flip_mean']:.4f}; Yee: {report['yee_fraction'] * 100:.0f} % "
            f"of {len(report['views'])} views differ",
            f"Luxel {report['luxel']['seconds']:.1f} s, {report['luxel']['shots']} shots; "
            f"Cycles reference {report['cycles_samples']} samples"]


# ------------------------------------------------------------------------------ Luxel bake
class SnapshotBake:
    """A Luxel bake with its lightmaps kept at 1, 2, 4, ... shots and at the end
    (native.evaluation.snapshots), timed from the bake's start (export included, snapshots excluded)."""

    def __init__(self, job):
        self.snapshots = Snapshots(job.started)
        self.device = job.solver.ctx.info.get("GL_RENDERER", "unknown")
        self.settings = asdict(job.solver.settings)

    def curve(self, targets, names, reference, measure=None):
        """The error of each snapshot against ``reference``; ``measure`` (the pages by name
        to a dict) adds its own entries to each point."""
        page_of = {obj.name: int(obj.luxel.image[PAGE_KEY]) for obj in targets}
        points = []
        snapshots = self.snapshots
        for index, (shots, seconds) in enumerate(zip(snapshots.shots, snapshots.seconds)):
            pages = [snapshots.page(index, page_of[name]) for name in names]
            error = lightmap_error(pages, [reference[name] for name in names])
            points.append({"shots": shots, "seconds": seconds, "rms": error.rms,
                           "rel_rms": error.relative_rms,
                           "objects": _object_rel_rms(names, pages, reference),
                           **(measure(dict(zip(names, pages))) if measure else {})})
        return points


def bake_with_snapshots(context):
    job = BakeJob(context)
    try:
        job.set_up()
        bake = SnapshotBake(job)
        while job.solver.step():
            bake.snapshots.after_step(job.solver)
        bake.snapshots.take(job.solver)
    except BaseException:
        job.release()
        raise
    job.finish()
    context.scene.luxel.stats.seconds = bake.snapshots.seconds[-1]
    return bake


# ---------------------------------------------------------------------------------- Cycles
def cycles_curve(context, options, names, reference, seed=1, measure=None):
    """Cycles bakes at 1, 4, 16, ... samples (below the reference's), timed, with another
    seed than the reference so that their noise is independent; ``measure`` as in
    SnapshotBake.curve."""
    points = []
    samples = 1
    while samples * CURVE_SAMPLES_STEP <= options.samples:
        started = time.perf_counter()
        bakes = cycles_reference(context, samples=samples, bounces=options.bounces,
                                 objects=names, seed=seed)
        seconds = time.perf_counter() - started
        pages = [bakes[n] for n in names]
        error = lightmap_error(pages, [reference[n] for n in names])
        points.append({"samples": samples, "seconds": seconds, "rms": error.rms,
                       "rel_rms": error.relative_rms,
                       "objects": _object_rel_rms(names, pages, reference),
                       **(measure(dict(zip(names, pages))) if measure else {})})
        samples *= CURVE_SAMPLES_STEP
    return points


def _object_rel_rms(names, pages, reference):
    """{name: relative RMS} of each object's page against its reference."""
    errors = {}
    for name, page in zip(names, pages):
        try:
            errors[name] = lightmap_error([page], [reference[name]]).relative_rms
        except ValueError:      # no texel in common
            errors[name] = float("nan")
    return errors


# ---------------------------------------------------------------------------------- output
def _output_directory(directory):
    if not directory:
        raise SettingsError("no folder for the comparison: set one (Render properties > Luxel "
                            "Lightmaps > Compare with Cycles, or --output DIR)")
    if directory.startswith("//") and not bpy.data.filepath:
        raise SettingsError(f"the .blend is not saved, so the folder '{directory}' has no "
                            "place: save the file first or choose an absolute folder")
    path = bpy.path.abspath(directory)
    try:
        os.makedirs(os.path.join(path, "error_maps"), exist_ok=True)
        os.makedirs(os.path.join(path, "views"), exist_ok=True)
    except OSError as error:
        raise SettingsError(f"cannot write the comparison into '{path}': {error.strerror}; "
                            "choose a folder you can write to") from error
    if not os.access(path, os.W_OK):
        raise SettingsError(f"cannot write the comparison into '{path}': choose a folder you "
                            "can write to")
    return path


def _object_entries(names, luxel_pages, reference, scale, directory):
    entries = []
    for index, name in enumerate(names):
        page, cycles = luxel_pages[name], reference[name]
        try:
            error = lightmap_error([page], [cycles])
        except ValueError:      # Cycles covered no texel centre of it (a sliver)
            continue
        covered = cycles[..., 3] > 0.5
        rows, columns = np.nonzero(covered)
        crop = (slice(max(rows.min() - 2, 0), rows.max() + 3),
                slice(max(columns.min() - 2, 0), columns.max() + 3))
        image = error_map(page[crop], cycles[crop], scale)
        path = f"error_maps/{index:03d}_{_file_safe(name)}.png"
        write_png(os.path.join(directory, path), _to_rgb8(np.flipud(image[..., :3])))
        entries.append({"name": name, "texels": error.texels, "rms": error.rms,
                        "rel_rms": error.relative_rms, "max_error": error.max_error,
                        "luxel_mean": page[covered][:, :3].mean(axis=0).tolist(),
                        "cycles_mean": cycles[covered][:, :3].mean(axis=0).tolist(),
                        "reference_noise_rms": float(np.linalg.norm(texel_noise(cycles,
                                                                                covered))),
                        "error_map": path})
    return entries


def _view_entry(index, view, directory):
    comparison = compare_views(view.cycles, view.luxel, FOV_DEGREES, YEE_PIXEL_THRESHOLD)
    stem = f"views/{index + 1:02d}_{_file_safe(view.name)}"
    paths = {"cycles_image": f"{stem}_cycles.png", "luxel_image": f"{stem}_luxel.png",
             "yee_map": f"{stem}_yee.png", "flip_map": f"{stem}_flip.png"}
    write_png(os.path.join(directory, paths["cycles_image"]), comparison.reference_display)
    write_png(os.path.join(directory, paths["luxel_image"]), comparison.test_display)
    write_png(os.path.join(directory, paths["yee_map"]),
              failure_image(comparison.reference_display, comparison.yee.failed))
    write_png(os.path.join(directory, paths["flip_map"]), _to_rgb8(comparison.flip.heatmap))
    return {"name": view.name, "source": view.source, **paths,
            "yee_failed_pixels": comparison.yee.failed_pixels,
            "yee_fraction": comparison.yee.fraction,
            "yee_different": bool(comparison.yee.different),
            "flip_mean": comparison.flip.mean, "exposure": comparison.exposure}


def _store_summary(scene, report, directory):
    summary = scene.luxel.comparison
    summary.rel_rms = report["rel_rms"]
    summary.rms = report["rms"]
    summary.max_error = report["max_error"]
    summary.flip_mean = report["flip_mean"]
    summary.yee_fraction = report["yee_fraction"]
    summary.report = os.path.join(directory, "report.html")
    summary.valid = True


def _to_rgb8(image):
    return np.clip(np.round(np.asarray(image) * 255.0), 0, 255).astype(np.uint8)


def _file_safe(name):
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)[:48]


def _mean(values):
    return float(np.mean(values)) if values else float("nan")


def _scene_label(scene):
    return (f"{os.path.basename(bpy.data.filepath)} / {scene.name}" if bpy.data.filepath
            else scene.name)


def _luxel_version():
    manifest = os.path.join(os.path.dirname(os.path.dirname(__file__)),
                            "blender_manifest.toml")
    try:
        with open(manifest, "rb") as handle:
            return tomllib.load(handle)["version"]
    except (OSError, KeyError, tomllib.TOMLDecodeError):
        return "unknown"


def _cpu_name():
    name = platform.processor() or platform.machine()
    return f"{name}, {os.cpu_count()} threads"

