"""Export sample .blend scenes to bench/scenes/<name>.npz, so the benchmarks run where Blender
is not installed (the npz files are committed). Needs the bpy module:

    python bench/export_scenes.py                       # columns and cornell_box
    python bench/export_scenes.py temple office         # others from sample_blends/

The scene is what a bake exports (addon/export.py), with its materials as Cycles evaluates
them per texel of the file's own lightmap settings (addon/materials.py; the textures serve
any density, at that one's resolution); its warnings are printed."""
import argparse
import sys

from common import ROOT  # also puts the repository on sys.path

sys.path.insert(0, str(ROOT / "tools"))
import blender  # noqa: E402  (tools/blender.py: bpy with Luxel enabled)

SCENES = ROOT / "bench" / "scenes"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("names", nargs="*", default=["columns", "cornell_box"])
    args = parser.parse_args()

    bpy = blender.start_blender()
    addon = blender.luxel().addon
    SCENES.mkdir(exist_ok=True)
    for name in args.names:
        bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / f"{name}.blend"))
        result = addon.export.export_scene(bpy.context)
        addon.materials.evaluate_materials(bpy.context.evaluated_depsgraph_get(), result,
                                           bpy.context.scene.luxel.solver_settings())
        for warning in result.warnings:
            print(f"{name}: warning: {warning}")
        path = SCENES / f"{name}.npz"
        result.scene.save(path)
        scene = result.scene
        print(f"{name}: {len(scene.triangles)} triangles, {len(scene.object_names)} objects, "
              f"{len(scene.lights)} lights -> {path.relative_to(ROOT)} "
              f"({path.stat().st_size / 1024:.0f} KiB)")


if __name__ == "__main__":
    main()
