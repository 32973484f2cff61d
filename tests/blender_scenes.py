"""Small Blender scenes, one per kind of light Luxel exports, plus the Cornell box, for the
Cycles parity tests. Every receiving object has its own mesh and a clear name; the front faces
of the receivers face the light (a Cycles bake is of the front side).

Materials are Principled BSDFs with base colours well below 1 and Specular IOR Level 0, so
the albedo is the base colour exactly; ``point_scene(specular=0.5, roughness=0.5)`` is the
default Principled BSDF, whose specular layer takes about 4 % from Cycles' diffuse pass
(measured: 0.6385 against 0.6633 under a point light), as Cycles' own evaluation of the
materials gives it (addon/materials.py)."""
import math

import blender_session

bpy = blender_session.blender()
import mathutils  # noqa: E402  (after bpy)

FLOOR = (0.60, 0.55, 0.50)
BACK = (0.45, 0.55, 0.45)
SIDE = (0.60, 0.40, 0.35)
BLOCK = (0.30, 0.40, 0.60)

CORNELL_WHITE = (0.725, 0.71, 0.68)
CORNELL_RED = (0.63, 0.065, 0.05)
CORNELL_GREEN = (0.14, 0.45, 0.091)
CORNELL_LIGHT = (17.0, 12.0, 4.0)

AREA_SHAPES = {             # shape: (size, size_y)
    'SQUARE': (0.9, 0.9),
    'RECTANGLE': (1.2, 0.5),
    'DISK': (1.0, 1.0),
    'ELLIPSE': (1.3, 0.6),
}


# --------------------------------------------------------------------------------- pieces
def material(name, colour, specular=0.0, emission=None, strength=0.0, roughness=1.0):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:           # Blender before 5.0 makes it on use_nodes
        mat.use_nodes = True
    principled = mat.node_tree.nodes["Principled BSDF"]
    principled.inputs["Base Color"].default_value = (*colour, 1.0)
    principled.inputs["Roughness"].default_value = roughness
    principled.inputs["Specular IOR Level"].default_value = specular
    if emission is not None:
        principled.inputs["Emission Color"].default_value = (*emission, 1.0)
        principled.inputs["Emission Strength"].default_value = strength
    return mat


def mesh_object(scene, name, vertices, faces, mat):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, v)) for v in vertices], [], faces)
    if mat is not None:
        mesh.materials.append(mat)
    mesh.validate()
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def quad(scene, name, corners, mat):
    """A quad; corners counter-clockwise seen from its front."""
    return mesh_object(scene, name, corners, [(0, 1, 2, 3)], mat)


def block(scene, name, centre, size, mat, top=True):
    """An axis-aligned box with outward faces (no bottom: it stands on the floor)."""
    (cx, cy, cz), (sx, sy, sz) = centre, size
    x0, x1, y0, y1 = cx - sx / 2, cx + sx / 2, cy - sy / 2, cy + sy / 2
    z0, z1 = cz - sz / 2, cz + sz / 2
    vertices = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
                (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    faces = [(0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    if top:
        faces.append((4, 5, 6, 7))
    return mesh_object(scene, name, vertices, faces, mat)


def light(scene, name, kind, location, rotation=(0.0, 0.0, 0.0), energy=100.0,
          colour=(1.0, 1.0, 1.0), **settings):
    data = bpy.data.lights.new(name, kind)
    data.energy = energy
    data.color = colour
    if kind in ('POINT', 'SPOT'):
        data.shadow_soft_size = 0.0      # the units contract's point light: radius 0
    if kind == 'SUN':
        data.angle = 0.0
    for key, value in settings.items():
        setattr(data, key, value)
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    obj.rotation_euler = rotation
    scene.collection.objects.link(obj)
    return obj


def aim(obj, target):
    """Point a light's -Z at ``target``."""
    direction = mathutils.Vector(target) - obj.location
    obj.rotation_euler = direction.to_track_quat('-Z', 'Y').to_euler()


def luxel_settings(scene, density, threshold=0.005):
    settings = scene.luxel
    settings.texel_density = density
    settings.threshold = threshold
    settings.max_shots = 20000


# --------------------------------------------------------------------------------- scenes
def stage(specular=0.0, density=7.0, roughness=1.0):
    """A 4 x 4 m floor, a back wall (y = 2) and a side wall (x = -2), 2.5 m high, and a
    0.8 m block off centre: open to the front and the right, no light yet."""
    scene = blender_session.empty_file()

    def surface(name, colour):
        return material(name, colour, specular, roughness=roughness)

    quad(scene, "Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)],
         surface("Floor", FLOOR))
    quad(scene, "BackWall", [(-2, 2, 0), (2, 2, 0), (2, 2, 2.5), (-2, 2, 2.5)],
         surface("BackWall", BACK))
    quad(scene, "SideWall", [(-2, 2, 0), (-2, 2, 2.5), (-2, -2, 2.5), (-2, -2, 0)],
         surface("SideWall", SIDE))
    block(scene, "Block", (0.3, 0.5, 0.4), (0.8, 0.8, 0.8), surface("Block", BLOCK))
    luxel_settings(scene, density)
    return scene


def point_scene(specular=0.0, roughness=1.0):
    scene = stage(specular, roughness=roughness)
    light(scene, "PointLamp", 'POINT', (0.6, -0.4, 1.9), energy=400.0)
    return scene


def spot_scene():
    """A spot whose cone edge and blend fall across the floor, the block and the back wall."""
    scene = stage()
    lamp = light(scene, "SpotLamp", 'SPOT', (-0.4, -1.6, 2.3), energy=800.0,
                 spot_size=math.radians(55.0), spot_blend=0.3)
    aim(lamp, (0.2, 0.6, 0.4))
    return scene


def sun_scene():
    """A sun from the front right, 40 degrees up: the block shadows the floor and the walls."""
    scene = stage()
    lamp = light(scene, "Sun", 'SUN', (0, 0, 3), energy=3.0)
    elevation, azimuth = math.radians(40.0), math.radians(35.0)
    toward_sun = (math.cos(elevation) * math.sin(azimuth), -math.cos(elevation) *
                  math.cos(azimuth), math.sin(elevation))
    aim(lamp, tuple(p - d for p, d in zip(lamp.location, toward_sun)))
    return scene


def area_scene(shape='SQUARE'):
    """An area light of the given shape 2.2 m up, tilted towards the back wall."""
    scene = stage()
    size, size_y = AREA_SHAPES[shape]
    settings = dict(shape=shape, size=size)
    if shape in ('RECTANGLE', 'ELLIPSE'):
        settings["size_y"] = size_y
    light(scene, "AreaLamp", 'AREA', (-0.3, -0.2, 2.2), rotation=(math.radians(25.0), 0, 0),
          energy=300.0, colour=(1.0, 0.9, 0.8), **settings)
    return scene


def emissive_scene():
    """A glowing panel (Principled emission, colour x strength) hanging 1.9 m up: it lights
    the room from both faces, as Blender's emission does; it gets no lightmap itself."""
    scene = stage()
    lamp = quad(scene, "GlowPanel", [(-0.6, -0.5, 1.9), (-0.6, 0.3, 1.9), (0.4, 0.3, 1.9),
                                     (0.4, -0.5, 1.9)],
                material("Glow", (0.05, 0.05, 0.05), emission=(1.0, 0.85, 0.6), strength=12.0))
    lamp.luxel.receive = False
    return scene


def world_scene():
    """Only a uniform world colour lights the stage."""
    scene = stage()
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.4, 0.5, 0.7, 1.0)
    background.inputs["Strength"].default_value = 1.5
    scene.world.color = (0.4, 0.5, 0.7)
    return scene


def panel_room_scene():
    """A closed 4 x 3 x 2.5 m room lit by a glowing ceiling panel 1 cm under the ceiling (a
    thin gap at 7 texels/m), as offices are modelled. Its back glows into the gap, where the
    light bounces between the panel and the ceiling, and what misses the panel at its edge
    leaves into the room."""
    scene = blender_session.empty_file()
    wall = material("RoomWall", (0.8, 0.8, 0.8))
    floor = material("RoomFloor", FLOOR)
    x, y, h = 2.0, 1.5, 2.5
    centre = (0.0, 0.0, h / 2)
    for name, corners, mat in (
            ("Floor", [(-x, -y, 0), (x, -y, 0), (x, y, 0), (-x, y, 0)], floor),
            ("Ceiling", [(-x, -y, h), (x, -y, h), (x, y, h), (-x, y, h)], wall),
            ("WallSouth", [(-x, -y, 0), (x, -y, 0), (x, -y, h), (-x, -y, h)], wall),
            ("WallNorth", [(-x, y, 0), (x, y, 0), (x, y, h), (-x, y, h)], wall),
            ("WallWest", [(-x, -y, 0), (-x, y, 0), (-x, y, h), (-x, -y, h)], wall),
            ("WallEast", [(x, -y, 0), (x, y, 0), (x, y, h), (x, -y, h)], wall)):
        _face(quad(scene, name, corners, mat), centre, towards=True)
    panel = quad(scene, "Panel", [(-0.4, -0.4, h - 0.01), (0.4, -0.4, h - 0.01),
                                  (0.4, 0.4, h - 0.01), (-0.4, 0.4, h - 0.01)],
                 material("PanelGlow", (0.8, 0.8, 0.8), emission=(1.0, 0.95, 0.85),
                          strength=20.0))
    _face(panel, centre, towards=True)
    panel.luxel.receive = False
    luxel_settings(scene, 7.0)
    return scene


def cornell_scene(density=30.0):
    """The Cornell box from its published data (millimetres, y up), turned z up (Blender
    (x, y, z) = (x, -z, y) / 1000), open at the front, lit by its 130 x 105 mm light as a
    one-sided rectangular area light 0.1 mm under the ceiling with radiance 17 12 4."""
    scene = blender_session.empty_file()
    mm = 0.001

    def p(x, y, z):
        return (x * mm, -z * mm, y * mm)

    w, h, d = 552.8, 548.8, 559.2
    white = material("CornellWhite", CORNELL_WHITE)
    red = material("CornellRed", CORNELL_RED)
    green = material("CornellGreen", CORNELL_GREEN)
    centre = p(w / 2, h / 2, d / 2)
    for name, corners, mat in (
            ("Floor", [p(0, 0, 0), p(w, 0, 0), p(w, 0, d), p(0, 0, d)], white),
            ("Ceiling", [p(0, h, 0), p(0, h, d), p(w, h, d), p(w, h, 0)], white),
            ("BackWall", [p(0, 0, d), p(w, 0, d), p(w, h, d), p(0, h, d)], white),
            ("RedWall", [p(w, 0, 0), p(w, h, 0), p(w, h, d), p(w, 0, d)], red),
            ("GreenWall", [p(0, 0, 0), p(0, 0, d), p(0, h, d), p(0, h, 0)], green)):
        _face(quad(scene, name, corners, mat), centre, towards=True)
    for name, top, height in (
            ("ShortBlock", [(130, 65), (82, 225), (240, 272), (290, 114)], 165.0),
            ("TallBlock", [(423, 247), (265, 296), (314, 456), (472, 406)], 330.0)):
        corners = [p(x, height, z) for x, z in top] + [p(x, 0, z) for x, z in top]
        faces = [(0, 1, 2, 3)] + [(i, 4 + i, 4 + (i + 1) % 4, (i + 1) % 4) for i in range(4)]
        obj = mesh_object(scene, name, corners, faces, white)
        _face(obj, sum(map(mathutils.Vector, corners), mathutils.Vector()) / 8, towards=False)
    area = (343 - 213) * mm * (332 - 227) * mm
    strongest = max(CORNELL_LIGHT)
    light(scene, "CornellLight", 'AREA', p(278, 548.7, 279.5), energy=strongest * math.pi * area,
          colour=tuple(c / strongest for c in CORNELL_LIGHT), shape='RECTANGLE',
          size=(343 - 213) * mm, size_y=(332 - 227) * mm)
    luxel_settings(scene, density)
    return scene


def _face(obj, point, towards):
    """Flip the faces whose front does not face ``point`` (towards) or faces it (not)."""
    mesh = obj.data
    for polygon in mesh.polygons:
        facing = polygon.normal.dot(mathutils.Vector(point) - polygon.center) > 0
        if facing != towards:
            polygon.flip()
    mesh.update()


SCENES = {
    "panel-room": panel_room_scene,
    "point": point_scene,
    "spot": spot_scene,
    "sun": sun_scene,
    **{f"area-{shape.lower()}": (lambda shape=shape: area_scene(shape)) for shape in AREA_SHAPES},
    "emissive": emissive_scene,
    "world": world_scene,
    "cornell": cornell_scene,
}
