"""The realistic interior (sample_blends/interior.blend, built the way users model one): the
share of the rendered surface that gets a lightmap, the bake's time, texels and shots, and
each shown copy's mean against a Cycles bake into the same lightmap UVs (objects shown
through Luxel's modifier, curves, text and instances through stand-ins of their evaluated
meshes: addon/reference.py, copies=True).

    python bench/bench_interior.py [--density D] [--threshold T] [--samples N]
                                   [--supersample S] [--default-materials]
                                   [--without NAME ...] [--lower PREFIX METRES]
                                   [--hemicube N]
                                   [--blend NAME] [--json PATH]

--default-materials gives every Principled BSDF Blender's default specular layer (Specular
IOR Level 0.5, Roughness 0.5) in place of the file's matte ones; --without deletes the named
objects (a light, say) first; --lower moves the objects whose names start with PREFIX down
(the office's ceiling lights out of their thin gap, say); --hemicube sets the visibility
map's side (0, the default: automatic). --samples is Cycles': with fewer, the small copies'
means carry Cycles' own noise (BENCHMARKS.md, the realistic interior). --supersample S has
Cycles bake S x S sub-texels a texel and compares with their mean over the texel's surface
(reference.cycles_reference). --blend bakes another of sample_blends/ the same way (office,
living, temple). Cycles' bakes are kept in bench/cache/, keyed by the file, the options that
change what Cycles sees and the lightmap UV layout, so that a run whose layout did not
change bakes Luxel only.
"""
import argparse
import hashlib
import importlib
from pathlib import Path
import sys
import time

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "bench"))
import blender as runner  # noqa: E402  (tools/blender.py)
from common import save_results  # noqa: E402

BOUNCES = 32


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--density", type=float, default=10.0)
    parser.add_argument("--threshold", type=float, default=0.02)
    parser.add_argument("--samples", type=int, default=1024)
    parser.add_argument("--supersample", type=int, default=1)
    parser.add_argument("--default-materials", action="store_true")
    parser.add_argument("--without", action="append", default=[], metavar="NAME")
    parser.add_argument("--lower", nargs=2, metavar=("PREFIX", "METRES"))
    parser.add_argument("--hemicube", type=int, default=0, metavar="N")
    parser.add_argument("--blend", default="interior", metavar="NAME")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    bpy = runner.start_blender()
    addon = runner.luxel().addon
    reference = importlib.import_module(runner.MODULE + ".addon.reference")
    bpy.ops.wm.open_mainfile(filepath=str(_blend_path(args)))
    scene = bpy.context.scene
    scene.luxel.texel_density, scene.luxel.threshold = args.density, args.threshold
    scene.luxel.hemicube_resolution = args.hemicube
    for name in args.without:
        bpy.data.objects.remove(bpy.data.objects[name])
    if args.lower:
        prefix, metres = args.lower[0], float(args.lower[1])
        for obj in bpy.data.objects:
            if obj.name.startswith(prefix):
                obj.location.z -= metres
    if args.default_materials:
        for material in bpy.data.materials:
            for node in material.node_tree.nodes if material.node_tree else ():
                if node.bl_idname == 'ShaderNodeBsdfPrincipled':
                    node.inputs["Specular IOR Level"].default_value = 0.5
                    node.inputs["Roughness"].default_value = 0.5

    export = addon.export.export_scene(bpy.context)
    solver_scene = export.scene
    lights = {obj.name for obj in scene.objects if obj.type == 'LIGHT'}
    surface = np.array([name not in lights for name in solver_scene.object_names])
    area = solver_scene.triangle_area
    rendered = area[surface[solver_scene.object_index]].sum()
    shown = sum(area[r.first_triangle:r.first_triangle + len(r.loops)].sum()
                for r in export.receivers)

    started = time.perf_counter()
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    seconds = time.perf_counter() - started
    stats = scene.luxel.stats
    started = time.perf_counter()
    cache = ROOT / "bench" / "cache" / f"{args.blend}-{_digest(bpy, args)}.npz"
    if cache.exists():
        with np.load(cache) as stored:
            cycles = {name.replace("|", "/"): stored[name] for name in stored.files}
    else:
        cycles = reference.cycles_reference(bpy.context, args.samples, BOUNCES, copies=True,
                                            supersample=args.supersample)
        cache.parent.mkdir(exist_ok=True)
        np.savez_compressed(cache, **{name.replace("/", "|"): image
                                      for name, image in cycles.items()})
    means = reference.object_means(cycles)
    cycles_seconds = time.perf_counter() - started
    luminance = np.array([0.2126, 0.7152, 0.0722])
    rows = []
    for name, mean in sorted(means.items()):
        ratio = float(mean.luxel @ luminance / max(mean.cycles @ luminance, 1e-30))
        # Relative RMS of the texels' luminance over Cycles' mean, on the texels Cycles baked.
        covered = cycles[name][..., 3] > 0
        luxel = reference._pixels(reference.luxel_page(scene, name))[covered][:, :3]
        difference = (luxel - cycles[name][covered][:, :3]) @ luminance
        rms = float(np.sqrt(np.mean(difference ** 2)) / max(mean.cycles @ luminance, 1e-30))
        rows.append({"object": name, "texels": mean.texels, "luxel": mean.luxel.tolist(),
                     "cycles": mean.cycles.tolist(), "ratio": ratio, "relative_rms": rms})
        print(f"{name:>14} {mean.texels:7d} texels  Luxel/Cycles {ratio:6.3f}  "
              f"relative RMS {rms:6.3f}")
    result = {"solver_objects": len(solver_scene.object_names), "receivers": len(export.receivers),
              "triangles": len(solver_scene.triangles), "area_shown": float(shown / rendered),
              "bake_seconds": seconds, "texels": stats.texels, "shots": stats.shots,
              "unshot_percent": stats.unshot, "density": args.density,
              "threshold": args.threshold, "cycles_samples": args.samples,
              "cycles_supersample": args.supersample,
              "default_materials": args.default_materials,
              "cycles_seconds": cycles_seconds, "cycles_cached": cache.name,
              "blend": args.blend, "without": args.without, "lower": args.lower,
              "hemicube": args.hemicube,
              "objects": rows,
              "warnings": list(export.warnings)}
    print(f"shown {100 * result['area_shown']:.1f} % of the rendered area; bake {seconds:.1f} s, "
          f"{stats.texels} texels, {stats.shots} shots; Cycles {cycles_seconds:.1f} s")
    for warning in export.warnings:
        print("warning:", warning)
    save_results(args.json, result)
    import os
    os._exit(0)     # bpy's teardown after a bake can crash on some versions


def _digest(bpy, args):
    """What decides Cycles' bakes: the file, the options, and the lightmap UV layout (the
    lightmap UV maps, the evaluated corners' snapshots and the page sizes)."""
    writeback = importlib.import_module(runner.MODULE + ".addon.writeback")
    digest = hashlib.sha256(_blend_path(args).read_bytes())
    key = (args.samples, BOUNCES, args.default_materials, sorted(args.without))
    # A plain bake keeps the key it had before supersampling and lowering were options.
    key += (args.supersample,) if args.supersample != 1 else ()
    key += (tuple(args.lower),) if args.lower else ()
    digest.update(repr(key).encode())
    for mesh in sorted(bpy.data.meshes, key=lambda mesh: mesh.name):
        for name in (writeback.UV_MAP, writeback.SNAPSHOT_ATTRIBUTE,
                     writeback.SNAPSHOT_BACK_ATTRIBUTE):
            attribute = mesh.attributes.get(name)
            if attribute is not None:
                width = {'FLOAT2': 2, 'FLOAT_VECTOR': 3}[attribute.data_type]
                values = np.empty(len(attribute.data) * width, dtype=np.float32)
                attribute.data.foreach_get("vector", values)
                digest.update(mesh.name.encode() + name.encode() + values.tobytes())
    for image in sorted(bpy.data.images, key=lambda image: image.name):
        digest.update(f"{image.name} {tuple(image.size)}".encode())
    return digest.hexdigest()[:16]


def _blend_path(args):
    return ROOT / "sample_blends" / f"{args.blend}.blend"


if __name__ == "__main__":
    main()
