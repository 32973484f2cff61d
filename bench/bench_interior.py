"""The realistic interior (sample_blends/interior.blend, built the way users model one): the
share of the rendered surface that gets a lightmap, the bake's time, texels and shots, and
each shown copy's mean against a Cycles bake into the same lightmap UVs (objects shown
through Luxel's modifier, curves, text and instances through stand-ins of their evaluated
meshes: addon/reference.py, copies=True).

    python bench/bench_interior.py [--density D] [--threshold T] [--samples N]
                                   [--default-materials] [--json PATH] [--cycles-cache PATH]

--default-materials gives every Principled BSDF Blender's default specular layer (Specular
IOR Level 0.5, Roughness 0.5) in place of the file's matte ones. --samples is Cycles': with
fewer, the small copies' means carry Cycles' own noise (BENCHMARKS.md, the realistic
interior). --cycles-cache keeps the Cycles bakes in a .npz and reuses them while the file,
the density, the samples, the materials and the lightmap layout stay the same, so a
Luxel-only re-run takes the bake's time alone.
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--density", type=float, default=10.0)
    parser.add_argument("--threshold", type=float, default=0.02)
    parser.add_argument("--samples", type=int, default=1024)
    parser.add_argument("--default-materials", action="store_true")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--cycles-cache", type=Path)
    args = parser.parse_args()
    bpy = runner.start_blender()
    addon = runner.luxel().addon
    reference = importlib.import_module(runner.MODULE + ".addon.reference")
    blend = ROOT / "sample_blends" / "interior.blend"
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    scene = bpy.context.scene
    scene.luxel.texel_density, scene.luxel.threshold = args.density, args.threshold
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
    identity = (f"{hashlib.sha256(blend.read_bytes()).hexdigest()} density {args.density} "
                f"samples {args.samples} bounces 32 default materials {args.default_materials}")
    cycles = cached_cycles(args.cycles_cache, identity, reference, scene)
    cached = cycles is not None
    if not cached:
        cycles = reference.cycles_reference(bpy.context, args.samples, 32, copies=True)
        if args.cycles_cache:
            names = sorted(cycles)
            np.savez_compressed(args.cycles_cache, identity=identity, names=np.array(names),
                                **{f"image_{i}": cycles[name] for i, name in enumerate(names)})
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
              "default_materials": args.default_materials,
              "cycles_seconds": cycles_seconds, "cycles_cached": cached,
              "objects": rows,
              "warnings": list(export.warnings)}
    print(f"shown {100 * result['area_shown']:.1f} % of the rendered area; bake {seconds:.1f} s, "
          f"{stats.texels} texels, {stats.shots} shots; Cycles {cycles_seconds:.1f} s"
          f"{' (kept)' if cached else ''}")
    for warning in export.warnings:
        print("warning:", warning)
    save_results(args.json, result)
    import os
    os._exit(0)     # bpy's teardown after a bake can crash on some versions


def cached_cycles(path, identity, reference, scene):
    """The Cycles bakes kept at ``path`` for this ``identity``, or None: none kept, another
    identity, or a texel Cycles covered that Luxel's page leaves empty (the layout moved)."""
    if path is None or not path.exists():
        return None
    kept = np.load(path)
    if str(kept["identity"]) != identity:
        return None
    cycles = {str(name): kept[f"image_{i}"] for i, name in enumerate(kept["names"])}
    for name, image in cycles.items():
        page = reference._pixels(reference.luxel_page(scene, name))
        if page.shape != image.shape or not (page[image[..., 3] > 0, 3] > 0).all():
            return None
    return cycles


if __name__ == "__main__":
    main()
