"""``blender -b scene.blend --command luxel bake|compare ...``: a headless bake, or a comparison
with Cycles, for pipelines. Progress goes to stdout; a failure prints one line to stderr and
exits non-zero."""
import argparse
from dataclasses import replace
import math
import os
import sys

import bpy

from ..native import MAX_SUBDIVISION_LEVEL, LuxelError
from .bake import BakeJob
from .compare import compare_with_cycles, summary_lines
from .properties import PROJECTIONS, SUBDIVISIONS
from .writeback import remove_lightmaps

EXIT_FAILED = 1
EXIT_USAGE = 2


class _UsageError(Exception):
    pass


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise _UsageError(message)


def _parser():
    parser = _Parser(prog="blender -b FILE.blend --command luxel",
                     description="Bake Luxel lightmaps in the background, or compare them "
                     "with Cycles.")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    bake = commands.add_parser("bake", help="bake the open .blend's scene")
    _add_bake_options(bake)
    bake.add_argument("--output", metavar="DIR", help="write EXR lightmaps into DIR")
    bake.add_argument("--preview", metavar="PNG",
                      help="render the camera view with the baked lighting (Workbench)")
    bake.add_argument("--save", action="store_true",
                      help="save the .blend with the lightmaps (packed, or linked to --output)")
    remove = commands.add_parser("remove", help="take away everything Luxel's bakes added")
    remove.add_argument("--save", action="store_true", help="save the .blend afterwards")
    compare = commands.add_parser("compare", help="bake with Luxel and with Cycles; write "
                                  "report.json, report.html and images into DIR")
    _add_bake_options(compare)
    compare.add_argument("--output", metavar="DIR", required=True, help="the report folder")
    compare.add_argument("--samples", type=int, help="Cycles samples of the reference bake")
    compare.add_argument("--view-samples", type=int, help="Cycles samples of each view")
    compare.add_argument("--views", type=int, help="views: the cameras, then automatic ones")
    compare.add_argument("--resolution", type=int, nargs=2, metavar=("W", "H"),
                         help="size of the views in pixels")
    return parser


def _add_bake_options(parser):
    parser.add_argument("--projection", choices=[item[0] for item in PROJECTIONS])
    parser.add_argument("--no-neighbour-visibility", action="store_true",
                        help="a receiver is visible only when its own visibility texel sees it")
    parser.add_argument("--subdivision", choices=[item[0] for item in SUBDIVISIONS],
                        help="texels that gather light at several points")
    parser.add_argument("--subdivision-level", type=int, metavar="N",
                        help=f"gather at 4^N points per texel, N in 1..{MAX_SUBDIVISION_LEVEL}")
    parser.add_argument("--shadow-range", type=float, nargs=2, metavar=("MIN", "MAX"),
                        help="ADAPTIVE refines triangles whose shadowed share is in [MIN, MAX]")
    parser.add_argument("--adaptive-shoot-level", action="store_true",
                        help="weak shooters shoot from coarser blocks")
    parser.add_argument("--no-ambient", action="store_true",
                        help="leave out the ambient term (the bounced light still unshot, "
                        "spread evenly)")
    parser.add_argument("--shots", type=int, help="stop after this many shots")
    parser.add_argument("--threshold", type=float, help="stop at this unshot energy fraction")
    parser.add_argument("--density", type=float, help="lightmap texels per metre")


def execute(argv):
    """The registered command; also what tests call with an argv list. Returns the exit code."""
    try:
        args = _parser().parse_args(list(argv))
        _check(args)
    except _UsageError as error:
        print(f"luxel: {error}", file=sys.stderr)
        return EXIT_USAGE
    try:
        return {"bake": _bake, "remove": _remove, "compare": _compare}[args.command](args)
    except LuxelError as error:
        print(f"luxel: {args.command} failed: {error}", file=sys.stderr)
        return EXIT_FAILED


def _check(args):
    if args.command == "remove":
        if args.save and not bpy.data.filepath:
            raise _UsageError("--save needs a .blend file: open one with blender -b FILE.blend")
        return
    if args.shots is not None and args.shots < 1:
        raise _UsageError("--shots must be 1 or more")
    if args.threshold is not None and not 0.0 <= args.threshold < 1.0:
        raise _UsageError("--threshold must be in [0, 1), e.g. 0.01")
    if args.density is not None and not 0.0 < args.density < math.inf:
        raise _UsageError("--density must be a positive number of texels per metre, e.g. 20")
    if (args.subdivision_level is not None
            and not 1 <= args.subdivision_level <= MAX_SUBDIVISION_LEVEL):
        raise _UsageError(f"--subdivision-level must be in 1..{MAX_SUBDIVISION_LEVEL}")
    if args.shadow_range is not None:
        shadow_min, shadow_max = args.shadow_range
        if not 0.0 <= shadow_min < shadow_max <= 1.0:
            raise _UsageError("--shadow-range MIN MAX must satisfy 0 <= MIN < MAX <= 1, "
                              "e.g. 0.02 0.98")
    if args.command == "bake" and args.save and not bpy.data.filepath:
        raise _UsageError("--save needs a .blend file: open one with blender -b FILE.blend")
    if args.command == "compare":
        for option, value in (("--samples", args.samples), ("--view-samples", args.view_samples),
                              ("--views", args.views)):
            if value is not None and value < 1:
                raise _UsageError(f"{option} must be 1 or more")
        if args.resolution is not None and min(args.resolution) < 16:
            raise _UsageError("--resolution W H must be at least 16 x 16 pixels")


def _apply_bake_options(args, settings):
    if args.projection:
        settings.projection = args.projection
    if args.no_neighbour_visibility:
        settings.neighbour_visibility = False
    if args.subdivision:
        settings.subdivision = args.subdivision
    if args.subdivision_level is not None:
        settings.subdivision_level = args.subdivision_level
    if args.shadow_range is not None:
        settings.subdivision_shadow_min, settings.subdivision_shadow_max = args.shadow_range
    if args.adaptive_shoot_level:
        settings.adaptive_shoot_level = True
    if args.no_ambient:
        settings.ambient = False
    if args.shots is not None:
        settings.max_shots = args.shots
    if args.threshold is not None:
        settings.threshold = args.threshold
    if args.density is not None:
        settings.texel_density = args.density


def _bake(args):
    context = bpy.context
    settings = context.scene.luxel
    _apply_bake_options(args, settings)
    if args.output:
        settings.output = 'FILES'
        settings.directory = os.path.abspath(args.output)

    job = BakeJob(context)
    for warning in job.warnings:
        print(f"luxel: warning: {warning}")
    print(f"luxel: {len(job.export.scene.triangles):,} triangles, "
          f"{job.solver.texel_count:,} texels on {job.solver.atlas.page_count} page(s)",
          flush=True)
    try:
        while not job.step(seconds=1.0):
            print(job.status(), flush=True)
    except BaseException:
        job.release()
        raise
    images = job.finish()
    stats = settings.stats
    print(f"luxel: done: {stats.texels:,} texels, {stats.shots} shots, {stats.unshot:.2f} % "
          f"unshot, {stats.seconds:.1f} s, {len(images)} image(s)", flush=True)
    if args.preview:
        render_preview(context.scene, os.path.abspath(args.preview))
        print(f"luxel: preview {args.preview}", flush=True)
    if args.save:
        bpy.ops.wm.save_mainfile()
        print(f"luxel: saved {bpy.data.filepath}", flush=True)
    return 0


def _remove(args):
    remove_lightmaps(bpy.context.scene)
    print("luxel: removed the lightmaps", flush=True)
    if args.save:
        bpy.ops.wm.save_mainfile()
        print(f"luxel: saved {bpy.data.filepath}", flush=True)
    return 0


def _compare(args):
    context = bpy.context
    _apply_bake_options(args, context.scene.luxel)
    given = {"samples": args.samples, "view_samples": args.view_samples, "views": args.views,
             "resolution": tuple(args.resolution) if args.resolution else None}
    options = replace(context.scene.luxel.comparison.options(os.path.abspath(args.output)),
                      **{name: value for name, value in given.items() if value is not None})

    def progress(fraction, text):
        print(f"luxel: compare {100.0 * fraction:3.0f} %: {text}", flush=True)

    report = compare_with_cycles(context, options, progress)
    for line in summary_lines(report):
        print(f"luxel: {line}", flush=True)
    print(f"luxel: report {os.path.join(options.directory, 'report.html')}", flush=True)
    return 0


def render_preview(scene, path):
    """Workbench render of the camera view showing the lightmaps; the scene's render and
    display settings are restored afterwards."""
    if scene.camera is None:
        raise LuxelError("the scene has no camera for the preview: add one or drop --preview")
    render, shading = scene.render, scene.display.shading
    saved = (render.engine, render.filepath, render.image_settings.file_format,
             shading.light, shading.color_type, scene.luxel.show_baked)
    try:
        render.engine = 'BLENDER_WORKBENCH'
        render.filepath = path
        render.image_settings.file_format = 'PNG'
        shading.light = 'FLAT'
        shading.color_type = 'TEXTURE'
        scene.luxel.show_baked = True
        bpy.ops.render.render(write_still=True)
    finally:
        (render.engine, render.filepath, render.image_settings.file_format,
         shading.light, shading.color_type, scene.luxel.show_baked) = saved


_command = None


def register():
    global _command
    _command = bpy.utils.register_cli_command("luxel", execute)


def unregister():
    global _command
    if _command is not None:
        bpy.utils.unregister_cli_command(_command)
        _command = None
