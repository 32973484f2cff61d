"""Levels as users bring them into Blender: an OBJ through Blender's importer (one object of
many material groups, a brush without a material, no UV map, a zero-area triangle, coordinates
20 km from the origin), and the same level through a glTF round trip. Lit by a sun and a
uniform sky, every open floor face is the truth rho * (S cos(theta) + pi * L_sky) / pi within
3 % (nothing above it but the sky), and the bake's warnings name what it repaired."""
import importlib
import math

import numpy as np

import blender_scenes
import blender_session
from test_blender_gltf import bilinear

bpy = blender_session.blender()
addon = blender_session.addon().addon
writeback = importlib.import_module(blender_session.MODULE + ".addon.writeback")

OFFSET = (20000.0, 3.0, -20000.0)   # OBJ axes (y up): 20 km east and north
SUN_STRENGTH, SUN_ELEVATION = 3.0, math.radians(50.0)
SKY = 0.4
COLOURS = {"red": (0.7, 0.2, 0.1), "green": (0.2, 0.6, 0.3), "grey": (0.5, 0.5, 0.5)}
DEFAULT_ALBEDO = 0.8    # Blender's grey, where a face has no material
# Floor tiles, 8 m a side, in OBJ's (x, z), and their material (None: one the .mtl file
# lacks, as a level editor's export names its untextured faces).
TILES = [((0, 0), "red"), ((8, 0), "green"), ((0, 8), None), ((8, 8), "grey"),
         ((16, 0), "red"), ((16, 8), None)]
TILE = 8.0


def write_level(folder):
    """The level as a level editor's OBJ export: one object, 'usemtl' groups, no UVs."""
    x0, y0, z0 = OFFSET
    lines, vertices = ["mtllib level.mtl"], []

    def vertex(x, y, z):
        vertices.append(f"v {x0 + x:.4f} {y0 + y:.4f} {z0 + z:.4f}")
        return len(vertices)

    faces = []
    for (x, z), colour in TILES:
        corners = [vertex(x, 0, z), vertex(x, 0, z + TILE), vertex(x + TILE, 0, z + TILE),
                   vertex(x + TILE, 0, z)]
        faces.append(("usemtl " + (colour or "untextured"), "f " + " ".join(map(str, corners))))
    # A brush block in a far corner, and a zero-area triangle (three points on a line).
    block = [vertex(22 + dx, dy, 14 + dz) for dy in (0, 1.5) for dz in (0, 1.5)
             for dx in (0, 1.5)]
    for face in ((4, 5, 7, 6), (0, 2, 3, 1), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2),
                 (1, 3, 7, 5)):
        faces.append(("usemtl grey", "f " + " ".join(str(block[i]) for i in face)))
    line = [vertex(3, 0.5, 3), vertex(4, 0.5, 3), vertex(5, 0.5, 3)]
    faces.append(("usemtl grey", "f " + " ".join(map(str, line))))
    # A brush the editor gave no material: an object of its own, before any 'usemtl' (after
    # one, faces keep the last).
    bare = [vertex(24, 0, 0), vertex(24, 0, TILE), vertex(24 + TILE, 0, TILE),
            vertex(24 + TILE, 0, 0)]
    lines += vertices + ["o bare", "f " + " ".join(map(str, bare)), "o level"]
    for group, face in faces:
        lines += [group, face]
    (folder / "level.obj").write_text("\n".join(lines) + "\n")
    materials = []
    for name, colour in COLOURS.items():
        materials += [f"newmtl {name}", "Kd " + " ".join(map(str, colour)), "Ks 0 0 0",
                      "Ns 0", "illum 1"]
    (folder / "level.mtl").write_text("\n".join(materials) + "\n")
    return folder / "level.obj"


def light_the_level(scene):
    lamp = blender_scenes.light(scene, "Sun", 'SUN', (0, 0, 10), energy=SUN_STRENGTH)
    lamp.data.angle = 0.0
    toward_sun = (math.cos(SUN_ELEVATION), 0.0, math.sin(SUN_ELEVATION))
    blender_scenes.aim(lamp, tuple(p - d for p, d in zip(lamp.location, toward_sun)))
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (SKY, SKY, SKY, 1.0)
    background.inputs["Strength"].default_value = 1.0
    scene.world.color = (SKY,) * 3


def albedo_of(material):
    """What Cycles renders a face with: its Principled BSDF's base colour, Blender's grey
    where the face has no material."""
    if material is None:
        return np.full(3, DEFAULT_ALBEDO)
    shader = next(node for node in material.node_tree.nodes if node.type == 'BSDF_PRINCIPLED')
    return np.array(shader.inputs["Base Color"].default_value[:3])


def open_tiles(obj):
    """{face index: albedo} of the floor's tiles (normal up; quads, or two triangles each)."""
    slots = [slot.material for slot in obj.material_slots] or [None]
    turn = obj.matrix_world.to_3x3()
    return {polygon.index: albedo_of(slots[polygon.material_index])
            for polygon in obj.data.polygons
            if polygon.area > 30.0 and (turn @ polygon.normal).normalized().z > 0.99}


def lightmap_at_centres(obj, faces):
    """The lightmap at each face's centre (the mean of its corners' lightmap UVs: the tiles are
    squares, charted affinely), bilinear as a material reads it."""
    pixels = writeback.image_pixels(obj.luxel.image)[..., :3]
    layer = obj.data.uv_layers[obj.luxel.uv_map]
    centres = np.array([np.mean([layer.data[loop].uv[:] for loop in
                                 obj.data.polygons[index].loop_indices], axis=0)
                        for index in faces])
    return dict(zip(faces, bilinear(pixels, centres[:, 0], centres[:, 1])))


def bake_and_check(scene, capsys):
    light_the_level(scene)
    meshes = sorted((obj for obj in scene.objects if obj.type == 'MESH'),
                    key=lambda obj: len(obj.data.polygons))
    assert len(meshes) == 2 and not any(obj.data.uv_layers for obj in meshes)
    bare, level = meshes
    capsys.readouterr()
    assert addon.cli.execute(["bake", "--density", "1", "--threshold", "0.01"]) == 0
    printed = capsys.readouterr().out
    warnings = [line for line in printed.splitlines() if line.startswith("luxel: warning")]
    assert any(f"'{level.name}'" in line and "zero area" in line for line in warnings), printed
    assert any(f"'{bare.name}'" in line and "without a material" in line
               for line in warnings), printed
    truth_factor = (SUN_STRENGTH * math.sin(SUN_ELEVATION) + math.pi * SKY) / math.pi
    albedos = set()
    for obj in meshes:
        tiles = open_tiles(obj)
        assert tiles, obj.name
        for index, value in lightmap_at_centres(obj, tiles).items():
            np.testing.assert_allclose(value, tiles[index] * truth_factor, rtol=0.03,
                                       err_msg=f"{obj.name} face {index}")
            albedos.add(tuple(np.round(tiles[index], 3)))
    assert len(albedos) == 4    # red, green, grey, and Blender's grey where none was given


def test_an_obj_level_bakes_to_its_truth_and_names_what_was_repaired(tmp_path, capsys):
    scene = blender_session.empty_file()
    bpy.ops.wm.obj_import(filepath=str(write_level(tmp_path)))
    bake_and_check(scene, capsys)


def test_the_level_through_gltf_bakes_the_same(tmp_path, capsys):
    scene = blender_session.empty_file()
    bpy.ops.wm.obj_import(filepath=str(write_level(tmp_path)))
    path = tmp_path / "level.glb"
    bpy.ops.export_scene.gltf(filepath=str(path), export_format='GLB', export_texcoords=False)
    scene = blender_session.empty_file()
    bpy.ops.import_scene.gltf(filepath=str(path))
    for obj in [o for o in scene.objects if o.type != 'MESH']:
        bpy.data.objects.remove(obj)
    bake_and_check(scene, capsys)
