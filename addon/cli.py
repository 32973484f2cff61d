"""``blender -b scene.blend --command luxel bake|compare|export|view ...``: a headless bake, a
comparison with Cycles, a glTF file with the lightmaps or a page showing it, for pipelines. Progress goes to stdout; a failure prints one line to stderr and
exits non-zero."""
import argparse
from dataclasses import replace
import os
import sys
import time

import bpy

from ..native import LuxelError
from ..native.settings import add_options, given_settings
from ..native.viewer import serve, write_viewer
from .bake import BakeJob, divergence_message, remove_lightmaps, shot_limit_message
from .compare import compare_with_cycles, summary_lines
from .gltf_export import export_gltf
from .writeback import writable

EXIT_FAILED = 1
EXIT_USAGE = 2
# The lightmaps were written, but from the bake's last checkpoint: its shots made light.
EXIT_DIVERGED = 3
# Cycles samples of --preview: enough to smooth the edges of what the lightmaps show.
PREVIEW_SAMPLES = 16


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
    add_options(bake)   # the solver's settings; one left out keeps the scene's
    bake.add_argument("--output", metavar="DIR", help="write EXR lightmaps into DIR")
    bake.add_argument("--preview", metavar="PNG",
                      help="render the camera view with the baked lighting (Cycles)")
    saving = bake.add_mutually_exclusive_group()
    saving.add_argument("--save", action="store_true",
                        help="save the .blend with the lightmaps (packed, or linked to "
                        "--output)")
    saving.add_argument("--save-as", metavar="FILE.blend",
                        help="save the baked scene as a new .blend, leaving the open one as "
                        "it was")
    export = commands.add_parser("export", help="write the baked scene as glTF, each object's "
                                 "lightmap in its material (MOZ_lightmap, TEXCOORD_1)")
    export.add_argument("--gltf", metavar="FILE.glb", required=True,
                        help="the .glb (or .gltf) file to write")
    view = commands.add_parser("view", help="export the baked scene to FILE.glb and show it "
                               "in a web page served on this computer (127.0.0.1)")
    view.add_argument("glb", metavar="FILE.glb", help="the GLB file to write and show")
    view.add_argument("--folder", metavar="DIR", help="where the page goes (default: the "
                      "GLB's name without .glb, beside it)")
    view.add_argument("--port", type=int, default=8000, help="the port to serve on (0: any)")
    view.add_argument("--no-serve", action="store_true",
                      help="write the page's folder and stop, serving nothing")
    remove = commands.add_parser("remove", help="take away everything Luxel's bakes added")
    remove.add_argument("--save", action="store_true", help="save the .blend afterwards")
    compare = commands.add_parser("compare", help="bake with Luxel and with Cycles; write "
                                  "report.json, report.html and images into DIR")
    add_options(compare)
    compare.add_argument("--output", metavar="DIR", required=True, help="the report folder")
    compare.add_argument("--samples", type=int, help="Cycles samples of the reference bake")
    compare.add_argument("--view-samples", type=int, help="Cycles samples of each view")
    compare.add_argument("--views", type=int, help="views: the cameras, then automatic ones")
    compare.add_argument("--resolution", type=int, nargs=2, metavar=("W", "H"),
                         help="size of the views in pixels")
    return parser


def execute(argv):
    """The registered command; also what tests call with an argv list. Returns the exit code."""
    try:
        args = _parser().parse_args(list(argv))
        _check(args)
    except _UsageError as error:
        print(f"luxel: {error}", file=sys.stderr)
        return EXIT_USAGE
    try:
        return {"bake": _bake, "remove": _remove, "compare": _compare, "export": _export,
                "view": _view}[args.command](args)
    except LuxelError as error:
        print(f"luxel: {args.command} failed: {error}", file=sys.stderr)
        return EXIT_FAILED


def _check(args):
    unopened = _unopened_blend(sys.argv)
    if unopened is not None:
        raise _UsageError(f"'{unopened}' did not open, and Blender went on with its startup "
                          "scene: check the path and that it is a .blend file")
    if args.command == "remove":
        if args.save and not bpy.data.filepath:
            raise _UsageError("--save needs a .blend file: open one with blender -b FILE.blend")
        return
    if args.command == "bake" and args.save and not bpy.data.filepath:
        raise _UsageError("--save needs a .blend file: open one with blender -b FILE.blend")
    if args.command == "bake" and args.save_as is not None:
        target = os.path.abspath(args.save_as)
        if not target.lower().endswith(".blend"):
            raise _UsageError(f"--save-as {args.save_as}: name a .blend file")
        if os.path.isdir(target) or not writable(os.path.dirname(target)):
            raise _UsageError(f"--save-as {args.save_as}: '{target}' cannot be written: "
                              "choose a place you may write to")
    if args.command == "compare":
        for option, value in (("--samples", args.samples), ("--view-samples", args.view_samples),
                              ("--views", args.views)):
            if value is not None and value < 1:
                raise _UsageError(f"{option} must be 1 or more")
        if args.resolution is not None and min(args.resolution) < 16:
            raise _UsageError("--resolution W H must be at least 16 x 16 pixels")


def _unopened_blend(argv):
    """The last .blend Blender's command line names before --command when no file is open
    (Blender goes on with its startup file where it cannot read one), else None."""
    if "--command" not in argv or bpy.data.filepath:
        return None
    named = [argument for argument in argv[:argv.index("--command")]
             if argument.lower().endswith(".blend")]
    return named[-1] if named else None


def _apply_bake_options(args, settings):
    for name, value in given_settings(args).items():
        setattr(settings, name, value)


def _bake(args):
    context = bpy.context
    settings = context.scene.luxel
    _apply_bake_options(args, settings)
    if args.output:
        settings.output = 'FILES'
        settings.directory = os.path.abspath(args.output)

    job = BakeJob(context)
    try:
        while not job.is_set_up:
            job.step(seconds=1.0)
            _print_warnings(job)
            if not job.is_set_up:
                print(f"luxel: {job.status()}", flush=True)
        print(f"luxel: {len(job.export.scene.triangles):,} triangles, "
              f"{job.solver.texel_count:,} texels on {job.solver.atlas.page_count} page(s)",
              flush=True)
        while not job.step(seconds=1.0):
            print(f"luxel: {job.status()}", flush=True)
    except BaseException:
        job.release()
        raise
    images = job.finish()
    stats = settings.stats
    print(f"luxel: done: {stats.texels:,} texels, {stats.shots:,} shots, {stats.unshot:.2f} % "
          f"unshot, {stats.seconds:.1f} s, {len(images)} image(s)", flush=True)
    stopped = shot_limit_message(stats, job.settings.threshold)
    if stopped:
        print(f"luxel: warning: {stopped}: raise --shots and bake again", flush=True)
    if args.preview:
        render_preview(context.scene, os.path.abspath(args.preview))
        print(f"luxel: preview {args.preview}", flush=True)
    if args.save:
        bpy.ops.wm.save_mainfile()
        print(f"luxel: saved {bpy.data.filepath}", flush=True)
    if args.save_as is not None:
        target = os.path.abspath(args.save_as)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=target, check_existing=False)
        print(f"luxel: saved {target}", flush=True)
    diverged = divergence_message(stats)
    if diverged:
        print(f"luxel: {diverged}", file=sys.stderr, flush=True)
        return EXIT_DIVERGED
    return 0


def _print_warnings(job):
    for warning in job.new_warnings():
        print(f"luxel: warning: {warning}", flush=True)


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


def _export(args):
    objects = export_gltf(bpy.context, args.gltf)
    print(f"luxel: wrote {args.gltf} with the lightmaps of {len(objects)} object(s)", flush=True)
    return 0


def _view(args):
    glb = os.path.abspath(args.glb)
    if not glb.lower().endswith(".glb"):
        raise LuxelError(f"'{args.glb}': name a .glb file for the page to show")
    export_gltf(bpy.context, glb)
    folder = os.path.abspath(args.folder or os.path.splitext(glb)[0])
    write_viewer(glb, folder)
    print(f"luxel: wrote the page {os.path.join(folder, 'index.html')}", flush=True)
    if args.no_serve:
        return 0
    server = serve(folder, port=args.port)
    print(f"luxel: serving {server.url} (Ctrl+C stops)", flush=True)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        server.shutdown()
        server.server_close()
    return 0


def render_preview(scene, path):
    """A Cycles render of the camera view with the baked lighting shown (Show Baked Lighting:
    each baked surface is its lightmap's emission, so a few samples and no bounces make it),
    as a PNG through the scene's view transform; the scene's settings are restored after.
    Cycles runs on the CPU, with no depth buffer for a lamp drawn in the ceiling to fight."""
    if scene.camera is None:
        raise LuxelError("the scene has no camera for the preview: add one or drop --preview")
    render, cycles = scene.render, scene.cycles
    kept = {(render, "engine"): 'CYCLES', (render, "filepath"): path,
            (render.image_settings, "file_format"): 'PNG', (cycles, "device"): 'CPU',
            (cycles, "samples"): PREVIEW_SAMPLES, (cycles, "use_adaptive_sampling"): False,
            (cycles, "use_denoising"): False, (cycles, "max_bounces"): 0,
            (scene.luxel, "show_baked"): True}
    saved = {key: getattr(*key) for key in kept}
    try:
        for (owner, name), value in kept.items():
            setattr(owner, name, value)
        bpy.ops.render.render(write_still=True)
    finally:
        for (owner, name), value in saved.items():
            setattr(owner, name, value)


_command = None


def register():
    global _command
    _command = bpy.utils.register_cli_command("luxel", execute)


def unregister():
    global _command
    if _command is not None:
        bpy.utils.unregister_cli_command(_command)
        _command = None
