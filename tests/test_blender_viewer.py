"""The viewer page of a bake (``--command luxel view``), rendered by headless Chromium from the
baked camera, against Cycles rendering the same view with Show Baked Lighting (each baked
surface its lightmap's emission, no bounces): the Cornell box, and a room with modifiers,
linked duplicates and collection instances. Per object (instances of one object together),
the mean within 5 % and 90 % of its pixels within 10 %, away from object edges (Cycles
filters its pixels, the page does not)."""
import importlib

import numpy as np
import OpenEXR
import pytest

import blender_scenes
import blender_session
from browser import render_viewer
from test_blender_every_object import modelled_room

bpy = blender_session.blender()
addon = blender_session.addon().addon
WIDTH, HEIGHT = 200, 150


def camera(scene, location, target, lens=35.0):
    data = bpy.data.cameras.new("Camera")
    data.lens = lens
    obj = bpy.data.objects.new("Camera", data)
    scene.collection.objects.link(obj)
    obj.location = location
    blender_scenes.aim(obj, target)
    scene.camera = obj
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100


def cycles_view(scene, path):
    """Linear radiance and object names per pixel of a Cycles render with the baked lighting
    shown (emission only: no bounces), through an EXR with the Object Index pass."""
    names = {}
    for index, obj in enumerate(o for o in scene.objects if o.type != 'CAMERA'):
        obj.pass_index = index + 1
        names[index + 1] = obj.name
    scene.view_layers[0].use_pass_object_index = True
    scene.luxel.show_baked = True
    cycles = scene.cycles
    cycles.device, cycles.samples, cycles.max_bounces = 'CPU', 16, 0
    cycles.use_adaptive_sampling = cycles.use_denoising = False
    cycles.filter_width = 0.01  # a pixel is its centre's surface, as on the page
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):     # Blender 5.0 chooses multilayer images there
        settings.media_type = 'MULTI_LAYER_IMAGE'
    settings.file_format = 'OPEN_EXR_MULTILAYER'
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    with OpenEXR.File(str(path)) as exr:    # one part per pass in Blender 5.0, before one
        channels = {name: channel.pixels for part in exr.parts
                    for name, channel in part.channels.items()}
    combined = next(pixels for name, pixels in channels.items() if "Combined" in name)
    rgb = (combined[..., :3] if combined.ndim == 3 else
           np.dstack([channels[f"ViewLayer.Combined.{c}"] for c in "RGB"]))
    index = np.rint(next(pixels for name, pixels in channels.items()
                         if "Index" in name)).astype(int)
    objects = np.vectorize(lambda i: names.get(i, ""))(index)
    return rgb, objects


def page_view(tmp_path):
    folder = tmp_path / "page"
    assert addon.cli.execute(["view", str(tmp_path / "scene.glb"), "--folder", str(folder),
                              "--no-serve"]) == 0
    measured = render_viewer(folder, WIDTH, HEIGHT)
    names = np.array(measured.names + [""])       # id -1: the background
    return measured.rgb, names[measured.ids]


def interior(objects):
    """Pixels whose four neighbours show the same object."""
    same = np.ones(objects.shape, dtype=bool)
    for axis in (0, 1):
        for step in (1, -1):
            same &= np.roll(objects, step, axis=axis) == objects
    same[[0, -1], :] = same[:, [0, -1]] = False
    return same


def compare(scene, tmp_path, expected_objects):
    page, page_objects = page_view(tmp_path)
    cycles, cycles_objects = cycles_view(scene, tmp_path / "cycles.exr")
    kept = interior(page_objects) & interior(cycles_objects) & (page_objects == cycles_objects)
    rows = {}
    for name in sorted(set(page_objects[kept].ravel()) - {""}):
        mask = kept & (page_objects == name)
        ours, theirs = page[mask].mean(axis=1), cycles[mask].mean(axis=1)
        lit = theirs > 0.01 * cycles.max()
        within = np.abs(ours[lit] - theirs[lit]) <= 0.1 * theirs[lit]
        rows[name] = (ours.mean() / theirs.mean(), within.mean() if lit.any() else 1.0,
                      int(mask.sum()))
    print("\n".join(f"{name:12s} mean ratio {ratio:.3f}, {100 * share:.0f} % within 10 %, "
                    f"{count} px" for name, (ratio, share, count) in rows.items()))
    assert expected_objects <= rows.keys()
    for name, (ratio, share, count) in rows.items():
        if count < 30:      # a sliver of a few pixels: its edges are most of it
            continue
        assert abs(ratio - 1.0) < 0.05, (name, ratio)
        assert share >= 0.9, (name, share)


def test_the_cornell_box_page_shows_what_blender_shows(tmp_path):
    scene = blender_scenes.cornell_scene(density=60.0)
    scene.luxel.threshold = 0.02
    bpy.data.objects["CornellLight"].visible_camera = False   # the page has no lamp
    camera(scene, (0.278, 0.8, 0.273), (0.278, 0.0, 0.273), lens=38.0)
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    compare(scene, tmp_path, {"Floor", "Ceiling", "BackWall", "RedWall", "GreenWall",
                              "ShortBlock", "TallBlock"})


def test_a_room_with_instances_page_shows_what_blender_shows(tmp_path):
    scene = modelled_room()
    scene.luxel.threshold = 0.02
    camera(scene, (2.6, -1.7, 1.6), (-0.5, 0.6, 0.4), lens=20.0)
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    compare(scene, tmp_path, {"Room", "Sofa", "Chair", "ChairTwin", "Stool"})


def test_the_sample_interior_opens_in_the_viewer(tmp_path):
    """sample_blends/interior.blend as users bring it (Solidify, Boolean, Bevel, Subdivision
    whose viewport level differs from the render's, Array, Mirror, linked duplicates, an
    excluded collection instanced twice, a curve, text, a textured floor with its own UV
    map), baked coarsely: every object the baked camera sees is lit on the page (a lightmap
    that missed its place would be black), and the floor's texture shows through."""
    bpy.ops.wm.open_mainfile(filepath=str(blender_session.ROOT / "sample_blends" /
                                          "interior.blend"))
    assert addon.cli.execute(["bake", "--density", "6", "--threshold", "0.05"]) == 0
    page, objects = page_view(tmp_path)
    seen = {name: page[objects == name].mean(axis=1) for name in set(objects.ravel()) - {""}}
    assert len(seen) >= 8
    for name, values in seen.items():
        if len(values) >= 30:
            assert np.median(values) > 0.0, name
    floor = next(values for name, values in seen.items() if "floor" in name.lower())
    assert np.percentile(floor, 90) > 1.5 * np.percentile(floor, 10)
