"""A real level as a user brings it (OBJ through Blender's importer, every material matte grey
0.8, a sun and a uniform sky as in bench_levels.py), baked through the add-on, and seen from
cameras standing in it: each view rendered by Cycles path tracing every bounce and by Cycles
showing Luxel's lightmaps (Show Baked Lighting), compared as issue 47 asks (the mean within
5 %, 80 % of the pixels within 10 %).

    python bench/bench_level_views.py --levels DIR --level steelribs --density 0.5 \\
        [--threshold 0.01] [--shots N] [--views 3] [--samples 256] [--resolution 320 180] \\
        [--back-faces AUTO|ON|OFF] \\
        [--images DIR] [--json bench/results/level-views-steelribs-0.5-llvmpipe.json]

Cameras stand 1.7 m over floor points (upward faces, area-weighted, with 2 m of head room),
looking level-ish where the way is longest: what a player sees, found in any level."""
import argparse
import importlib
import math
from pathlib import Path
import sys
import time

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "bench"))
import blender as runner  # noqa: E402  (tools/blender.py)
from bench_levels import ALBEDO, GAME_UNIT, SKY, SUN_DIRECTION, SUN_STRENGTH  # noqa: E402
from common import add_level_arguments, save_results  # noqa: E402

EYE_HEIGHT = 1.7
HEAD_ROOM = 2.0
CANDIDATES = 400
BOUNCES = 64        # every bounce that matters at albedo 0.8 (0.8^64 ~ 1e-6)


def import_level(bpy, path):
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.obj_import(filepath=str(path), global_scale=GAME_UNIT)
    scene = bpy.context.scene
    for material in bpy.data.materials:         # matte grey, as bench_levels.py bakes it
        if material.node_tree is None:
            material.use_nodes = True
        shader = next((n for n in material.node_tree.nodes if n.type == 'BSDF_PRINCIPLED'), None)
        if shader is None:
            continue
        for link in list(shader.inputs["Base Color"].links):
            material.node_tree.links.remove(link)
        shader.inputs["Base Color"].default_value = (ALBEDO, ALBEDO, ALBEDO, 1.0)
        shader.inputs["Specular IOR Level"].default_value = 0.0
        shader.inputs["Roughness"].default_value = 1.0
    sun_data = bpy.data.lights.new("Sun", 'SUN')
    sun_data.energy, sun_data.angle = SUN_STRENGTH, 0.0
    sun = bpy.data.objects.new("Sun", sun_data)
    scene.collection.objects.link(sun)
    from mathutils import Vector
    sun.rotation_euler = Vector(SUN_DIRECTION).to_track_quat('-Z', 'Y').to_euler()
    world = bpy.data.worlds.new("Sky")
    if world.node_tree is None:
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (SKY, SKY, SKY, 1.0)
    world.color = (SKY,) * 3
    scene.world = world
    scene.render.engine = 'CYCLES'
    return scene


def level_cameras(bpy, scene, count, resolution, seed=1):
    """``count`` cameras over floor points, each looking where the way is longest."""
    from mathutils import Vector
    depsgraph = bpy.context.evaluated_depsgraph_get()
    level = next(obj for obj in scene.objects if obj.type == 'MESH')
    mesh = level.data
    matrix = level.matrix_world
    floors = [(p.area, matrix @ p.center) for p in mesh.polygons
              if (matrix.to_3x3() @ p.normal).normalized().z > 0.9]
    areas = np.array([area for area, _ in floors])
    rng = np.random.default_rng(seed)
    candidates = []
    for index in rng.choice(len(floors), size=CANDIDATES, p=areas / areas.sum()):
        eye = floors[index][1] + Vector((0.0, 0.0, EYE_HEIGHT))
        hit = scene.ray_cast(depsgraph, floors[index][1] + Vector((0, 0, 0.05)),
                             Vector((0, 0, 1)), distance=HEAD_ROOM)[0]
        if hit:
            continue
        ways = []
        for angle in np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False):
            direction = Vector((math.cos(angle), math.sin(angle), -0.15)).normalized()
            found, location = scene.ray_cast(depsgraph, eye, direction, distance=200.0)[:2]
            ways.append(((location - eye).length if found else 200.0, direction))
        way, direction = max(ways, key=lambda item: item[0])
        candidates.append((way, eye, direction))
    candidates.sort(key=lambda item: -item[0])
    cameras = []
    for way, eye, direction in candidates:
        if len(cameras) == count:
            break
        if any((eye - camera.location).length < 10.0 for camera in cameras):
            continue
        data = bpy.data.cameras.new(f"View {len(cameras) + 1}")
        data.lens, data.clip_start = 18.0, 0.05
        camera = bpy.data.objects.new(data.name, data)
        scene.collection.objects.link(camera)
        camera.location = eye
        camera.rotation_euler = direction.to_track_quat('-Z', 'Y').to_euler()
        cameras.append(camera)
    scene.camera = cameras[0]
    scene.render.resolution_x, scene.render.resolution_y = resolution
    return cameras


def compare(view):
    """Mean ratio and the share of pixels within 10 % (where Cycles shows light)."""
    cycles, luxel = view.cycles.mean(axis=-1), view.luxel.mean(axis=-1)
    lit = cycles > 1e-3 * cycles.max()
    within = np.abs(luxel[lit] - cycles[lit]) <= 0.1 * cycles[lit]
    return {"name": view.name, "mean_ratio": float(luxel[lit].mean() / cycles[lit].mean()),
            "within_10_percent": float(within.mean()), "lit_pixels": int(lit.sum())}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_level_arguments(parser, density=0.5)
    parser.add_argument("--views", type=int, default=3)
    parser.add_argument("--samples", type=int, default=256, help="Cycles' path tracing")
    parser.add_argument("--resolution", type=int, nargs=2, default=(320, 180))
    parser.add_argument("--back-faces", choices=("AUTO", "ON", "OFF"), default="AUTO",
                        help="the level object's Back Faces (Object properties)")
    parser.add_argument("--images", type=Path, help="write each view's two renders as PNGs")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    bpy = runner.start_blender()
    addon = runner.luxel().addon
    views_module = importlib.import_module(runner.MODULE + ".addon.views")
    scene = import_level(bpy, args.levels / f"{args.level}.obj")
    cameras = level_cameras(bpy, scene, args.views, tuple(args.resolution))
    for obj in scene.objects:
        if obj.type == 'MESH':
            obj.luxel.back_faces = args.back_faces
    options = ["bake", "--density", str(args.density), "--threshold", str(args.threshold)]
    if args.shots:
        options += ["--shots", str(args.shots)]
    started = time.perf_counter()
    if addon.cli.execute(options) != 0:
        raise SystemExit("the bake failed")
    bake_seconds = time.perf_counter() - started
    stats = scene.luxel.stats
    started = time.perf_counter()
    views = views_module.render_views(bpy.context, len(cameras), tuple(args.resolution),
                                      args.samples, bounces=BOUNCES)
    render_seconds = time.perf_counter() - started
    result = {
        "level": args.level, "density": args.density, "threshold": args.threshold,
        "back_faces": args.back_faces, "texels": stats.texels, "shots": stats.shots, "unshot": stats.unshot / 100.0,
        "stopped_at_shot_limit": stats.stopped_at_shot_limit, "bake_seconds": bake_seconds,
        "cycles_samples": args.samples, "resolution": list(args.resolution),
        "render_seconds": render_seconds,
        "cameras": [[*camera.location, *camera.rotation_euler] for camera in cameras],
        "views": [compare(view) for view in views],
    }
    if args.images:
        native = importlib.import_module(runner.MODULE + ".native")
        args.images.mkdir(parents=True, exist_ok=True)
        for view in views:      # one exposure for both: the path-traced view's mean at 0.18
            exposure = 0.18 / max(float(view.cycles.mean()), 1e-9)
            for kind in ("cycles", "luxel"):
                native.write_png(args.images / f"{args.level}-{view.name}-{kind}.png",
                                 native.tone_map(getattr(view, kind), exposure))
    for view in result["views"]:
        print(f"{view['name']}: Luxel / Cycles mean {view['mean_ratio']:.3f}, "
              f"{100 * view['within_10_percent']:.0f} % of pixels within 10 %")
    print({key: value for key, value in result.items() if key != "views"})
    save_results(args.json, result)


if __name__ == "__main__":
    main()
