"""Back faces in Blender: a sheet whose back faces are solved (Back Faces On) shows their light
when seen from behind, in a Cycles render of Show Baked Lighting; a closed mesh whose normals
point inwards is baked on the side that is seen, while a room modelled as a box seen from
within keeps its inward faces."""
import importlib
import math

import numpy as np
import pytest

import blender_scenes
import blender_session
from test_blender_addon import texels_of
from test_blender_parity import assert_close, print_table

bpy = blender_session.blender()
addon = blender_session.addon().addon
reference = importlib.import_module(blender_session.MODULE + ".addon.reference")

ALBEDO = 0.5
POWER = 100.0


def sheet_lit_from_behind():
    """A 2 m sheet at z = 1 facing up, a point light 0.5 m under its centre, a dark floor."""
    scene = blender_session.empty_file()
    blender_scenes.quad(scene, "Sheet", [(-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)],
                        blender_scenes.material("Sheet", (ALBEDO,) * 3))
    blender_scenes.quad(scene, "Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)],
                        blender_scenes.material("Floor", (0.05,) * 3))
    blender_scenes.light(scene, "Lamp", 'POINT', (0.0, 0.0, 0.5), energy=POWER)
    blender_scenes.luxel_settings(scene, 16.0, threshold=0.01)
    scene.objects["Sheet"].luxel.back_faces = 'ON'
    return scene


def render_centre(scene, tmp_path, height, looking_up):
    """The mean of the central 8 x 8 pixels of a Cycles render of Show Baked Lighting from
    (0, 0, height), straight up or down (linear EXR, no view transform)."""
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, 0.0, height)
    camera.rotation_euler = (math.pi if looking_up else 0.0, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.engine = 'CYCLES'
    scene.cycles.samples = 4
    scene.cycles.use_denoising = False
    scene.render.resolution_x = scene.render.resolution_y = 32
    scene.view_settings.view_transform = 'Standard'
    scene.render.image_settings.file_format = 'OPEN_EXR'
    path = tmp_path / f"render-{'up' if looking_up else 'down'}.exr"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(path))
    pixels = np.array(image.pixels[:]).reshape(32, 32, 4)
    bpy.data.images.remove(image)
    bpy.data.objects.remove(camera)
    return pixels[12:20, 12:20, :3].mean()


def test_back_faces_that_are_solved_are_shown_from_behind(tmp_path):
    scene = sheet_lit_from_behind()
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    sheet = scene.objects["Sheet"]
    assert "LuxelLightmapBack" in sheet.data.uv_layers
    scene.luxel.show_baked = True
    # Direct light on the back right above the lamp: rho I / (pi d^2), I = P / (4 pi); the
    # dark floor adds under 1 % and the view's 8 x 8 pixels span 4 degrees of cos^3 falloff.
    direct = ALBEDO * POWER / (4 * math.pi) / (math.pi * 0.5 ** 2)
    from_below = render_centre(scene, tmp_path, 0.25, looking_up=True)
    assert 0.97 * direct < from_below < 1.05 * direct
    from_above = render_centre(scene, tmp_path, 2.0, looking_up=False)
    assert from_above < 0.05 * direct
    scene.luxel.show_baked = False
    bpy.ops.luxel.remove_lightmaps()
    assert "LuxelLightmapBack" not in sheet.data.uv_layers


def baked(*, write=True):
    """A bake of the context's scene through a BakeJob, whose warnings it keeps: written
    into the file, or released once set up and shot."""
    job = addon.bake.BakeJob(bpy.context)
    while not job.step(1.0):
        pass
    if write:
        job.finish()
    else:
        job.release()
    return job


def closed_cube(scene, name, centre, size, mat, inwards):
    (cx, cy, cz), half = centre, size / 2
    vertices = [(cx + x * half, cy + y * half, cz + z * half)
                for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    if inwards:
        faces = [tuple(reversed(face)) for face in faces]
    return blender_scenes.mesh_object(scene, name, vertices, faces, mat)


def stage_with_cube(inwards):
    scene = blender_scenes.point_scene()
    bpy.data.objects.remove(scene.objects["Block"])
    closed_cube(scene, "Cube", (0.3, 0.5, 0.41), 0.8,
                blender_scenes.material("Cube", (0.2, 0.3, 0.6)), inwards)
    return scene


def test_a_closed_mesh_with_inward_normals_bakes_its_outside_like_cycles_sees_it():
    stage_with_cube(inwards=False)
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    cycles = reference.object_means(reference.cycles_reference(bpy.context, samples=256,
                                                               bounces=32))
    stage_with_cube(inwards=True)
    job = baked()
    assert any(w.startswith("'Cube' is a closed mesh whose normals point inwards")
               for w in job.warnings)
    # Luxel's means over the texels a Cycles bake covers (one sample: only its coverage is
    # used), against the Cycles means of the cube with its normals outwards.
    luxel = reference.object_means(reference.cycles_reference(bpy.context, samples=1,
                                                              bounces=0))
    for name, mean in luxel.items():
        mean.cycles, mean.cycles_error = cycles[name].cycles, cycles[name].cycles_error
    print_table(luxel)
    assert_close(luxel, set(cycles))


def test_a_room_seen_from_inside_keeps_its_inward_faces():
    scene = blender_session.empty_file()
    closed_cube(scene, "Room", (0.0, 0.0, 1.5), 3.0, blender_scenes.material("Room", (0.5,) * 3),
                inwards=True)
    blender_scenes.light(scene, "Lamp", 'POINT', (0.2, 0.1, 2.0), energy=POWER)
    blender_scenes.luxel_settings(scene, 6.0, threshold=0.01)
    job = baked()
    assert not any("point inwards" in w for w in job.warnings)
    means = reference.object_means(reference.cycles_reference(bpy.context, samples=128,
                                                              bounces=32))
    print_table(means)
    assert_close(means, {"Room"})


def test_a_glowing_box_seen_from_inside_is_a_furnace():
    """A closed 1 m box with inward normals whose material emits 1 and reflects 0.9: its
    inside is what is seen (a furnace, a room whose walls glow), so every texel shows
    rho E / (1 - rho) = 9. It was taken for a mesh with flipped normals and baked on its
    outside, black."""
    scene = blender_session.empty_file()
    box = closed_cube(scene, "Furnace", (0.0, 0.0, 0.5), 1.0,
                      blender_scenes.material("Furnace", (0.9,) * 3, emission=(1.0,) * 3,
                                              strength=1.0), inwards=True)
    blender_scenes.luxel_settings(scene, 8.0, threshold=0.01)
    job = baked()
    assert not any("point inwards" in w for w in job.warnings)
    values = texels_of(box)
    np.testing.assert_allclose(values, 9.0, rtol=0.03)


def test_a_closed_box_around_the_camera_keeps_its_inward_faces():
    """The camera inside a closed box with inward normals sees its inside: kept, no warning
    (a light outside it reaches nothing there)."""
    scene = blender_session.empty_file()
    closed_cube(scene, "Room", (0.0, 0.0, 1.5), 3.0, blender_scenes.material("Room", (0.5,) * 3),
                inwards=True)
    blender_scenes.light(scene, "Lamp", 'POINT', (0.0, 0.0, 5.0), energy=POWER)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.5, -0.5, 1.2)
    scene.collection.objects.link(camera)
    scene.camera = camera
    blender_scenes.luxel_settings(scene, 4.0, threshold=0.01)
    job = baked()
    assert not any("point inwards" in w for w in job.warnings)
    scene.camera = None
    bpy.data.objects.remove(camera)
    job = baked(write=False)
    assert any("'Room' is a closed mesh whose normals point inwards" in w for w in job.warnings)


@pytest.mark.parametrize("slots", ([], [None]), ids=("no slot", "an empty slot"))
def test_a_mesh_without_a_material_shows_its_lightmap_and_gets_its_slots_back(tmp_path, slots):
    """A floor without a material (a level imported as one mesh; or an empty slot), baked as
    Blender's default grey: with Show Baked Lighting and the lamp off, a Cycles render shows
    what a path-traced render of it in a matte grey of 0.8 shows with the lamp on (Cycles'
    own surface for no material adds a glossy layer, which a lightmap does not hold). There
    was no material to show the lightmap in: no pixel lit. Off, its slots are as before."""
    scene = blender_session.empty_file()
    floor = blender_scenes.quad(scene, "Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)],
                                blender_scenes.material("Matte", (0.8,) * 3))
    lamp = blender_scenes.light(scene, "Lamp", 'POINT', (0.0, 0.0, 1.0), energy=POWER)
    traced = render_centre(scene, tmp_path, 3.0, looking_up=False)
    floor.data.materials.clear()
    bpy.data.materials.remove(bpy.data.materials["Matte"])
    for slot in slots:
        floor.data.materials.append(slot)
    blender_scenes.luxel_settings(scene, 8.0, threshold=0.01)
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    scene.luxel.show_baked = True
    lamp.hide_render = True
    assert render_centre(scene, tmp_path, 3.0, looking_up=False) == pytest.approx(traced,
                                                                                  rel=0.03)
    scene.luxel.show_baked = False
    assert list(floor.data.materials) == slots
    assert addon.display.FILL_MATERIAL not in bpy.data.materials


def subdivision_levels_differ(sofa):
    subdivision = sofa.modifiers.new("Subdivision", 'SUBSURF')
    assert (subdivision.levels, subdivision.render_levels) == (1, 2)   # Blender's defaults
    return "Levels Viewport 1 and Render 2"


def multires_levels_differ(sofa):
    multires = sofa.modifiers.new("Multires", 'MULTIRES')
    with bpy.context.temp_override(object=sofa, active_object=sofa):
        for _ in range(2):
            bpy.ops.object.multires_subdivide(modifier="Multires", mode='CATMULL_CLARK')
    multires.levels, multires.render_levels = 1, 2
    return "Levels Viewport 1 and Render 2"


def array_only_in_renders(sofa):
    array = sofa.modifiers.new("Array", 'ARRAY')
    array.count, array.relative_offset_displace = 2, (1.2, 0.0, 0.0)
    array.show_viewport = False
    return "is on in renders and off in the viewport"


def decimate_in_both(sofa):
    sofa.modifiers.new("Subdivision", 'SUBSURF').render_levels = 1
    sofa.modifiers.new("Decimate", 'DECIMATE').ratio = 0.5
    return None


# Modifier stacks whose viewport and render evaluations differ (and one where they agree), on
# a sofa made the usual way: a box with a Bevel of 2 segments first. (builder: what the
# bake's report names, None where nothing differs)
STACKS = {"Subdivision Surface at Blender's defaults": subdivision_levels_differ,
          "Multires": multires_levels_differ, "an Array only in renders": array_only_in_renders,
          "Decimate": decimate_in_both}


@pytest.mark.parametrize("add_stack", STACKS.values(), ids=STACKS)
def test_a_sofa_whose_modifiers_render_otherwise_shows_its_lightmap_in_a_render(tmp_path,
                                                                                 add_stack):
    """A Cycles render with Show Baked Lighting and the lamp off shows the sofa's top as a
    path-traced render does, whatever its modifiers' viewport and render settings (0.04 of it
    with Subdivision at its defaults, viewport level 1 and render 2: the bake fitted level 1,
    the render drew level 2 and showed no lightmap). The bake serves the render; its report
    names what the viewport evaluates otherwise, and the viewport's settings stay."""
    scene = blender_session.empty_file()
    blender_scenes.quad(scene, "Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)],
                        blender_scenes.material("Floor", (0.5,) * 3))
    sofa = closed_cube(scene, "Sofa", (0.0, 0.0, 0.3), 1.0,
                       blender_scenes.material("Sofa", (0.6,) * 3), inwards=False)
    sofa.scale = (1.0, 0.6, 0.6)
    bevel = sofa.modifiers.new("Bevel", 'BEVEL')
    bevel.segments, bevel.width = 2, 0.05
    named = add_stack(sofa)
    viewport = [(m.show_viewport, getattr(m, "levels", None)) for m in sofa.modifiers]
    lamp = blender_scenes.light(scene, "Lamp", 'POINT', (0.3, 0.2, 2.0), energy=POWER)
    traced = render_centre(scene, tmp_path, 2.5, looking_up=False)
    job = baked()
    reported = [w for w in job.warnings if w.startswith("'Sofa' evaluates otherwise in the viewport and in renders")]
    assert (named in reported[0]) if named else not reported
    assert [(m.show_viewport, getattr(m, "levels", None))
            for m in sofa.modifiers if m.name != addon.writeback.MODIFIER] == viewport
    scene.luxel.show_baked = True
    lamp.hide_render = True
    assert render_centre(scene, tmp_path, 2.5, looking_up=False) == pytest.approx(traced,
                                                                                  rel=0.05)


def test_geometry_nodes_reading_is_viewport_are_named_in_the_report():
    """Geometry nodes that switch on Is Viewport cannot be set to render by a bake: it fits
    their viewport geometry, and the report and the Object panel's list name the modifier."""
    scene = blender_session.empty_file()
    sofa = closed_cube(scene, "Sofa", (0.0, 0.0, 0.3), 1.0,
                       blender_scenes.material("Sofa", (0.6,) * 3), inwards=False)
    tree = bpy.data.node_groups.new("Finer For Renders", 'GeometryNodeTree')
    tree.interface.new_socket("Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
    tree.interface.new_socket("Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    given, result = tree.nodes.new('NodeGroupInput'), tree.nodes.new('NodeGroupOutput')
    finer = tree.nodes.new('GeometryNodeSubdivisionSurface')
    switch = tree.nodes.new('GeometryNodeSwitch')
    switch.input_type = 'GEOMETRY'
    viewport = tree.nodes.new('GeometryNodeIsViewport')
    tree.links.new(given.outputs[0], finer.inputs["Mesh"])
    tree.links.new(viewport.outputs[0], switch.inputs["Switch"])
    tree.links.new(finer.outputs[0], switch.inputs["False"])
    tree.links.new(given.outputs[0], switch.inputs["True"])
    tree.links.new(switch.outputs[0], result.inputs[0])
    sofa.modifiers.new("Finer", 'NODES').node_group = tree
    blender_scenes.light(scene, "Lamp", 'POINT', (0.3, 0.2, 2.0), energy=POWER)
    assert addon.evaluation.differences(sofa) == [
        "geometry nodes 'Finer' read Is Viewport (the bake fits the viewport's geometry there)"]
    job = baked(write=False)
    assert any(w.startswith("'Sofa' evaluates otherwise in the viewport and in renders") and "read Is Viewport" in w
               for w in job.warnings)
