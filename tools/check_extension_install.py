"""Validates an extension zip as `blender --command extension validate` does, installs it into a
fresh Blender user profile through the bpy module, as the preferences' "Install from Disk" does,
then checks that Luxel enables, that its dependencies load from the zip's wheels, that the solver
gets an OpenGL context and that `bpy.ops.luxel.bake()` bakes a small lit room, or with
--cornell-box the Cornell box (as sample_blends/generate.py builds it, plus a Bevel modifier on
the short block), each object's mean within 5 % of a Cycles bake by the same Blender
(addon/reference.py of the installed zip).

    python tools/check_extension_install.py [--cornell-box] dist/luxel-<version>.zip

The check runs in a child process with an empty user profile (BLENDER_USER_RESOURCES). The
bundled packages (moderngl, glcontext, xatlas, OpenEXR) must be importable there only from the
site-packages into which Blender extracts the zip's wheels. Two modes, chosen automatically:

- Isolated, when this Python can import a bundled package, such as the development venv (`make
  test` installs bpy and the solver's dependencies into .venv): the child runs as `python -S`,
  without site-packages, with PYTHONPATH set to a temporary folder of symlinks to bpy and the
  distributions it requires, recursively (by importlib.metadata, dist-info folders included).
  Blender's startup (addon_utils._initialize_extensions_site_packages) puts the extension
  site-packages on sys.path itself, `site` or not, so nothing is added by hand.
- Plain, when this Python has bpy (and its requirements) but none of the bundled packages: the
  child runs with this Python's own paths.

In both modes the child first checks that no bundled package is importable before the install.
Exits non-zero with the reason on failure.
"""
import argparse
import importlib
import importlib.metadata
import importlib.util
import os
from pathlib import Path
import re
import subprocess
import sys
import tempfile
import time

ROOT = Path(__file__).resolve().parent.parent
REPO = "user_default"
PACKAGE = f"bl_ext.{REPO}.luxel"
BUNDLED = ("moderngl", "glcontext", "xatlas", "OpenEXR", "flip_evaluator")
# The Cornell box: Luxel's texels per metre (at 20 Luxel's ceiling, 0.1 mm over the light, is
# 0.82 of Cycles', from 30 on within 5 %) and stopping threshold; Cycles' samples and bounces.
# Cycles' noise on an object mean at 512 samples: 0.5-0.9 % on the light's 30 texels, at most
# 0.2 % elsewhere; at 256, Blender 5.0 put Luxel's light at 0.942 of Cycles' (at 1024: 0.987).
CORNELL_DENSITY = 40.0
CORNELL_THRESHOLD = 0.01
CYCLES_SAMPLES = 512
CYCLES_BOUNCES = 32
TOLERANCE = 0.05  # of Cycles' mean, per RGB channel


def fail(reason):
    sys.exit(f"extension check failed: {reason}")


def validate_strictly(zip_path):
    """Blender's own strict manifest check, which installing skips: it also limits lengths, such
    as 64 characters for the tagline, and takes only Blender's own tags. The handler of
    `blender --command extension validate` (in the bundled bl_pkg add-on), which prints why."""
    from bl_pkg.bl_extension_cli import cli_extension_handler
    if cli_extension_handler(["validate", str(zip_path)]) != 0:
        fail("Blender's validator rejects the zip (its reasons above)")


def build_room(bpy):
    """An empty scene holding a closed 4 x 4 x 3 m box with inward faces, a 300 W point light
    inside and a black world (a new world's node tree lights the scene grey)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    corners = [(x, y, z) for z in (0.0, 3.0) for x, y in ((-2, -2), (2, -2), (2, 2), (-2, 2))]
    outward = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    mesh = bpy.data.meshes.new("Room")
    mesh.from_pydata(corners, [], [face[::-1] for face in outward])
    room = bpy.data.objects.new("Room", mesh)
    scene.collection.objects.link(room)
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", 'POINT'))
    lamp.data.energy = 300.0
    lamp.location = (0.0, 0.0, 2.0)
    scene.collection.objects.link(lamp)
    scene.world = bpy.data.worlds.new("Black")
    if scene.world.node_tree is None:  # Blender before 5.0 creates it on use_nodes
        scene.world.use_nodes = True
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    return room


def build_cornell_box(bpy):
    """The Cornell box of sample_blends/cornell_box.blend, built by the script that made it (a
    file saved by Blender 5.0 does not open in 4.2)."""
    spec = importlib.util.spec_from_file_location("generate",
                                                  ROOT / "sample_blends" / "generate.py")
    generate = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(generate)
    generate.build_cornell_box()
    return [obj.name for obj in bpy.context.scene.objects if obj.type == 'MESH']


def bake_cornell_box(bpy, meshes):
    """Luxel's bake, then a Cycles DIFFUSE bake (direct + indirect + colour) into the same UVs;
    every mesh's mean within TOLERANCE of Cycles' in each channel. The short block gets a
    Bevel modifier first, so that Luxel's own modifier (the lightmap UVs of an evaluated
    mesh, through geometry nodes) is checked on each Blender too."""
    reference = importlib.import_module(f"{PACKAGE}.addon.reference")
    bevel = bpy.data.objects["short_block"].modifiers.new("Bevel", 'BEVEL')
    bevel.width = 0.01
    settings = bpy.context.scene.luxel
    settings.texel_density = CORNELL_DENSITY
    settings.threshold = CORNELL_THRESHOLD
    started = time.perf_counter()
    if (result := bpy.ops.luxel.bake()) != {'FINISHED'}:
        fail(f"bpy.ops.luxel.bake() returned {result}")
    baked = time.perf_counter()
    # Cycles 5.2 and later log on stdout that they found no CUDA library: not Luxel's to say.
    with importlib.import_module(f"{PACKAGE}.addon.materials").bake_reports_silenced():
        pages = reference.cycles_reference(bpy.context, samples=CYCLES_SAMPLES,
                                           bounces=CYCLES_BOUNCES, copies=True)
    means = reference.object_means(pages)
    stats = settings.stats
    print(f"Luxel: {stats.texels:,} texels, {stats.shots} shots, {stats.unshot:.2f} % unshot, "
          f"{baked - started:.1f} s; Cycles: {CYCLES_SAMPLES} samples, "
          f"{time.perf_counter() - baked:.1f} s")
    if missing := sorted(set(meshes) - set(means)):
        fail(f"no lightmap for {', '.join(missing)}")
    failures = []
    for name, mean in means.items():
        noise = mean.cycles_error / mean.cycles
        print(f"{name}: {mean.texels} texels, Luxel / Cycles "
              + " ".join(f"{ratio:.3f}" for ratio in mean.ratio)
              + " (Cycles' noise " + " ".join(f"{value:.2%}" for value in noise) + ")")
        if mean.texels < 20 or not all(abs(ratio - 1.0) <= TOLERANCE for ratio in mean.ratio):
            failures.append(name)
    if failures:
        fail(f"Luxel and Cycles differ by more than {TOLERANCE:.0%} (or too few texels) on "
             + ", ".join(failures))


def export_and_view(bpy):
    """The bake as glTF through this Blender's exporter (its hooks differ between versions):
    every mesh node's primitives carry TEXCOORD_1 and a MOZ_lightmap material; and the viewer
    page, whose three.js the zip ships, is written beside it."""
    import json
    import tempfile
    cli = importlib.import_module(f"{PACKAGE}.addon.cli")
    gltf = importlib.import_module(f"{PACKAGE}.native.gltf")
    viewer = importlib.import_module(f"{PACKAGE}.native.viewer")
    folder = Path(tempfile.mkdtemp(prefix="luxel-gltf-"))
    if cli.execute(["export", "--gltf", str(folder / "box.glb")]) != 0:
        fail("--command luxel export --gltf failed")
    document = gltf.read_gltf(folder / "box.glb").document
    primitives = [primitive for node in document["nodes"] if "mesh" in node
                  for primitive in document["meshes"][node["mesh"]]["primitives"]]
    lit = [p for p in primitives if "TEXCOORD_1" in p["attributes"] and "MOZ_lightmap" in
           document["materials"][p["material"]].get("extensions", {})]
    if not primitives or len(lit) != len(primitives) or "luxel_lightmap" in json.dumps(document):
        fail(f"the glTF export gave {len(lit)} of {len(primitives)} primitives their lightmap")
    page = viewer.write_viewer(folder / "box.glb", folder / "page")
    print(f"glTF: {len(lit)} primitives with MOZ_lightmap; the page {page.name} written")


def bake(bpy, room):
    import numpy as np
    settings = bpy.context.scene.luxel
    settings.texel_density = 4.0
    settings.threshold = 0.05
    result = bpy.ops.luxel.bake()
    if result != {'FINISHED'}:
        fail(f"bpy.ops.luxel.bake() returned {result}")
    image = room.luxel.image
    if image is None:
        fail("the bake finished but the room has no lightmap image")
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    if not np.isfinite(pixels).all() or pixels.max() <= 0.0:
        fail(f"lightmap '{image.name}' is not finite and positive (max {pixels.max()})")
    stats = settings.stats
    print(f"bake: {stats.texels:,} texels, {stats.shots} shots, {stats.unshot:.2f} % unshot, "
          f"{stats.seconds:.1f} s; '{image.name}' {image.size[0]}x{image.size[1]}, "
          f"max {pixels.max():.3g}")


def check_in_blender(zip_path, cornell_box):
    """Runs in the child process, whose BLENDER_USER_RESOURCES is an empty folder."""
    try:
        import bpy
    except ImportError as error:
        fail(f"{sys.executable} has no bpy module ({error})")
    # Before the install no bundled package may be found, or the checks below would prove nothing.
    if found := [name for name in BUNDLED if importlib.util.find_spec(name) is not None]:
        fail(f"{', '.join(found)} importable before the install: {sys.path}")
    print(f"Blender {bpy.app.version_string}, Python {sys.version.split()[0]}, "
          f"numpy {importlib.import_module('numpy').__version__}")
    validate_strictly(zip_path)
    # The scene first: the Cornell box starts from the factory settings, which disable Luxel.
    scene = build_cornell_box(bpy) if cornell_box else build_room(bpy)
    try:
        bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo=REPO,
                                                 enable_on_install=True)
    except RuntimeError as error:  # the operator's report of a failed install or register()
        fail(f"install or enable: {error}")
    if PACKAGE not in bpy.context.preferences.addons:
        fail(f"{PACKAGE} installed but is not enabled")

    # Blender extracts the wheels of this platform into one site-packages of the user profile.
    site_packages = Path(bpy.utils.user_resource("EXTENSIONS", path=".local")).resolve()
    for name in BUNDLED:
        origin = Path(importlib.import_module(name).__file__).resolve()
        if not origin.is_relative_to(site_packages):
            fail(f"{name} loaded from {origin}, not from the wheels in {site_packages}")
        print(f"{name}: {origin.relative_to(site_packages)}")

    from bl_ext.user_default.luxel.native import create_context
    context = create_context()
    with context:  # which leaves Blender's context current; glGetString reads the current one
        print(f"OpenGL {context.info['GL_VERSION']} on {context.info['GL_RENDERER']}")
    context.release()
    if cornell_box:
        bake_cornell_box(bpy, scene)
        export_and_view(bpy)
    else:
        bake(bpy, scene)
    if bpy.app.version < (4, 5, 0):
        # Blender 4.2's bpy module crashes at exit (SIGSEGV) once a property with an update
        # callback or a command line command has been registered, as Luxel's are, even after
        # unregistering them; 4.5's does not. The checks have passed: leave without its teardown.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)


def requirement_closure(name):
    """Distributions that `name` requires, recursively, itself included; extras are skipped."""
    found, pending = {}, [name]
    while pending:
        distribution = importlib.metadata.distribution(pending.pop())
        key = re.sub(r"[-_.]+", "-", distribution.metadata["Name"]).lower()
        if key in found:
            continue
        found[key] = distribution
        for requirement in distribution.requires or []:
            if "extra" not in requirement.partition(";")[2]:
                pending.append(re.match(r"[A-Za-z0-9._-]+", requirement)[0])
    return found.values()


def link_bpy(folder):
    """Symlinks in folder to the top-level entries (packages, modules, dist-info folders) of bpy
    and the distributions it requires, so that folder on PYTHONPATH gives bpy and nothing else."""
    for distribution in requirement_closure("bpy"):
        for top in {Path(path).parts[0] for path in distribution.files or []} - {".."}:
            source = Path(distribution.locate_file(top))
            if source.exists() and not (folder / top).exists():
                (folder / top).symlink_to(source, target_is_directory=source.is_dir())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("zip", type=Path, help="the extension zip to install")
    parser.add_argument("--cornell-box", action="store_true",
                        help="bake the Cornell box and compare it with a Cycles bake")
    parser.add_argument("--in-blender", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.in_blender:
        check_in_blender(args.zip, args.cornell_box)
        return
    if not args.zip.is_file():
        fail(f"no zip at {args.zip}")
    started = time.perf_counter()
    command = [sys.executable, __file__, "--in-blender", str(args.zip.resolve())]
    if args.cornell_box:
        command.append("--cornell-box")
    # A child process, since Blender reads BLENDER_USER_RESOURCES once, when bpy is imported.
    with (tempfile.TemporaryDirectory(prefix="luxel-blender-user-") as resources,
          tempfile.TemporaryDirectory(prefix="luxel-bpy-only-") as bpy_only):
        env = dict(os.environ, BLENDER_USER_RESOURCES=resources)
        if any(importlib.util.find_spec(name) for name in BUNDLED):
            try:
                link_bpy(Path(bpy_only))
            except importlib.metadata.PackageNotFoundError as error:
                fail(f"{sys.executable} has a bundled package but no bpy to isolate ({error})")
            command.insert(1, "-S")
            env["PYTHONPATH"] = bpy_only
            print(f"isolated: python -S with only bpy and its requirements ({bpy_only})")
        result = subprocess.run(command, env=env)
    if result.returncode != 0:
        sys.exit(result.returncode)
    print(f"{args.zip}: installs, enables, finds its dependencies in the wheels and bakes"
          + (" the Cornell box as Cycles does" if args.cornell_box else "")
          + f" ({time.perf_counter() - started:.1f} s)")


if __name__ == "__main__":
    main()
