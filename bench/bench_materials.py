"""What evaluating the materials with Cycles costs (addon/materials.py): per sample .blend at
its own lightmap settings, the seconds evaluate_materials takes (median of --repeats, the
export and the atlas outside it: the atlas is charted once, then cached), the texels it
bakes and how many mesh copies bake at one sample (materials that cannot vary) and at
MATERIAL_SAMPLES. ``--furniture-levels L`` subdivides the realistic interior's furniture L
Subdivision Surface levels more first (bench_charting.py's big rooms).

    python bench/bench_materials.py [names...] [--repeats N] [--furniture-levels L]
        [--json PATH]
"""
import argparse
from pathlib import Path
import statistics
import sys
import time

from common import ROOT, save_results  # also puts the repository on sys.path

sys.path.insert(0, str(ROOT / "tools"))
import blender  # noqa: E402  (tools/blender.py: bpy with Luxel enabled)
import bench_charting  # noqa: E402  (the interior's furniture subdivided further)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", default=["cornell_box", "interior"])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--furniture-levels", type=int, default=0,
                        help="subdivide the interior's furniture this many levels more")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    bpy = blender.start_blender()
    addon = blender.luxel().addon
    native = blender.luxel().native
    rows = []
    for name in args.names:
        bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / f"{name}.blend"))
        if name == "interior" and args.furniture_levels:
            bench_charting.subdivide_furniture(bpy, args.furniture_levels)
        settings = bpy.context.scene.luxel.solver_settings()
        export = addon.export.export_scene(bpy.context)
        atlas = native.lightmap_atlas(export.scene, settings)      # charted (and cached)
        varying = sum(any(addon.materials._varies(bpy.data.materials[m])
                          for m in surface.materials if m is not None)
                      for surface in export.surfaces)
        seconds = []
        for _ in range(args.repeats):
            export = addon.export.export_scene(bpy.context)
            started = time.perf_counter()
            addon.materials.evaluate_materials(bpy.context.evaluated_depsgraph_get(), export,
                                               settings)
            seconds.append(time.perf_counter() - started)
        row = {"scene": name, "furniture_levels": args.furniture_levels if name == "interior"
               else 0, "triangles": len(export.scene.triangles),
               "density": settings.texel_density,
               "page_texels": atlas.width * atlas.height * atlas.page_count,
               "mesh_copies": len(export.surfaces), "varying": varying,
               "seconds": seconds, "median_seconds": statistics.median(seconds)}
        rows.append(row)
        print(f"{name}: {row['median_seconds']:.2f} s (median of {args.repeats}), "
              f"{row['page_texels']:,} page texels at {row['density']:g} texels/m, "
              f"{row['mesh_copies']} mesh copies of which {varying} vary")
    save_results(args.json, {"scenes": rows})
    import os
    os._exit(0)     # bpy's teardown can crash on some versions


if __name__ == "__main__":
    main()
