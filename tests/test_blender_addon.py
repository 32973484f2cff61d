"""The extension inside Blender (the bpy module, headless): registration, export, bake,
write-back, the baked-lighting switch, renders alongside Luxel's GL context, the command line."""
import dataclasses
import importlib
import math
import os
from types import SimpleNamespace

import numpy as np
import pytest

import blender_scenes
import blender_session

bpy = blender_session.blender()
reference = importlib.import_module(blender_session.MODULE + ".addon.reference")


# ------------------------------------------------------------------ scene helpers
material, mesh_object, light = (blender_scenes.material, blender_scenes.mesh_object,
                                blender_scenes.light)
lightmap_pixels = reference.luxel_lightmap


def cube(scene, name, size, location, mat=None, inward=False):
    h = size / 2
    vertices = [(x, y, z) for x in (-h, h) for y in (-h, h) for z in (-h, h)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    if inward:
        faces = [face[::-1] for face in faces]
    obj = mesh_object(scene, name, vertices, faces, mat)
    obj.location = location
    return obj


def room_scene(with_light=True):
    """A closed 4 m room with a block floating 10 cm over its floor and a point light."""
    scene = blender_session.empty_file()
    cube(scene, "room", 4.0, (0, 0, 2), material("walls", (0.6, 0.6, 0.6)), inward=True)
    cube(scene, "block", 1.0, (0.5, 0.3, 0.6), material("block", (0.5, 0.2, 0.2)))
    if with_light:
        light(scene, "lamp", 'POINT', (-0.8, -0.6, 3.0), energy=400.0)
    scene.luxel.texel_density = 6.0
    scene.luxel.threshold = 0.02
    return scene


def mesh_snapshot(scene):
    return {obj.name: (len(obj.data.vertices), len(obj.data.polygons),
                       [v.co[:] for v in obj.data.vertices],
                       [slot.material.name if slot.material else None
                        for slot in obj.material_slots])
            for obj in scene.objects if obj.type == 'MESH'}


def node_tree_snapshot():
    """Everything about every material's nodes that a user could see or render."""
    state = {}
    for mat in bpy.data.materials:
        tree = mat.node_tree
        nodes = []
        for node in tree.nodes:
            inputs = []
            for socket in node.inputs:
                value = getattr(socket, "default_value", None)
                inputs.append((socket.identifier, tuple(value) if hasattr(value, "__len__")
                               else value))
            nodes.append((node.name, node.bl_idname, node.label, tuple(node.location),
                          getattr(node, "is_active_output", None), tuple(inputs)))
        links = sorted((l.from_node.name, l.from_socket.identifier, l.to_node.name,
                        l.to_socket.identifier) for l in tree.links)
        active = tree.nodes.active.name if tree.nodes.active else None
        state[mat.name] = (nodes, links, active, sorted(mat.keys()))
    return state


def texels_of(obj):
    """Lightmap texels under the object's UV triangles' centroids (one per face corner fan)."""
    mesh = obj.data
    image = obj.luxel.image
    uv = np.empty(len(mesh.loops) * 2)
    mesh.uv_layers[obj.luxel.uv_map].uv.foreach_get("vector", uv)
    uv = uv.reshape(-1, 2)
    pixels = lightmap_pixels(obj)
    values = []
    for polygon in mesh.polygons:
        centre = uv[list(polygon.loop_indices)].mean(axis=0)
        x, y = (centre * image.size).astype(int)
        values.append(pixels[y, x, :3])
    return np.array(values)


def run_cli(argv):
    return blender_session.addon().addon.cli.execute(argv)


class RecordingLayout:
    """Stands in for a panel's UILayout: records the properties drawn, in any sub-layout."""

    def __init__(self, drawn=None):
        self.drawn = [] if drawn is None else drawn

    def column(self, **_):
        return RecordingLayout(self.drawn)

    row = column

    def prop(self, data, name, **_):
        self.drawn.append(name)

    def operator(self, *_, **__):
        pass

    label = operator


def drawn_render_settings(scene):
    """The scene.luxel properties that the render panel and its sub-panels draw."""
    panels = blender_session.addon().addon.panels
    layout = RecordingLayout()
    for panel in (panels.LUXEL_PT_render, panels.LUXEL_PT_render_visibility,
                  panels.LUXEL_PT_render_subdivision):
        panel.draw(SimpleNamespace(layout=layout), SimpleNamespace(scene=scene))
    return layout.drawn


# --------------------------------------------------------------------------- tests
def test_enable_disable_repeatedly_leaves_nothing_registered():
    import addon_utils
    for _ in range(3):
        addon_utils.disable(blender_session.MODULE)
        assert not hasattr(bpy.types.Scene, "luxel")
        assert not hasattr(bpy.types.Object, "luxel")
        assert not hasattr(bpy.types, "LUXEL_OT_bake")
        assert not hasattr(bpy.types, "LUXEL_PT_render")
        addon_utils.enable(blender_session.MODULE, default_set=True)
        assert hasattr(bpy.types.Scene, "luxel") and hasattr(bpy.types, "LUXEL_OT_bake")
    room_scene()
    assert bpy.ops.luxel.bake.poll()


def test_bake_writes_finite_lightmaps_and_uv_maps_and_leaves_meshes_alone():
    scene = room_scene()
    before = mesh_snapshot(scene)
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    assert mesh_snapshot(scene) == before
    for name in ("room", "block"):
        obj = scene.objects[name]
        assert obj.luxel.uv_map in obj.data.uv_layers
        assert obj.luxel.image is not None
        values = texels_of(obj)
        assert np.isfinite(values).all()
        assert (values.sum(axis=1) > 0).all(), f"{name} has an unlit face"
    stats = scene.luxel.stats
    assert stats.valid and stats.texels > 0 and stats.shots > 0
    assert stats.unshot <= 100 * scene.luxel.threshold or stats.shots == scene.luxel.max_shots


def test_rebake_replaces_results_and_leaves_no_orphans():
    scene = room_scene()
    bpy.ops.luxel.bake()
    block = scene.objects["block"]
    block.luxel.receive = False
    images_before = {image.name for image in bpy.data.images}
    bpy.ops.luxel.bake()
    assert "LuxelLightmap" not in block.data.uv_layers
    assert block.luxel.image is None and block.luxel.uv_map == ""
    assert {image.name for image in bpy.data.images} == images_before
    assert all(image.users > 0 for image in bpy.data.images)


def test_rebake_leaves_a_copy_of_a_baked_mesh_alone():
    """A copy the user keeps of a baked mesh (an asset, a backup) shares its arrays with it
    until either is written: a re-bake must write the baked mesh's own UVs, not the copy's."""
    scene = room_scene()
    bpy.ops.luxel.bake()
    room = scene.objects["room"]
    kept = room.data.copy()
    kept.use_fake_user = True

    def uvs(mesh):
        values = np.empty(len(mesh.loops) * 2)
        mesh.uv_layers["LuxelLightmap"].uv.foreach_get("vector", values)
        return values
    before = uvs(kept)
    scene.luxel.texel_density *= 1.5            # the re-bake lays the room out anew
    bpy.ops.luxel.bake()
    assert not np.array_equal(uvs(room.data), before)
    np.testing.assert_array_equal(uvs(kept), before)


def test_point_light_on_the_floor_matches_cos_over_r_squared():
    """Dark walls (rho 0.1): right under the lamp the texel holds rho I cos / (pi d^2) plus a
    bounce of about rho^2 P / (pi A (1 - rho)) = 1.5 % of the room's light, 13 % of that."""
    scene = room_scene()
    scene.objects["block"].hide_render = True
    walls = bpy.data.materials["walls"].node_tree.nodes["Principled BSDF"]
    walls.inputs["Base Color"].default_value = (0.1, 0.1, 0.1, 1.0)
    bpy.ops.luxel.bake()
    room = scene.objects["room"]
    pixels = lightmap_pixels(room)
    uv = np.empty(len(room.data.loops) * 2)
    room.data.uv_layers["LuxelLightmap"].uv.foreach_get("vector", uv)
    floor = next(p for p in room.data.polygons if p.normal.z > 0.9 and p.center.z < 0.01)
    loops = list(floor.loop_indices)
    corners_uv = uv.reshape(-1, 2)[loops]
    corners = np.array([room.matrix_world @ room.data.vertices[v].co for v in floor.vertices])
    # The texel at the point of the floor right under the lamp, by bilinear inverse on the
    # axis-aligned floor square.
    s = (-0.8 - corners[:, 0].min()) / 4.0
    t = (-0.6 - corners[:, 1].min()) / 4.0
    order = np.lexsort((corners[:, 1], corners[:, 0]))  # (-,-), (-,+), (+,-), (+,+)
    c = corners_uv[order]
    point = (1 - s) * (1 - t) * c[0] + (1 - s) * t * c[1] + s * (1 - t) * c[2] + s * t * c[3]
    x, y = (point * room.luxel.image.size).astype(int)
    direct = 0.1 * 400.0 / (4 * math.pi) / math.pi / 3.0 ** 2
    measured = pixels[y, x, 0]
    assert direct < measured < 1.25 * direct


def test_bake_reports_a_scene_without_light_and_changes_nothing():
    scene = room_scene(with_light=False)
    before = mesh_snapshot(scene)
    with pytest.raises(RuntimeError, match="no light"):
        bpy.ops.luxel.bake()
    assert mesh_snapshot(scene) == before
    assert not any("LuxelLightmap" in obj.data.uv_layers for obj in scene.objects
                   if obj.type == 'MESH')
    assert not bpy.data.images


def test_cancelled_bake_leaves_the_scene_as_it_was():
    scene = room_scene()
    addon = blender_session.addon().addon
    job = addon.bake.BakeJob(bpy.context)
    job.step(0.2)
    job.release()           # what Esc does in the modal operator
    assert not bpy.data.images
    assert not any("LuxelLightmap" in obj.data.uv_layers for obj in scene.objects
                   if obj.type == 'MESH')
    assert not scene.luxel.stats.valid


def test_hidden_instanced_and_modified_objects_export_as_they_render():
    scene = room_scene()
    export = blender_session.addon().addon.export
    hidden = cube(scene, "hidden", 0.5, (1, 1, 1), material("grey", (0.5, 0.5, 0.5)))
    hidden.hide_render = True
    off_render = bpy.data.collections.new("off render")
    scene.collection.children.link(off_render)
    off_render.objects.link(cube(bpy.context.scene, "in hidden collection", 0.3, (1, 0, 1)))
    scene.collection.objects.unlink(bpy.data.objects["in hidden collection"])
    off_render.hide_render = True
    cube(scene, "hidden in viewport", 0.3, (-1, 0, 1)).hide_set(True)
    arrayed = cube(scene, "arrayed", 0.2, (-1, 1, 0.1), material("grey2", (0.5, 0.5, 0.5)))
    modifier = arrayed.modifiers.new("array", 'ARRAY')
    modifier.count = 3
    collection = bpy.data.collections.new("props")
    prop = cube(bpy.context.scene, "prop", 0.3, (0, 0, 0), material("grey3", (0.4,) * 3))
    bpy.context.scene.collection.objects.unlink(prop)
    collection.objects.link(prop)
    instancer = bpy.data.objects.new("instancer", None)
    instancer.instance_type = 'COLLECTION'
    instancer.instance_collection = collection
    instancer.location = (1.2, -1.2, 0.15)
    scene.collection.objects.link(instancer)

    result = export.export_scene(bpy.context)
    names = result.scene.object_names
    assert "hidden" not in names and "in hidden collection" not in names
    assert any("'hidden in viewport' renders but is hidden in the viewport" in warning
               for warning in result.warnings)
    assert not any("in hidden collection" in warning for warning in result.warnings)
    arrayed_index = names.index("arrayed")
    assert (result.scene.object_index == arrayed_index).sum() == 3 * 12
    instance_index = names.index("instancer/prop")
    corners = result.scene.vertices[result.scene.triangles[
        result.scene.object_index == instance_index]]
    np.testing.assert_allclose(corners.reshape(-1, 3).mean(axis=0), (1.2, -1.2, 0.15), atol=1e-6)
    # The modified object and the instance get lightmaps of what renders, with no warning.
    receivers = {receiver.object_name for receiver in result.receivers}
    assert receivers == {"room", "block", "arrayed", "prop"}
    sources = {r.object_name: (r.uv_source, r.instancer_name) for r in result.receivers}
    assert sources["arrayed"] == ('SNAPSHOT', "arrayed")
    assert sources["prop"][1] == "instancer"
    assert not any("arrayed" in warning or "prop" in warning for warning in result.warnings)


def test_back_faces_receive_on_emitting_sheets_unless_set_otherwise():
    """Auto: an emitting plane (a lamp modelled as a sheet) receives on its back; a closed
    emitting cube and a plain plane do not. On and Off override it per object."""
    scene = room_scene()
    lamp = mesh_object(scene, "lamp_sheet", [(0, 0, 3.9), (1, 0, 3.9), (1, 1, 3.9), (0, 1, 3.9)],
                       [(0, 3, 2, 1)], material("glow", (0.8, 0.8, 0.8), emission=(1.0, 1.0, 1.0), strength=5.0))
    plane = mesh_object(scene, "plane", [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)],
                        [(0, 1, 2, 3)], material("grey", (0.5, 0.5, 0.5)))
    cube(scene, "glow_cube", 0.2, (1, 1, 1), bpy.data.materials["glow"])
    export = blender_session.addon().addon.export

    def backs():
        exported = export.export_scene(bpy.context).scene
        return {name: bool(exported.receive_back[exported.object_index == index].any())
                for index, name in enumerate(exported.object_names)}

    assert backs() == {"room": False, "block": False, "lamp_sheet": True, "plane": False,
                       "glow_cube": False}
    lamp.luxel.back_faces, plane.luxel.back_faces = 'OFF', 'ON'
    assert backs()["lamp_sheet"] is False and backs()["plane"] is True


def test_blender_lights_export_in_cycles_units():
    scene = room_scene(with_light=False)
    export = blender_session.addon().addon.export
    light(scene, "panel", 'AREA', (0, 0, 3.5), energy=20.0, shape='RECTANGLE', size=0.5,
          size_y=0.25)
    # -Z turned to +Y
    light(scene, "spot", 'SPOT', (1, 0, 3), (math.radians(90), 0, 0), energy=100.0,
          spot_size=math.radians(60), spot_blend=0.3)

    result = export.export_scene(bpy.context).scene
    panel = result.object_index == result.object_names.index("panel")
    # Area light: radiance P / (pi A), one-sided, facing -Z, casting no shadow.
    np.testing.assert_allclose(result.emission[panel], 20.0 / (math.pi * 0.125), rtol=1e-6)
    assert not result.occlude[panel].any() and not result.emission_two_sided[panel].any()
    corners = result.vertices[result.triangles[panel]]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    assert (normals[:, 2] < 0).all()
    spot = next(l for l in result.lights if l.name == "spot")
    np.testing.assert_allclose(spot.direction, (0, 1, 0), atol=1e-6)
    assert spot.spot_size == pytest.approx(math.radians(60)) and spot.power == 100.0


def test_world_colour_is_a_uniform_sky():
    scene = room_scene(with_light=False)
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1.0)
    background.inputs["Strength"].default_value = 2.0
    result = blender_session.addon().addon.export.export_scene(bpy.context).scene
    np.testing.assert_allclose(result.sky, (0.4, 0.8, 1.2), rtol=1e-6)


def test_workbench_renders_between_and_during_bakes_change_nothing(tmp_path):
    scene = room_scene()
    scene.render.engine = 'BLENDER_WORKBENCH'
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.location = (0, -1.9, 1.5)
    camera.rotation_euler = (math.radians(90), 0, 0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    bpy.ops.luxel.bake()
    first = lightmap_pixels(scene.objects["room"]).copy()

    renders = []

    def render():
        renders.append(tmp_path / f"render{len(renders)}.png")
        scene.render.filepath = str(renders[-1])
        bpy.ops.render.render(write_still=True)

    render()
    job = blender_session.addon().addon.bake.BakeJob(bpy.context)
    job.step(0.3)
    render()            # Blender's GL in the middle of Luxel's bake
    while not job.step(1.0):
        pass
    job.finish()
    render()
    second = lightmap_pixels(scene.objects["room"])
    np.testing.assert_allclose(second, first, rtol=1e-5, atol=1e-7)
    for path in renders:
        image = bpy.data.images.load(str(path))
        assert tuple(image.size) == (64, 48)
        assert max(image.pixels[:]) > 0.0


def test_show_baked_lighting_on_then_off_restores_node_trees_exactly():
    scene = room_scene()
    bpy.ops.luxel.bake()
    walls = bpy.data.materials["walls"]
    before = node_tree_snapshot()
    scene.luxel.show_baked = True
    output = next(n for n in walls.node_tree.nodes if n.bl_idname == 'ShaderNodeOutputMaterial'
                  and n.is_active_output)
    either = output.inputs["Surface"].links[0].from_node
    assert either.bl_idname == 'ShaderNodeMixShader'      # baked, or the material's own
    shown = either.inputs[2].links[0].from_node
    assert shown.bl_idname == 'ShaderNodeEmission'
    texture = shown.inputs["Color"].links[0].from_node
    assert texture.image == scene.objects["room"].luxel.image
    assert walls.node_tree.nodes.active == texture          # what Workbench shows
    scene.luxel.show_baked = False
    assert node_tree_snapshot() == before


def test_every_solver_setting_in_the_scene_reaches_the_native_settings():
    scene = room_scene()
    non_defaults = {
        "texel_density": 12.5, "max_atlas_size": 1024, "hemicube_resolution": 64,
        "shoot_level": 3, "threshold": 0.25, "max_shots": 77, "projection": "NONLINEAR",
        "neighbour_visibility": False, "subdivision": "ADAPTIVE", "subdivision_level": 3,
        "subdivision_shadow_min": 0.25, "subdivision_shadow_max": 0.75,
        "adaptive_shoot_level": True, "ambient": False, "patch_size": 0.5,
    }
    native = blender_session.addon().native
    exposed = {field.name for field in dataclasses.fields(native.Settings)
               if field.name in scene.luxel.bl_rna.properties}
    assert exposed == set(non_defaults)
    properties = scene.luxel.bl_rna.properties
    assert tuple(properties["projection"].enum_items.keys()) == native.PROJECTIONS
    assert tuple(properties["subdivision"].enum_items.keys()) == native.SUBDIVISIONS
    defaults = dataclasses.asdict(native.Settings())
    assert all(defaults[name] != value for name, value in non_defaults.items())
    for name, value in non_defaults.items():
        setattr(scene.luxel, name, value)
    assert dataclasses.asdict(scene.luxel.solver_settings()) == {**defaults, **non_defaults}


def as_stored(value):
    """A declared value as a Blender property holds it: a float in single precision."""
    return float(np.float32(value)) if isinstance(value, float) else value


def test_the_scene_properties_are_the_declared_settings():
    """Each solver setting in scene.luxel has the label, help, default and range or choices
    that native/settings.py declares, and a fresh scene hands the solver those defaults."""
    scene = blender_session.empty_file()
    declared = blender_session.addon().native.settings
    properties = scene.luxel.bl_rna.properties
    for setting in declared.EXPOSED_SETTINGS:
        prop = properties[setting.name]
        assert (prop.name, prop.description) == (setting.exposed.label, setting.help)
        assert prop.type == {bool: 'BOOLEAN', str: 'ENUM', int: 'INT', float: 'FLOAT'}[
            setting.kind], setting.name
        if setting.kind in (bool, str):
            assert prop.default == setting.default, setting.name
            assert [(item.identifier, item.name, item.description)
                    for item in getattr(prop, "enum_items", [])] == [
                (choice.identifier, choice.label, choice.help) for choice in setting.choices]
            continue
        assert prop.default == as_stored(setting.default), setting.name
        # Blender's limits where none is given: INT_MIN, INT_MAX or -FLT_MAX, FLT_MAX.
        unbounded = (2**31 - 1 if setting.kind is int else
                     float(np.finfo(np.float32).max))
        assert prop.hard_min == (-unbounded - (setting.kind is int) if setting.lowest is None
                                 else as_stored(setting.lowest)), setting.name
        assert prop.hard_max == (unbounded if setting.maximum is None else
                                 as_stored(setting.maximum)), setting.name
        if setting.soft_maximum is not None:
            assert prop.soft_max == as_stored(setting.soft_maximum), setting.name
        assert prop.subtype == setting.exposed.subtype, setting.name
        if setting.exposed.digits is not None:
            assert prop.precision == setting.exposed.digits, setting.name
    given = dataclasses.asdict(scene.luxel.solver_settings())
    for setting in declared.SETTINGS:
        assert given[setting.name] == as_stored(setting.default), setting.name


def test_the_command_line_sets_each_declared_setting_to_a_bound_unclamped():
    """Each exposed setting's option reaches scene.luxel: a number at the end of its range
    that is furthest from the default, a switch the other way, the last choice."""
    declared = blender_session.addon().native.settings
    cli = blender_session.addon().addon.cli
    scene = blender_session.empty_file()
    argv, expected = ["bake"], {}
    for setting in declared.EXPOSED_SETTINGS:
        if setting.exposed.option is None:   # set by its pair's option, below
            continue
        if setting.kind is bool:
            expected[setting.name] = not setting.default
            argv.append(("--" if expected[setting.name] else "--no-")
                        + setting.exposed.option[2:])
            continue
        expected[setting.name] = (setting.choices[-1].identifier if setting.choices else
                                  setting.minimum if setting.maximum is None else
                                  setting.maximum)
        argv += [setting.exposed.option, str(expected[setting.name])]
    for pair in declared.SETTING_PAIRS:
        low = declared.SETTINGS_BY_NAME[pair.lower].minimum
        high = declared.SETTINGS_BY_NAME[pair.upper].maximum
        expected.update({pair.lower: low, pair.upper: high})
        argv += [pair.option, str(low), str(high)]
    assert set(expected) == {setting.name for setting in declared.EXPOSED_SETTINGS}
    cli._apply_bake_options(cli._parser().parse_args(argv), scene.luxel)
    for name, value in expected.items():
        assert value != declared.SETTINGS_BY_NAME[name].default, name
        assert getattr(scene.luxel, name) == as_stored(value), name
    # Blender hands the bounds over in single precision: the solver takes them.
    scene.luxel.solver_settings().validate()


def test_render_panel_shows_the_subdivision_settings_that_apply():
    scene = room_scene()
    thresholds = {"subdivision_shadow_min", "subdivision_shadow_max"}
    always = {"projection", "neighbour_visibility", "adaptive_shoot_level", "subdivision"}
    for subdivision, shown, hidden in (("NONE", set(), thresholds | {"subdivision_level"}),
                                       ("REGULAR", {"subdivision_level"}, thresholds),
                                       ("ADAPTIVE", thresholds | {"subdivision_level"}, set())):
        scene.luxel.subdivision = subdivision
        drawn = set(drawn_render_settings(scene))
        assert drawn <= set(scene.luxel.bl_rna.properties.keys())
        assert always | shown <= drawn and not hidden & drawn, subdivision


def test_cli_rejects_a_bad_argument_and_a_scene_without_light(capsys):
    room_scene()
    assert run_cli(["bake", "--shots", "many"]) != 0
    assert "--shots" in capsys.readouterr().err
    assert run_cli(["bake", "--threshold", "2"]) != 0
    assert "--threshold" in capsys.readouterr().err
    room_scene(with_light=False)
    assert run_cli(["bake"]) != 0
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "no light" in error[0]


def test_cli_rejects_bad_visibility_and_subdivision_options_with_one_line(capsys):
    scene = room_scene()
    for argv, option in ((["--subdivision-level", "9"], "--subdivision-level"),
                         (["--subdivision-level", "-1"], "--subdivision-level"),
                         (["--shadow-range", "0.9", "0.1"], "--shadow-range"),
                         (["--shadow-range", "0.5", "1.5"], "--shadow-range"),
                         (["--shadow-range", "0.5"], "--shadow-range"),
                         (["--subdivision", "FINE"], "--subdivision"),
                         (["--projection", "SPHERE"], "--projection")):
        assert run_cli(["bake", *argv]) == 2, argv
        error = capsys.readouterr().err.strip().splitlines()
        assert len(error) == 1 and option in error[0], argv
    assert scene.luxel.subdivision == "NONE" and not scene.luxel.stats.valid


def test_cli_applies_the_visibility_and_subdivision_options(capsys):
    scene = room_scene()
    assert run_cli(["bake", "--projection", "NONLINEAR", "--no-neighbour-visibility",
                    "--subdivision", "ADAPTIVE", "--subdivision-level", "1",
                    "--shadow-range", "0.25", "0.75", "--adaptive-shoot-level", "--no-ambient",
                    "--density", "4", "--shots", "5"]) == 0
    assert "luxel: done" in capsys.readouterr().out
    settings = scene.luxel
    assert settings.projection == "NONLINEAR" and not settings.neighbour_visibility
    assert settings.subdivision == "ADAPTIVE" and settings.subdivision_level == 1
    assert (settings.subdivision_shadow_min, settings.subdivision_shadow_max) == (0.25, 0.75)
    assert settings.adaptive_shoot_level and not settings.ambient and settings.max_shots == 5
    assert settings.stats.valid and 0 < settings.stats.shots <= 5


def test_cli_bake_saves_the_blend_with_packed_lightmaps(tmp_path, capsys):
    scene = room_scene()
    path = tmp_path / "room.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    assert run_cli(["bake", "--density", "4", "--threshold", "0.05", "--save"]) == 0
    out = capsys.readouterr().out
    assert "luxel: done" in out and "saved" in out
    bpy.ops.wm.open_mainfile(filepath=str(path))
    room = bpy.context.scene.objects["room"]
    assert room.luxel.image is not None and room.luxel.image.packed_file is not None
    assert room.luxel.uv_map in room.data.uv_layers
    assert bpy.context.scene.luxel.texel_density == 4.0
    assert np.isfinite(lightmap_pixels(room)).all() and lightmap_pixels(room)[..., :3].max() > 0


def test_cli_bake_writes_exr_files_next_to_the_blend(tmp_path):
    room_scene()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "room.blend"))
    assert run_cli(["bake", "--density", "4", "--threshold", "0.05", "--output",
                    str(tmp_path / "maps")]) == 0
    files = sorted(p.name for p in (tmp_path / "maps").iterdir())
    # The lightmap and the irradiance it reflects (what glTF export writes).
    assert files == ["Luxel_Scene_0.exr", "Luxel_Scene_0_Irradiance.exr"]
    from native import read_exr
    pixels = read_exr(str(tmp_path / "maps" / files[0]))
    np.testing.assert_allclose(pixels[..., :3],
                               lightmap_pixels(bpy.context.scene.objects["room"])[..., :3],
                               rtol=1e-3, atol=1e-6)


def workbench_render(scene, path):
    """Workbench's render of the camera view in its Texture colour with Show Baked Lighting
    (what the viewport's Solid mode shows), as a PNG."""
    render, shading = scene.render, scene.display.shading
    render.engine = 'BLENDER_WORKBENCH'
    render.filepath = path
    render.image_settings.file_format = 'PNG'
    shading.light = 'FLAT'
    shading.color_type = 'TEXTURE'
    scene.luxel.show_baked = True
    bpy.ops.render.render(write_still=True)
    scene.luxel.show_baked = False


@pytest.mark.parametrize("renderer", ("workbench", "the command line's preview"))
def test_renders_show_the_lightmap_beside_a_uv_map_of_the_users(tmp_path, renderer):
    """The user's UV map (all corners at 0, 0) stays theirs; Workbench (through the active
    UV map) and the --preview render show the lightmap."""
    scene = blender_session.empty_file()
    plane = mesh_object(scene, "plane", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)],
                        [(0, 1, 2, 3)], material("plane", (0.5, 0.5, 0.5)))
    plane.data.uv_layers.new(name="UVMap")
    light(scene, "spot", 'SPOT', (0, 0, 2), energy=300.0, spot_size=math.radians(60))
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.location = (0, 0, 6)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x = scene.render.resolution_y = 64
    scene.luxel.texel_density = 8
    bpy.ops.luxel.bake()
    assert plane.data.uv_layers.active.name == "UVMap"

    path = tmp_path / "preview.png"
    if renderer == "workbench":
        workbench_render(scene, str(path))
    else:
        blender_session.addon().addon.cli.render_preview(scene, str(path))
    image = bpy.data.images.load(str(path))
    pixels = np.array(image.pixels[:]).reshape(64, 64, 4)
    assert pixels[32, 32, :3].min() > 0.3            # lit under the spot
    assert pixels[2, 2, :3].max() < pixels[32, 32, :3].min() / 4   # outside its cone
    assert plane.data.uv_layers.active.name == "UVMap" and not scene.luxel.show_baked


def test_rebake_while_baked_lighting_is_shown_reads_the_users_materials():
    scene = room_scene()
    bpy.ops.luxel.bake()
    first = lightmap_pixels(scene.objects["room"]).copy()
    before = node_tree_snapshot()
    scene.luxel.show_baked = True
    bpy.ops.luxel.bake()
    np.testing.assert_allclose(lightmap_pixels(scene.objects["room"]), first, rtol=1e-5,
                               atol=1e-7)
    scene.luxel.show_baked = False
    assert node_tree_snapshot() == before


def test_image_texture_albedo_is_sampled_through_the_materials_uv_map():
    """An 8 x 1 sRGB image (dark left half, light right half) as base colour, under a sun
    straight down of strength S: each half reflects rho S / pi, rho the linearised pixel."""
    scene = blender_session.empty_file()
    image = bpy.data.images.new("albedo", 8, 1)
    image.pixels.foreach_set([0.5, 0.25, 0.125, 1.0] * 4 + [0.75, 0.75, 0.75, 1.0] * 4)
    mat = material("textured", (0.5, 0.5, 0.5))
    texture = mat.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    mat.node_tree.links.new(texture.outputs["Color"],
                            mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    floor = mesh_object(scene, "floor", [(-2, -1, 0), (0, -1, 0), (0, 1, 0), (-2, 1, 0),
                                         (2, -1, 0), (2, 1, 0)],
                        [(0, 1, 2, 3), (1, 4, 5, 2)], mat)
    layer = floor.data.uv_layers.new(name="UVMap")
    corners_u = {0: 0.0, 1: 0.5, 2: 0.5, 3: 0.0, 4: 1.0, 5: 1.0}
    for loop in floor.data.loops:
        layer.data[loop.index].uv = (corners_u[loop.vertex_index], 0.5)
    light(scene, "sun", 'SUN', (0, 0, 5), energy=3.0)
    scene.luxel.texel_density = 8
    bpy.ops.luxel.bake()

    def linear(value):
        return value / 12.92 if value <= 0.04045 else ((value + 0.055) / 1.055) ** 2.4

    left, right = texels_of(floor)
    np.testing.assert_allclose(left, [linear(v) * 3.0 / math.pi for v in (0.5, 0.25, 0.125)],
                               rtol=0.02)
    np.testing.assert_allclose(right, [linear(0.75) * 3.0 / math.pi] * 3, rtol=0.02)


def test_cornell_box_sample_bakes_every_receiving_face_and_keeps_the_meshes():
    bpy.ops.wm.open_mainfile(filepath=str(blender_session.ROOT / "sample_blends" /
                                          "cornell_box.blend"))
    scene = bpy.context.scene
    scene.luxel.texel_density = 40.0
    scene.luxel.threshold = 0.02
    before = mesh_snapshot(scene)
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    assert mesh_snapshot(scene) == before
    receivers = [obj for obj in scene.objects if obj.type == 'MESH']
    assert len(receivers) == 8
    for obj in receivers:
        assert obj.luxel.uv_map == "LuxelLightmap" and "LuxelLightmap" in obj.data.uv_layers
        values = texels_of(obj)
        assert np.isfinite(values).all()
        assert (values.max(axis=1) > 0).all(), f"{obj.name} has a face left black"


def test_the_readme_quotes_what_make_bake_prints(capsys):
    """README.md's quote of `make bake` (tools/readme_outputs.py writes it) is what the same
    bake prints today, seconds aside: its numbers cannot drift from the code's."""
    import readme_outputs
    bpy.ops.wm.open_mainfile(filepath=str(blender_session.ROOT / "sample_blends" /
                                          "cornell_box.blend"))
    previous = os.getcwd()
    os.chdir(blender_session.ROOT)
    try:
        assert run_cli(readme_outputs.BAKE_ARGUMENTS) == 0
    finally:
        os.chdir(previous)
    printed = readme_outputs.quoted_lines(capsys.readouterr().out)
    assert readme_outputs.comparable(printed) == readme_outputs.comparable(
        readme_outputs.readme_quote())
