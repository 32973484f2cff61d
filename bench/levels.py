"""Real game levels, from OBJ files the project does not ship (bench/common.py has the
command line; the folder of LEVEL.obj files is LUXEL_LEVELS, by default bench/levels/ (git ignores
it), and a study without it is skipped):

    python bench/levels.py levels        # each level baked by the solver: shots, time, unshot
    python bench/levels.py level-views   # a level through Blender, seen from cameras in it,
                                         # Cycles path tracing against Luxel's lightmaps

A level is one object of many material groups and no UV map, lit by a sun and a uniform sky,
grey everywhere, as a level imported without its textures bakes."""
import math
import os
from pathlib import Path
import time

import numpy as np

import common
from common import Study

# One unit of Cube 2 and Tesseract maps is about 0.1 m (a player stands about 15 units).
GAME_UNIT = 0.1
SUN_DIRECTION = (0.3, 0.2, -0.9)
SUN_STRENGTH = 3.0
SKY = 0.5
ALBEDO = 0.8
# Cameras stand at eye height over floor points with head room over them.
EYE_HEIGHT = 1.7
HEAD_ROOM = 2.0
CAMERA_CANDIDATES = 400
VIEW_BOUNCES = 64        # every bounce that matters at albedo 0.8 (0.8^64 ~ 1e-6)
# Cycles' own lightmap bakes each texel as the mean over this many x this many sub-texels:
# the mean over its surface, as a Luxel texel holds it.
LIGHTMAP_SUPERSAMPLE = 2


def levels_folder():
    return Path(os.environ.get("LUXEL_LEVELS", common.ROOT / "bench" / "levels"))


def level_paths(names):
    """The levels' OBJ files (every one in the folder where ``names`` is empty); none where
    the folder is missing."""
    folder = levels_folder()
    if not folder.is_dir():
        print(f"no levels: {folder} is not a folder (set LUXEL_LEVELS)", flush=True)
        return []
    return [folder / f"{name}.obj" for name in names] if names else sorted(folder.glob("*.obj"))


# -------------------------------------------------------------------------------- levels
def read_obj(path, scale):
    """Vertices (Z up, metres) and triangles of an OBJ file, its polygons fanned, as
    Blender's importer reads it with its default axes (Y up, -Z forward); zero-area
    triangles dropped, as the add-on skips them. Returns (vertices, triangles, dropped)."""
    from native.scene import triangle_areas
    vertices, triangles = [], []
    with open(path) as lines:
        for line in lines:
            if line.startswith("v "):
                vertices.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                corners = [int(token.split("/")[0]) for token in line.split()[1:]]
                corners = [c - 1 if c > 0 else len(vertices) + c for c in corners]
                triangles += [[corners[0], corners[k], corners[k + 1]]
                              for k in range(1, len(corners) - 1)]
    v = np.asarray(vertices, dtype=np.float64) * scale
    v = np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1)
    t = np.asarray(triangles, dtype=np.int64)
    _, degenerate = triangle_areas(v[t])
    return v, t[~degenerate], int(degenerate.sum())


def level_scene(path):
    from native import Scene, SunLight
    vertices, triangles, dropped = read_obj(path, GAME_UNIT)
    direction = np.asarray(SUN_DIRECTION) / np.linalg.norm(SUN_DIRECTION)
    scene = Scene(vertices=vertices, triangles=triangles,
                  albedo=np.full((len(triangles), 3), ALBEDO),
                  lights=[SunLight(direction=tuple(direction), strength=SUN_STRENGTH)],
                  sky=(SKY,) * 3)
    return scene, dropped


def levels(names, density, threshold, shots):
    """Each level at ``density`` to ``threshold`` or ``shots`` shots (0: the automatic
    limit), phases timed (Settings.profile): set-up, shots, unshot fraction, the unshot
    fraction every 500 shots, and the energy ledger's imbalance."""
    from native import Settings, Solver, create_context
    rows = []
    ctx = create_context()
    for path in level_paths(names):
        scene, dropped = level_scene(path)
        started = time.perf_counter()
        with Solver(scene, Settings(texel_density=density, threshold=threshold,
                                    max_shots=shots, profile=True), ctx=ctx) as solver:
            set_up = time.perf_counter() - started
            trace = []
            while solver.step():
                progress = solver.progress
                if not trace or progress.shots >= trace[-1]["shots"] + 500:
                    trace.append({"shots": progress.shots, "unshot": progress.unshot_fraction,
                                  "seconds": progress.seconds})
            progress = solver.progress
            row = {"level": path.stem, "triangles": len(scene.triangles),
                   "zero_area_dropped": dropped, "texels": solver.texel_count,
                   "set_up_seconds": set_up, "seconds": progress.seconds,
                   "shots": progress.shots, "shot_limit": progress.shot_limit,
                   "unshot": progress.unshot_fraction, "converged": progress.converged,
                   "diverged": progress.diverged, "phases": dict(solver.timings),
                   "ledger_imbalance": solver.ledger().imbalance(), "trace": trace}
        rows.append(row)
        print(f"{row['level']}: {row['texels']:,} texels, {row['shots']} shots, "
              f"{100 * row['unshot']:.2f} % unshot, {row['seconds']:.0f} s", flush=True)
    ctx.release()
    return {"density": density, "threshold": threshold, "rows": rows}


# --------------------------------------------------------------------------- level views
def level_views(names, density, threshold, shots, views, samples, lightmap_samples, resolution):
    """Each level imported through Blender's OBJ importer (every material matte grey, the sun
    and sky of ``levels``), baked through the add-on, and seen from ``views`` cameras standing
    in it: each view rendered by Cycles path tracing every bounce at ``samples`` a pixel and
    by Cycles showing Luxel's lightmaps, compared over the surfaces Cycles shows lit (not the
    sky): the mean, and the share of pixels within 10 %; and the same for Cycles' own
    lightmap of the level at the density, baked at ``lightmap_samples`` a sub-texel
    (cycles_lightmap_views), what detail finer than a texel leaves. Indoors the path tracer
    needs thousands of samples before its own noise stays within 10 % on most pixels."""
    paths = level_paths(names)
    if not paths:
        return {"rows": []}
    bpy, luxel = common.start_blender()
    import importlib
    views_module = importlib.import_module(luxel.__name__ + ".addon.views")
    rows = []
    for path in paths:
        scene = import_level(bpy, path)
        cameras = level_cameras(bpy, scene, views, tuple(resolution))
        options = ["bake", "--density", str(density), "--threshold", str(threshold)]
        if shots:
            options += ["--shots", str(shots)]
        started = time.perf_counter()
        if luxel.addon.cli.execute(options) != 0:
            raise SystemExit(f"{path.stem}: the bake failed")
        bake_seconds = time.perf_counter() - started
        stats = scene.luxel.stats
        started = time.perf_counter()
        rendered = views_module.render_views(bpy.context, len(cameras), tuple(resolution),
                                             samples, bounces=VIEW_BOUNCES)
        render_seconds = time.perf_counter() - started
        best = cycles_lightmap_views(bpy, luxel, views_module, scene, rendered,
                                     lightmap_samples, tuple(resolution))
        views = []
        for view, shown in zip(rendered, best):
            views.append({**compare_view(view), "cycles_lightmap": compare_view(shown)})
        row = {"level": path.stem, "texels": stats.texels, "shots": stats.shots,
               "unshot": stats.unshot / 100.0, "bake_seconds": bake_seconds,
               "render_seconds": render_seconds, "views": views}
        rows.append(row)
        for view in row["views"]:
            best = view["cycles_lightmap"]
            print(f"{row['level']} {view['name']}: Luxel / Cycles mean "
                  f"{view['mean_ratio']:.3f}, {100 * view['within_10_percent']:.0f} % of "
                  f"pixels within 10 %; Cycles' own lightmap {best['mean_ratio']:.3f}, "
                  f"{100 * best['within_10_percent']:.0f} %", flush=True)
    return {"density": density, "threshold": threshold, "cycles_samples": samples,
            "lightmap_samples": lightmap_samples, "resolution": list(resolution), "rows": rows}


def import_level(bpy, path):
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.obj_import(filepath=str(path), global_scale=GAME_UNIT)
    scene = bpy.context.scene
    for material in bpy.data.materials:         # matte grey, as levels() bakes it
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
    from mathutils import Vector
    sun_data = bpy.data.lights.new("Sun", 'SUN')
    sun_data.energy, sun_data.angle = SUN_STRENGTH, 0.0
    sun = bpy.data.objects.new("Sun", sun_data)
    scene.collection.objects.link(sun)
    sun.rotation_euler = Vector(SUN_DIRECTION).to_track_quat('-Z', 'Y').to_euler()
    world = bpy.data.worlds.new("Sky")
    if world.node_tree is None:
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (SKY, SKY, SKY, 1.0)
    world.color = (SKY,) * 3
    scene.world = world
    # The sky lights the level but is not seen: a view compares lightmaps, and pixels of sky
    # (the same in both renders) made up to four fifths of a view's pixels within 10 %.
    world.cycles_visibility.camera = False
    scene.render.engine = 'CYCLES'
    return scene


def level_cameras(bpy, scene, count, resolution, seed=1):
    """``count`` cameras at eye height over floor points (upward faces, area-weighted, with
    head room, seeing the fronts of the faces around them), each looking level-ish where the
    way to a surface is longest: what a player sees across the level; not into the open sky,
    which shows no lightmap."""
    from mathutils import Vector
    depsgraph = bpy.context.evaluated_depsgraph_get()
    level = next(obj for obj in scene.objects if obj.type == 'MESH')
    matrix = level.matrix_world
    floors = [(p.area, matrix @ p.center) for p in level.data.polygons
              if (matrix.to_3x3() @ p.normal).normalized().z > 0.9]
    areas = np.array([area for area, _ in floors])
    rng = np.random.default_rng(seed)
    candidates = []
    for index in rng.choice(len(floors), size=CAMERA_CANDIDATES, p=areas / areas.sum()):
        floor = floors[index][1]
        if scene.ray_cast(depsgraph, floor + Vector((0, 0, 0.05)), Vector((0, 0, 1)),
                          distance=HEAD_ROOM)[0]:
            continue
        eye = floor + Vector((0.0, 0.0, EYE_HEIGHT))
        ways, outside = [], False
        for angle in np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False):
            direction = Vector((math.cos(angle), math.sin(angle), -0.15)).normalized()
            found, location, normal = scene.ray_cast(depsgraph, eye, direction,
                                                     distance=200.0)[:3]
            if found:
                ways.append(((location - eye).length, direction))
                outside |= normal.dot(direction) > 0.0
        # On the level's outer shell, a floor point sees the backs of its walls, which
        # Cycles lights and a lightmap leaves dark: half of pandora's views were such backs.
        if outside or not ways:
            continue
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


def cycles_lightmap_views(bpy, luxel, views_module, scene, rendered, samples, resolution):
    """The ``rendered`` views again, each lightmap page showing Cycles' own bake of its
    objects into Luxel's texels (every bounce, each texel the mean over its surface, the
    gutter filled as Luxel's) in place of Luxel's: what any lightmap of this density shows
    at best, against the same path tracing. Luxel's pages come back afterwards."""
    addon, fill_gutter = luxel.addon, luxel.native.postprocess.fill_gutter
    padding = luxel.native.Settings().padding     # the add-on's bakes chart at the default
    objects = [obj for obj in scene.objects if obj.type == 'MESH' and obj.luxel.image]
    baked = addon.reference.cycles_reference(bpy.context, samples=samples, bounces=VIEW_BOUNCES,
                                             objects=objects, supersample=LIGHTMAP_SUPERSAMPLE)
    pages = {}
    for obj in objects:
        image = obj.luxel.image
        page = pages.setdefault(image.name, (image, np.zeros((image.size[1], image.size[0], 4),
                                                              np.float32)))[1]
        texels = baked[obj.name][..., 3] > 0.0
        page[texels] = baked[obj.name][texels]
    own = {name: addon.writeback.image_pixels(image).copy() for name, (image, _) in pages.items()}
    try:
        for image, page in pages.values():
            fill_gutter(page, padding + 1)
            page[..., 3] = 1.0
            image.pixels.foreach_set(page.ravel())
            image.update()
        shown = views_module.render_views(bpy.context, len(rendered), resolution, samples,
                                          bounces=VIEW_BOUNCES, path_traced=False)
    finally:
        for name, (image, _) in pages.items():
            image.pixels.foreach_set(own[name].ravel())
            image.update()
    return [views_module.View(view.name, view.source, view.cycles, best.luxel)
            for view, best in zip(rendered, shown)]


def compare_view(view):
    """Mean ratio and the share of pixels within 10 %, over the pixels where Cycles shows a
    lit surface (import_level hides the sky from the cameras)."""
    cycles, luxel = view.cycles.mean(axis=-1), view.luxel.mean(axis=-1)
    lit = cycles > 1e-3 * cycles.max()
    within = np.abs(luxel[lit] - cycles[lit]) <= 0.1 * cycles[lit]
    return {"name": view.name, "mean_ratio": float(luxel[lit].mean() / cycles[lit].mean()),
            "within_10_percent": float(within.mean()), "surface_pixels": int(lit.sum())}


STUDIES = (
    Study("levels", levels, {
        "quick": dict(names=["steelribs"], density=0.25, threshold=0.01, shots=50),
        "cpu": dict(names=[], density=0.5, threshold=0.01, shots=600),
        "gpu": dict(names=[], density=1.0, threshold=0.01, shots=0)}),
    Study("level-views", level_views, {
        "quick": dict(names=["steelribs"], density=0.25, threshold=0.01, shots=50, views=1,
                      samples=4, lightmap_samples=4, resolution=[64, 36]),
        "cpu": dict(names=["steelribs"], density=0.5, threshold=0.01, shots=600, views=2,
                    samples=64, lightmap_samples=64, resolution=[160, 90]),
        "gpu": dict(names=[], density=1.0, threshold=0.01, shots=0, views=3, samples=2048,
                    lightmap_samples=256, resolution=[320, 180])}, blender=True),
)

if __name__ == "__main__":
    common.main(__doc__.split("\n\n")[0], STUDIES)
