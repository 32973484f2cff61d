"""Materials as Cycles sees them (addon/materials.py): node trees Luxel once read by hand, or
could not, against Cycles' own bakes of the same lightmap UVs.

Truths: Cycles' DIFFUSE bake with only the COLOR pass (the albedo) and with DIRECT + INDIRECT
+ COLOR (the lightmap), both of the user's own objects through addon/reference.py at more
samples than Luxel's evaluation takes, and the analytic integral of a linear gradient."""
import importlib
import math

import numpy as np
import pytest

import blender_scenes
import blender_session

bpy = blender_session.blender()
reference = importlib.import_module(blender_session.MODULE + ".addon.reference")
addon = blender_session.addon().addon

SUN = 3.0                   # W/m^2, straight down
DENSITY = 8.0               # texels per metre: a 2 m plane is 16 x 16 texels


def textured_material(name, build):
    """A Principled BSDF (specular 0, roughness 1) whose base colour ``build(tree)`` wires."""
    mat = blender_scenes.material(name, (0.5, 0.5, 0.5))
    tree = mat.node_tree
    tree.links.new(build(tree), tree.nodes["Principled BSDF"].inputs["Base Color"])
    return mat


def checker_image():
    """A 16 x 16 image of 4 x 4 squares, orange and blue-grey."""
    image = bpy.data.images.new("checker", 16, 16, float_buffer=True)
    y, x = np.mgrid[0:16, 0:16]
    odd = ((x // 4 + y // 4) % 2).astype(bool)
    pixels = np.where(odd[..., None], (0.7, 0.35, 0.1, 1.0), (0.15, 0.25, 0.35, 1.0))
    image.pixels.foreach_set(pixels.astype(np.float32).ravel())
    return image


def through_mapping(tree):
    """Image through a Mapping node: scale 4, rotation 30 degrees, UV coordinates."""
    coordinates = tree.nodes.new("ShaderNodeTexCoord")
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (4.0, 4.0, 1.0)
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(30.0))
    image = tree.nodes.new("ShaderNodeTexImage")
    image.image = checker_image()
    tree.links.new(coordinates.outputs["UV"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], image.inputs["Vector"])
    return image.outputs["Color"]


def noise_ramp(tree):
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 2.0
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.1, 0.15, 0.3, 1.0)
    ramp.color_ramp.elements[1].color = (0.7, 0.7, 0.75, 1.0)
    tree.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    return ramp.outputs["Color"]


def vertex_colours(tree):
    attribute = tree.nodes.new("ShaderNodeVertexColor")
    attribute.layer_name = "Paint"
    return attribute.outputs["Color"]


def node_group(tree):
    """A group mixing two colours by a gradient of the object's coordinates."""
    group = bpy.data.node_groups.new("Tint", "ShaderNodeTree")
    group.interface.new_socket("Colour", in_out='OUTPUT', socket_type='NodeSocketColor')
    inside = group.nodes
    output = inside.new("NodeGroupOutput")
    gradient = inside.new("ShaderNodeTexGradient")
    mix = inside.new("ShaderNodeMix")
    mix.data_type = 'RGBA'
    mix.inputs["A"].default_value = (0.6, 0.2, 0.2, 1.0)
    mix.inputs["B"].default_value = (0.2, 0.5, 0.3, 1.0)
    group.links.new(gradient.outputs["Fac"], mix.inputs["Factor"])
    group.links.new(mix.outputs["Result"], output.inputs["Colour"])
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    return node.outputs["Colour"]


MATERIALS = {"Mapped": through_mapping, "Ramp": noise_ramp, "Painted": vertex_colours,
             "Grouped": node_group}


def planes_scene():
    """Four 2 m planes side by side, each with one material, under a sun straight down."""
    scene = blender_session.empty_file()
    for index, (name, build) in enumerate(MATERIALS.items()):
        x = 2.5 * index
        plane = blender_scenes.quad(scene, name, [(x, 0, 0), (x + 2, 0, 0), (x + 2, 2, 0),
                                                  (x, 2, 0)], textured_material(name, build))
        plane.data.uv_layers.new(name="UVMap")
        if name == "Painted":
            paint = plane.data.color_attributes.new("Paint", 'FLOAT_COLOR', 'CORNER')
            for corner, colour in zip(paint.data, ((0.8, 0.1, 0.1, 1), (0.1, 0.8, 0.1, 1),
                                                   (0.1, 0.1, 0.8, 1), (0.7, 0.7, 0.1, 1))):
                corner.color = colour
    blender_scenes.light(scene, "Sun", 'SUN', (0, 0, 5), energy=SUN)
    blender_scenes.luxel_settings(scene, DENSITY, threshold=0.01)
    return scene


def bake_keeping_albedo():
    """Bake the current scene with Luxel; returns the albedo pages it solved with."""
    job = addon.bake.BakeJob(bpy.context)
    try:
        while not job.step(1.0):
            pass
        albedo_pages = job.export.scene.albedo_textures
        job.finish()
    except BaseException:
        job.release()
        raise
    return albedo_pages


def albedo_against_cycles(obj, albedo_pages, colour):
    """The object's albedo per texel Cycles' DIFFUSE COLOR bake ``colour`` covers, and
    Cycles', checked within 2 % RMS of Cycles' mean; returns both (N, 3)."""
    page = int(obj.luxel.image[addon.writeback.PAGE_KEY])
    covered = colour[..., 3] > 0
    truth = colour[covered][:, :3].astype(np.float64)
    ours = albedo_pages[page][covered] * addon.materials.TEXTURE_TINT
    relative = (ours - truth) / truth.mean(axis=0)
    assert np.sqrt((relative ** 2).mean()) < 0.02, obj.name
    return ours, truth


def test_albedo_of_any_node_tree_is_cycles_diffuse_colour_per_texel():
    """Per texel, the albedo Luxel solves with is Cycles' own DIFFUSE COLOR bake of the same
    UVs (2 % RMS, 1 % in the mean: both are sampled, Luxel's at 32 samples a texel), and each
    lightmap is a Cycles DIFFUSE bake's within 5 % in the mean and RMS per texel (the tiling
    a Mapping node makes leaves the mean as it is)."""
    scene = planes_scene()
    albedo_pages = bake_keeping_albedo()
    colour = reference.cycles_reference(bpy.context, samples=256, pass_filter={'COLOR'})
    lit = reference.cycles_reference(bpy.context, samples=256, bounces=4)
    for name in MATERIALS:
        obj = scene.objects[name]
        ours, truth = albedo_against_cycles(obj, albedo_pages, colour[name])
        np.testing.assert_allclose(ours.mean(axis=0), truth.mean(axis=0), rtol=0.01,
                                   err_msg=name)
        mean = reference.object_means({name: lit[name]})[name]
        np.testing.assert_allclose(mean.luxel, mean.cycles, rtol=0.05, err_msg=name)
        covered = lit[name][..., 3] > 0
        lightmap = reference.luxel_lightmap(obj)[covered][:, :3]
        relative = (lightmap - lit[name][covered][:, :3]) / mean.cycles
        assert np.sqrt((relative ** 2).mean()) < 0.05, name


def test_constant_materials_of_many_objects_bake_as_cycles_colour_per_texel():
    """Materials that cannot vary over a surface are evaluated in one Cycles bake of the
    objects joined (addon/materials.py, _joined): per texel each object's albedo is still
    Cycles' own DIFFUSE COLOR bake of its UVs, for objects turned and scaled, one with two
    material slots and a face whose slot number lies past its last slot (Blender shows it
    with the last), and beside them one whose material varies (baked alone)."""
    scene = blender_session.empty_file()
    colours = {"Red": (0.7, 0.1, 0.1), "Green": (0.1, 0.6, 0.2), "Blue": (0.15, 0.2, 0.7),
               "Grey": (0.5, 0.5, 0.5)}
    materials = {name: blender_scenes.material(name, colour) for name, colour in colours.items()}
    # The slots' object first: a slot number past its own would reach the others'.
    slots = blender_scenes.mesh_object(
        scene, "Slots", [(0, 3, 0), (2, 3, 0), (2, 5, 0), (0, 5, 0), (4, 3, 0), (4, 5, 0),
                         (6, 3, 0), (6, 5, 0)],
        [(0, 1, 2, 3), (1, 4, 5, 2), (4, 6, 7, 5)], materials["Blue"])
    slots.data.materials.append(materials["Grey"])
    slots.data.polygons.foreach_set("material_index", [0, 1, 7])
    red = blender_scenes.quad(scene, "Red", [(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0)],
                              materials["Red"])
    green = blender_scenes.quad(scene, "Green", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)],
                                materials["Green"])
    green.location, green.scale = (3.0, 0.0, 0.0), (2.0, 1.5, 1.0)
    green.rotation_euler = (0.0, 0.0, math.radians(30.0))
    varying = blender_scenes.quad(scene, "Ramp", [(7, 0, 0), (9, 0, 0), (9, 2, 0), (7, 2, 0)],
                                  textured_material("Ramp", noise_ramp))
    for obj in (red, green, slots, varying):
        obj.data.uv_layers.new(name="UVMap")
    blender_scenes.light(scene, "Sun", 'SUN', (0, 0, 5), energy=SUN)
    blender_scenes.luxel_settings(scene, DENSITY, threshold=0.01)
    albedo_pages = bake_keeping_albedo()
    colour = reference.cycles_reference(bpy.context, samples=64, pass_filter={'COLOR'})
    for name in ("Red", "Green", "Slots", "Ramp"):
        albedo_against_cycles(scene.objects[name], albedo_pages, colour[name])
    # The slots' faces: blue, then grey twice (the third's slot is past the last).
    slot_colours = colour["Slots"][colour["Slots"][..., 3] > 0][:, :3]
    assert np.isclose(slot_colours, colours["Blue"], atol=1e-3).all(axis=1).mean() > 0.2
    assert np.isclose(slot_colours, colours["Grey"], atol=1e-3).all(axis=1).mean() > 0.5


def test_emission_of_a_procedural_texture_emits_its_integral():
    """A 2 m plane emitting a linear gradient (0 to 1 across it, Generated coordinates) at
    strength 4 from both faces: 2 pi A 4 / 2 watts per channel."""
    scene = blender_session.empty_file()
    mat = bpy.data.materials.new("Glow")
    tree = mat.node_tree
    tree.nodes.clear()
    gradient = tree.nodes.new("ShaderNodeTexGradient")
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 4.0
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(gradient.outputs["Color"], emission.inputs["Color"])
    tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    blender_scenes.quad(scene, "Panel", [(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0)], mat)
    blender_scenes.luxel_settings(scene, DENSITY)
    job = addon.bake.BakeJob(bpy.context)
    try:
        job.set_up()
        emitted = job.solver.ledger().emitted
    finally:
        job.release()
    np.testing.assert_allclose(emitted, 2.0 * math.pi * 4.0 * 4.0 * 0.5, rtol=0.01)


SIGN_COLOUR = (0.2, 0.5, 0.8)


def test_letters_thinner_than_a_texel_get_their_colour_on_every_texel_they_touch():
    """Extruded text at 10 cm texels, its strokes and sides a few centimetres wide (the
    interior's sign), under a slanting sun: on every texel a letter touches (where Cycles,
    baking 4 x 4 sub-texels a texel, finds it) Luxel's albedo is the material's colour, and
    its lightmap's mean is Cycles' DIFFUSE bake's mean over the same sub-texels within 5 %.
    Cycles writes a texel only where its centre lies on a triangle: texels a stroke only
    crossed took no colour, and their lightmap was black."""
    scene = blender_session.empty_file()
    text = bpy.data.curves.new("Sign", "FONT")
    text.body, text.extrude, text.size = "LUXEL", 0.02, 0.4
    text.materials.append(blender_scenes.material("Sign", SIGN_COLOUR))
    sign = bpy.data.objects.new("Sign", text)
    scene.collection.objects.link(sign)
    blender_scenes.light(scene, "Sun", 'SUN', (0, 0, 5), rotation=(0.5, 0.3, 0.0),
                         energy=SUN)
    blender_scenes.luxel_settings(scene, 10.0)
    albedo_pages = bake_keeping_albedo()
    cycles = reference.cycles_reference(bpy.context, samples=16, bounces=4, copies=True,
                                        supersample=4)["Sign"]
    touched = cycles[..., 3] > 0
    page = reference.luxel_page(scene, "Sign")
    albedo = albedo_pages[int(page[addon.writeback.PAGE_KEY])][touched]
    np.testing.assert_allclose(albedo * addon.materials.TEXTURE_TINT,
                               np.broadcast_to(SIGN_COLOUR, albedo.shape), rtol=0.01)
    mean = reference.object_means({"Sign": cycles})["Sign"]
    np.testing.assert_allclose(mean.luxel, mean.cycles, rtol=0.05)


def test_evaluation_leaves_the_file_as_it_was_also_when_it_fails(monkeypatch):
    """No temporary scene, object, mesh, material or image stays, the user's render settings
    and active UV maps are untouched, after a bake and after a failing one."""
    scene = planes_scene()
    scene.cycles.samples = 7
    active = {obj.name: obj.data.uv_layers.active.name for obj in scene.objects
              if obj.type == 'MESH'}

    def blocks():
        return {kind: sorted(block.name for block in getattr(bpy.data, kind))
                for kind in ("scenes", "objects", "meshes", "materials", "images")}

    before = blocks()
    job = addon.bake.BakeJob(bpy.context)
    job.set_up()
    job.release()
    assert blocks() == before
    assert scene.cycles.samples == 7 and bpy.context.scene == scene

    def fail(*args, **kwargs):
        raise RuntimeError("Cycles failed")
    monkeypatch.setattr(addon.materials, "fill_gutter", fail)
    with pytest.raises(addon.bake.BakeError, match="evaluating the materials"):
        addon.bake.BakeJob(bpy.context).set_up()
    assert blocks() == before
    assert active == {obj.name: obj.data.uv_layers.active.name for obj in scene.objects
                      if obj.type == 'MESH'}


@pytest.mark.parametrize("wall_colour", [(0.8, 0.75, 0.7), (0.4, 0.26, 0.15)],
                         ids=["light", "dark"])
def test_light_that_glossy_layers_reflect_lights_the_other_surfaces(wall_colour):
    """A room and a block of Blender's default Principled BSDF (Specular IOR Level 0.5,
    Roughness 0.5), lit by a point light: each object's mean within 3 % of a Cycles DIFFUSE
    bake, its lightmap showing only the diffuse share while the glossy layer's light reaches
    the others as if diffuse (dropped, they were 11-17 % dark). Dark walls, whose glossy
    share is a larger part of what they reflect, tell the normal-incidence share from the
    white-sky one (docs/glossy-layers.md: the block came out 5 % bright
    with the white-sky share)."""
    scene = blender_session.empty_file()
    walls = blender_scenes.material("Walls", wall_colour, specular=0.5, roughness=0.5)
    cube = blender_scenes.material("Cube", (0.3, 0.5, 0.7), specular=0.5, roughness=0.5)
    blender_scenes.block(scene, "Room", (0, 0, 1.5), (4, 4, 3), walls).data.flip_normals()
    blender_scenes.quad(scene, "Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], walls)
    blender_scenes.block(scene, "Block", (0.6, 0.4, 0.5), (1, 1, 1), cube)
    blender_scenes.light(scene, "Lamp", 'POINT', (-0.8, -0.6, 2.6), energy=300.0)
    blender_scenes.luxel_settings(scene, 6.0, threshold=0.005)
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    cycles = reference.cycles_reference(bpy.context, samples=128, bounces=32)
    for name, mean in reference.object_means(cycles).items():
        np.testing.assert_allclose(mean.luxel, mean.cycles, rtol=0.03, err_msg=name)



@pytest.mark.parametrize("elevation", [35.0, 60.0])
def test_a_sunlit_glossy_floor_lights_a_wall_low_beside_it_as_in_cycles(elevation):
    """A black floor of the default specular layer (Specular IOR Level 0.5, Roughness 0.5)
    under a sun 35 or 60 degrees up, and a wall 0.5 m high facing the sun, shaded from it by
    a black overhang: all the wall's light is the floor's glossy reflection of the sun, which
    reaches it below 35 degrees. Its mean within 5 % of a Cycles DIFFUSE bake (the bake to
    0.1 % unshot without the ambient term, which in a scene this open outweighs the wall's
    light at 60 degrees). A Phong lobe about the mirror direction gave it 0.59 and 0.18 of
    Cycles': GGX's lobe sends light that comes in at a slant mostly nearer the horizon
    (native/lobes.py)."""
    scene = blender_session.empty_file()
    floor = blender_scenes.material("GlossyBlack", (0.0, 0.0, 0.0), specular=0.5,
                                    roughness=0.5)
    black = blender_scenes.material("Black", (0.0, 0.0, 0.0))
    white = blender_scenes.material("White", (0.8, 0.8, 0.8))
    blender_scenes.quad(scene, "Floor", [(-1.5, -2.0, 0), (1.5, -2.0, 0), (1.5, 0.6, 0),
                                         (-1.5, 0.6, 0)], floor)
    blender_scenes.quad(scene, "Wall", [(-1.0, 0.5, 0), (1.0, 0.5, 0), (1.0, 0.5, 0.5),
                                        (-1.0, 0.5, 0.5)], white)
    blender_scenes.quad(scene, "Overhang", [(-1.3, -0.5, 0.5), (-1.3, 0.6, 0.5),
                                            (1.3, 0.6, 0.5), (1.3, -0.5, 0.5)], black)
    sun = blender_scenes.light(scene, "Sun", 'SUN', (0, 0, 3), energy=3.0)
    up = math.radians(elevation)
    blender_scenes.aim(sun, (0.0, math.cos(up), 3.0 - math.sin(up)))   # travelling to +y
    blender_scenes.luxel_settings(scene, 10.0, threshold=0.001)
    scene.luxel.ambient = False
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    cycles = reference.cycles_reference(bpy.context, samples=128, bounces=8,
                                        objects=[bpy.data.objects["Wall"]])
    wall = reference.object_means(cycles)["Wall"]
    assert wall.luxel == pytest.approx(wall.cycles, rel=0.05)


@pytest.mark.parametrize("modifier", (None, 'SUBSURF'), ids=("as made", "subdivided"))
def test_a_mesh_without_a_uv_map_looks_the_same_after_a_bake_and_shows_that_albedo(tmp_path,
                                                                                     modifier):
    """A plane made without a UV map (a script's, an import's) whose material reads Texture
    Coordinate > UV through a Mapping node into an image renders one flat colour (its UVs
    are 0 without a map). After a bake, with Show Baked Lighting off, its render is the same
    to the bit: the lightmap's map did not become its render map (it did: 77 % apart; with
    a Subdivision Surface, the map Luxel's modifier adds did: a checker of standard
    deviation 0.19 over a flat 0.41). On, with the sun off, it shows that flat colour's light
    as path tracing does (the albedo was read through Luxel's temporary map)."""
    from test_blender_back_faces import render_centre
    scene = blender_session.empty_file()
    plane = blender_scenes.quad(scene, "Plane", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)],
                                textured_material("Plane", through_mapping))
    if modifier is not None:
        plane.modifiers.new("Modifier", modifier)
    sun = blender_scenes.light(scene, "Sun", 'SUN', (0, 0, 5), energy=SUN)
    blender_scenes.luxel_settings(scene, DENSITY, threshold=0.01)
    assert len(plane.data.uv_layers) == 0
    before = render_centre(scene, tmp_path, 2.0, looking_up=False)
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    assert render_centre(scene, tmp_path, 2.0, looking_up=False) == before
    scene.luxel.show_baked = True
    sun.hide_render = True
    assert render_centre(scene, tmp_path, 2.0, looking_up=False) == pytest.approx(before,
                                                                                  rel=0.03)
    scene.luxel.show_baked = False
    bpy.ops.luxel.remove_lightmaps()
    assert len(plane.data.uv_layers) == 0
