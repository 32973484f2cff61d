"""Build Luxel's sample scenes from scratch and save them as compressed .blend files.

Run with the Blender Python module (bpy 5.0.1):

    python sample_blends/generate.py [--output DIR] [names...]

Conventions the baker relies on: metres, Z up; Principled BSDF materials (diffuse:
Base Color, Roughness 1, Specular IOR Level 0; emitters: Emission Color x Emission
Strength); a black world; every mesh single-user, without duplicate
vertices or degenerate faces, its faces pointing out of solids and into rooms.
"""

import argparse
import math
import os
import random

import bpy
from mathutils import Vector
from mathutils.kdtree import KDTree

WHITE = (0.725, 0.71, 0.68)


# --- geometry ---------------------------------------------------------------------


def box(lo, hi, skip=(), inward=False):
    """Axis-aligned box from corner lo to corner hi. skip names faces to leave out
    ('-x', '+x', '-y', '+y', '-z', '+z'), e.g. '-z' for a box standing on the floor;
    inward=True turns the normals inside, for rooms."""
    xs, ys, zs = zip(lo, hi)
    verts = [(xs[i & 1], ys[(i >> 1) & 1], zs[(i >> 2) & 1]) for i in range(8)]
    sides = {
        "-x": (0, 4, 6, 2),
        "+x": (1, 3, 7, 5),
        "-y": (0, 1, 5, 4),
        "+y": (2, 6, 7, 3),
        "-z": (0, 2, 3, 1),
        "+z": (4, 5, 7, 6),
    }
    faces = [f[::-1] if inward else f for name, f in sides.items() if name not in skip]
    return verts, faces


def lathe(profile, segments, closed=False, flutes=0):
    """Surface of revolution about +Z from (r, z) or (r, z, depth) profile points.

    Faces point to the right of the profile's direction in the (r, z) plane, so a
    profile running counter-clockwise round a solid's cross-section gives outward
    normals. r == 0 is a pole (one vertex, a fan of triangles). depth > 0 cuts
    `flutes` concave grooves of that relative depth into the ring."""
    verts, rings = [], []
    for point in profile:
        r, z = point[0], point[1]
        depth = point[2] if len(point) > 2 else 0.0
        if r == 0:
            rings.append([len(verts)] * segments)
            verts.append((0.0, 0.0, z))
            continue
        rings.append(range(len(verts), len(verts) + segments))
        for j in range(segments):
            a = 2 * math.pi * j / segments
            rr = r * (1 - depth * 0.5 * (1 + math.cos(flutes * a)))
            verts.append((rr * math.cos(a), rr * math.sin(a), z))
    pairs = list(zip(rings, rings[1:]))
    if closed:
        pairs.append((rings[-1], rings[0]))
    faces = []
    for lo, hi in pairs:
        for j in range(segments):
            k = (j + 1) % segments
            # dict.fromkeys drops the repeated pole vertex, leaving a triangle.
            faces.append(tuple(dict.fromkeys((lo[j], lo[k], hi[k], hi[j]))))
    return verts, faces


def sphere(radius, segments, rings):
    profile = [(0.0, -radius)]
    profile += [
        (radius * math.sin(math.pi * i / rings), -radius * math.cos(math.pi * i / rings))
        for i in range(1, rings)
    ]
    profile.append((0.0, radius))
    return lathe(profile, segments)


def torus(major, minor, segments, sides):
    profile = [
        (
            major + minor * math.cos(2 * math.pi * i / sides),
            minor * math.sin(2 * math.pi * i / sides),
        )
        for i in range(sides)
    ]
    return lathe(profile, segments, closed=True)


def polygon_down(radius, sides):
    """Flat fan of `sides` triangles in the z = 0 plane, facing -Z (ceiling lights)."""
    verts = [(0.0, 0.0, 0.0)]
    verts += [
        (
            radius * math.cos(2 * math.pi * j / sides),
            radius * math.sin(2 * math.pi * j / sides),
            0.0,
        )
        for j in range(sides)
    ]
    faces = [(0, 1 + (j + 1) % sides, 1 + j) for j in range(sides)]
    return verts, faces


def plane(width, depth):
    """Quad in the z = 0 plane centred on the origin, facing +Z (ground planes)."""
    w, d = width / 2, depth / 2
    return [(-w, -d, 0.0), (w, -d, 0.0), (w, d, 0.0), (-w, d, 0.0)], [(0, 1, 2, 3)]


def rect_down(width, depth):
    """Quad in the z = 0 plane centred on the origin, facing -Z."""
    verts, faces = plane(width, depth)
    return verts, [f[::-1] for f in faces]


class MeshBuilder:
    """Collects parts (vertices, polygons, a material slot per polygon) for one mesh."""

    def __init__(self):
        self.verts, self.faces, self.mats = [], [], []

    def add(self, part, mat=0, offset=(0.0, 0.0, 0.0)):
        verts, faces = part
        base = len(self.verts)
        self.verts += [tuple(c + o for c, o in zip(v, offset)) for v in verts]
        self.faces += [tuple(base + i for i in f) for f in faces]
        self.mats += [mat] * len(faces)
        return self

    def add_oriented(self, verts, faces, point, toward, mat=0):
        """Add polygons, each wound so its normal points toward (or away from) point."""
        fixed = []
        for f in faces:
            corners = [Vector(verts[i]) for i in f]
            normal = sum(
                ((a - corners[0]).cross(b - corners[0]) for a, b in zip(corners[1:], corners[2:])),
                Vector(),
            )
            centre = sum(corners, Vector()) / len(corners)
            outward = normal.dot(centre - Vector(point)) > 0
            fixed.append(f if outward != toward else f[::-1])
        return self.add((verts, fixed), mat)

    def build(self, scene, name, materials, location=(0.0, 0.0, 0.0), rotation_z=0.0, smooth=False):
        """Create a new mesh and object; call again for another single-user copy."""
        used = sorted({i for f in self.faces for i in f})
        remap = {old: new for new, old in enumerate(used)}
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(
            [self.verts[i] for i in used], [], [[remap[i] for i in f] for f in self.faces]
        )
        mesh.polygons.foreach_set("material_index", self.mats)
        mesh.polygons.foreach_set("use_smooth", [smooth] * len(self.faces))
        for mat in materials:
            mesh.materials.append(mat)
        mesh.validate()
        mesh.update()
        obj = bpy.data.objects.new(name, mesh)
        obj.location = location
        obj.rotation_euler.z = rotation_z
        scene.collection.objects.link(obj)
        return obj


def single(part, scene, name, material, **kwargs):
    return MeshBuilder().add(part).build(scene, name, [material], **kwargs)


# --- scene setup ------------------------------------------------------------------


def new_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.preferences.filepaths.save_version = 0  # no .blend1 backups on rebuild
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.render.resolution_x, scene.render.resolution_y = 320, 240
    scene.render.resolution_percentage = 100
    # A new world lights the scene grey by default; the baker expects darkness.
    scene.world = bpy.data.worlds.new("world")
    if scene.world.node_tree is None:  # Blender before 5.0 makes it on use_nodes
        scene.world.use_nodes = True
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    background.inputs["Strength"].default_value = 1.0
    return scene


def diffuse(name, rgb):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender before 5.0 makes it on use_nodes
        mat.use_nodes = True
    mat.diffuse_color = (*rgb, 1.0)  # viewport colour
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*rgb, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    return mat


def emitter(name, rgb, strength):
    mat = diffuse(name, (0.78, 0.78, 0.78))
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Emission Color"].default_value = (*rgb, 1.0)
    bsdf.inputs["Emission Strength"].default_value = strength
    return mat


def add_camera(scene, location, target, lens=35.0):
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    cam.data.lens = lens
    cam.location = location
    cam.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam
    return cam


def add_light(scene, name, kind, energy, location, rotation=(0.0, 0.0, 0.0)):
    light = bpy.data.objects.new(name, bpy.data.lights.new(name, kind))
    light.data.energy = energy
    light.location = location
    light.rotation_euler = rotation
    scene.collection.objects.link(light)
    return light


def closed_room(scene, size, wall, floor):
    """Floor, walls and ceiling as separate inward-facing meshes of a room whose floor
    is centred on the origin."""
    sx, sy, h = size[0] / 2, size[1] / 2, size[2]
    verts, faces = box((-sx, -sy, 0.0), (sx, sy, h), inward=True)
    names = ("wall_west", "wall_east", "wall_south", "wall_north", "floor", "ceiling")
    for name, face in zip(names, faces):
        single((verts, [face]), scene, name, floor if name == "floor" else wall)


# --- scenes -----------------------------------------------------------------------


def cornell(x, y, z):
    """Cornell-box millimetres, Y up -> Blender metres, Z up. (x, y, z) -> (x, -z, y) is
    a +90 degree rotation about X, not a mirror: the red wall stays on the camera's left.
    The open front is the plane y = 0 and the box extends to y = -0.5592."""
    return (x / 1000.0, -z / 1000.0, y / 1000.0)


def build_cornell_box():
    scene = new_scene()
    white = diffuse("white", WHITE)
    red = diffuse("red", (0.63, 0.065, 0.05))
    green = diffuse("green", (0.14, 0.45, 0.091))
    light = emitter("light", (1.0, 12.0 / 17.0, 4.0 / 17.0), 17.0)  # radiance (17, 12, 4)

    inside = cornell(278.0, 274.4, 279.6)
    quads = {
        "floor": ([(552.8, 0, 0), (0, 0, 0), (0, 0, 559.2), (549.6, 0, 559.2)], white),
        "ceiling": (
            [(556, 548.8, 0), (556, 548.8, 559.2), (0, 548.8, 559.2), (0, 548.8, 0)],
            white,
        ),
        "back_wall": (
            [(549.6, 0, 559.2), (0, 0, 559.2), (0, 548.8, 559.2), (556, 548.8, 559.2)],
            white,
        ),
        "green_wall": ([(0, 0, 559.2), (0, 0, 0), (0, 548.8, 0), (0, 548.8, 559.2)], green),
        "red_wall": ([(552.8, 0, 0), (549.6, 0, 559.2), (556, 548.8, 559.2), (556, 548.8, 0)], red),
        # 0.1 mm below the ceiling so the two do not coincide; faces the floor.
        "light": (
            [(343, 548.7, 227), (343, 548.7, 332), (213, 548.7, 332), (213, 548.7, 227)],
            light,
        ),
    }
    for name, (corners, mat) in quads.items():
        verts = [cornell(*c) for c in corners]
        MeshBuilder().add_oriented(verts, [(0, 1, 2, 3)], inside, toward=True).build(
            scene, name, [mat]
        )

    blocks = {
        "short_block": [(130, 165, 65), (82, 165, 225), (240, 165, 272), (290, 165, 114)],
        "tall_block": [(423, 330, 247), (265, 330, 296), (314, 330, 456), (472, 330, 406)],
    }
    for name, top in blocks.items():
        # Four sides and the top; the bottom rests on the floor and is never seen.
        verts = [cornell(*c) for c in top] + [cornell(x, 0.0, z) for x, _, z in top]
        faces = [(0, 1, 2, 3)] + [(i, (i + 1) % 4, 4 + (i + 1) % 4, 4 + i) for i in range(4)]
        centre = sum((Vector(v) for v in verts), Vector()) / len(verts)
        MeshBuilder().add_oriented(verts, faces, centre, toward=False).build(scene, name, [white])

    # The original camera: (278, 273, -800) looking down +z, 35 mm lens, 25 mm film.
    cam = add_camera(scene, cornell(278, 273, -800), cornell(278, 273, 0))
    cam.data.sensor_fit = "VERTICAL"
    cam.data.sensor_height = 25.0
    return scene


def build_cornell_primitives():
    """A Cornell box as a user builds one from Blender's primitives, not from the published
    data: 0.555 m planes for the walls, scaled and turned default cubes standing on the floor
    for the blocks (closed, their bottoms on the floor), and a plane lamp 0.2 mm under the
    ceiling, emitting from both faces as Cycles' emission does. The equal-error study
    measures Luxel against Cycles on it as on a box it was not tuned on."""
    scene = new_scene()
    white = diffuse("white", WHITE)
    red = diffuse("red", (0.63, 0.065, 0.05))
    green = diffuse("green", (0.14, 0.45, 0.091))
    lamp = emitter("lamp", (1.0, 12.0 / 17.0, 4.0 / 17.0), 17.0)
    side = 0.555
    middle = side / 2.0

    def primitive(add, name, material, location, rotation, scale):
        add(location=location, rotation=rotation)
        obj = bpy.context.object
        obj.name = obj.data.name = name
        obj.scale = scale
        obj.data.materials.append(material)

    plane = lambda name, material, location, rotation, width=side, depth=side: primitive(
        lambda **place: bpy.ops.mesh.primitive_plane_add(size=1.0, **place), name, material,
        location, rotation, (width, depth, 1.0))
    # Default planes face +Z: each turned to face into the box.
    plane("floor", white, (middle, middle, 0.0), (0.0, 0.0, 0.0))
    plane("ceiling", white, (middle, middle, side), (math.pi, 0.0, 0.0))
    plane("back_wall", white, (middle, side, middle), (math.pi / 2.0, 0.0, 0.0))
    plane("red_wall", red, (0.0, middle, middle), (0.0, math.pi / 2.0, 0.0))
    plane("green_wall", green, (side, middle, middle), (0.0, -math.pi / 2.0, 0.0))
    plane("lamp", lamp, (middle, middle, side - 0.0002), (math.pi, 0.0, 0.0), 0.13, 0.105)
    for name, (x, y), height, turn in (("short_block", (0.185, 0.17), 0.165, -17.0),
                                       ("tall_block", (0.37, 0.35), 0.33, 17.0)):
        primitive(lambda **place: bpy.ops.mesh.primitive_cube_add(size=1.0, **place), name,
                  white, (x, y, height / 2.0), (0.0, 0.0, math.radians(turn)),
                  (0.165, 0.165, height))
    add_camera(scene, (middle, -1.0, middle), (middle, middle, middle), lens=30.0)
    return scene


def temple_column():
    """Fluted Doric column standing on z = 0: plinth, shaft with entasis, echinus, abacus."""
    shaft = [(0.40, 0.15, 0.12), (0.39, 1.70, 0.12), (0.365, 3.25, 0.12), (0.33, 4.75, 0.12)]
    echinus = [(0.37, 4.84), (0.48, 5.00)]
    return (
        MeshBuilder()
        .add(box((-0.48, -0.48, 0.0), (0.48, 0.48, 0.15), skip=("-z",)))
        # Open at both ends: plinth and abacus cover them.
        .add(lathe(shaft + echinus, segments=96, flutes=24))
        .add(box((-0.52, -0.52, 5.0), (0.52, 0.52, 5.15)))
    )


def build_temple():
    scene = new_scene()
    stone = diffuse("stone", (0.70, 0.66, 0.58))
    ground_mat = diffuse("ground", (0.35, 0.40, 0.25))
    roof_mat = diffuse("roof_tiles", (0.55, 0.25, 0.15))

    single(plane(60.0, 60.0), scene, "ground", ground_mat)

    # Stylobate: three steps, each 0.3 m high and 0.5 m narrower than the one below.
    half_x, half_y = 5.35, 7.75
    for step in range(3):
        inset = 0.5 * step
        single(
            box(
                (-half_x + inset, -half_y + inset, 0.3 * step),
                (half_x - inset, half_y - inset, 0.3 * (step + 1)),
                skip=("-z",),
            ),
            scene,
            f"stylobate_step_{step + 1}",
            stone,
        )
    floor_z = 0.9

    # Peristyle of 4 x 6 columns on a 2.4 m grid.
    column = temple_column()
    xs = [-3.6 + 2.4 * i for i in range(4)]
    ys = [-6.0 + 2.4 * j for j in range(6)]
    ring = [(x, y) for y in ys for x in xs if x in (xs[0], xs[-1]) or y in (ys[0], ys[-1])]
    for n, (x, y) in enumerate(ring, start=1):
        column.build(scene, f"column_{n:02d}", [stone], location=(x, y, floor_z), smooth=True)

    # Cella: the closed inner chamber; its top is hidden by the architrave.
    top_z = floor_z + 5.15
    single(box((-2.2, -3.4, floor_z), (2.2, 4.4, top_z), skip=("-z", "+z")), scene, "cella", stone)
    single(box((-4.3, -6.7, top_z), (4.3, 6.7, top_z + 0.9)), scene, "architrave", stone)

    # Gable roof: ridge along Y, overhanging the architrave.
    z0, z1, hx, hy = top_z + 0.9, top_z + 2.3, 4.6, 7.0
    verts = [
        (-hx, -hy, z0),
        (hx, -hy, z0),
        (0.0, -hy, z1),
        (-hx, hy, z0),
        (hx, hy, z0),
        (0.0, hy, z1),
    ]
    faces = [(0, 1, 2), (3, 5, 4), (1, 4, 5, 2), (0, 2, 5, 3), (0, 3, 4, 1)]
    MeshBuilder().add_oriented(verts, faces, (0.0, 0.0, z0 + 0.4), toward=False).build(
        scene, "roof", [roof_mat]
    )

    add_light(
        scene, "sun", "SUN", 3.0, (0.0, 0.0, 20.0), (math.radians(50), 0.0, math.radians(-35))
    )
    add_light(scene, "porch_light", "POINT", 600.0, (0.0, -5.0, floor_z + 3.5))
    add_light(scene, "side_light", "POINT", 1000.0, (-8.0, 4.0, 3.0))
    add_camera(scene, (21.0, -27.0, 9.0), (0.0, 0.0, 3.0), lens=40.0)
    return scene


def desk():
    b = MeshBuilder()
    b.add(box((-0.8, -0.4, 0.72), (0.8, 0.4, 0.75)), mat=0)
    for x in (-0.72, 0.72):
        for y in (-0.32, 0.32):
            b.add(
                box((x - 0.025, y - 0.025, 0.0), (x + 0.025, y + 0.025, 0.72), skip=("-z", "+z")),
                mat=1,
            )
    b.add(box((-0.67, 0.30, 0.30), (0.67, 0.32, 0.70)), mat=0)  # modesty panel
    b.add(box((-0.12, 0.10, 0.75), (0.12, 0.28, 0.77), skip=("-z",)), mat=2)  # monitor foot
    b.add(box((-0.03, 0.19, 0.77), (0.03, 0.22, 1.00), skip=("-z",)), mat=2)  # monitor neck
    b.add(box((-0.30, 0.15, 0.88), (0.30, 0.19, 1.22)), mat=2)  # screen
    b.add(box((-0.22, -0.30, 0.75), (0.22, -0.15, 0.77), skip=("-z",)), mat=2)  # keyboard
    b.add(box((0.45, -0.10, 0.0), (0.65, 0.30, 0.45), skip=("-z",)), mat=2)  # computer
    return b


def chair():
    """Box-built chair facing +Y."""
    b = MeshBuilder()
    b.add(box((-0.23, -0.22, 0.43), (0.23, 0.22, 0.48)))
    for x in (-0.19, 0.19):
        for y in (-0.18, 0.18):
            b.add(box((x - 0.02, y - 0.02, 0.0), (x + 0.02, y + 0.02, 0.43), skip=("-z", "+z")))
        b.add(box((x - 0.02, -0.22, 0.48), (x + 0.02, -0.18, 0.92), skip=("-z",)))  # back post
    b.add(box((-0.17, -0.215, 0.60), (0.17, -0.185, 0.88), skip=("-x", "+x")))  # backrest
    return b


def bookcase(rng):
    """Bookcase 1 m wide, 2 m high, front at y = 0 and back at y = 0.35, full of books
    of random sizes (material slots 1..4). Parts touch but never share a corner."""
    b = MeshBuilder()
    for x in (-0.49, 0.49):
        b.add(box((x - 0.01, 0.0, 0.0), (x + 0.01, 0.35, 2.0), skip=("-z",)))
    b.add(box((-0.51, -0.01, 2.0), (0.51, 0.36, 2.03)))  # top board
    b.add(box((-0.48, 0.01, 0.0), (0.48, 0.33, 0.08), skip=("-z", "-x", "+x")))  # plinth
    b.add(box((-0.48, 0.33, 0.01), (0.48, 0.35, 1.99), skip=("-x", "+x")))  # back panel
    levels = [0.08]
    for k in range(1, 5):
        z = 0.08 + 0.38 * k
        b.add(box((-0.48, 0.0, z - 0.02), (0.48, 0.33, z), skip=("-x", "+x")))
        levels.append(z)
    for z in levels:
        x = -0.47
        while True:
            width = rng.uniform(0.02, 0.05)
            if x + width > 0.47:
                break
            depth, height = rng.uniform(0.18, 0.25), rng.uniform(0.2, 0.3)
            b.add(
                box((x, 0.32 - depth, z), (x + width, 0.32, z + height), skip=("-z",)),
                mat=rng.randint(1, 4),
            )
            x += width + 0.003
    return b


def plant(pot_radius, foliage_radius, segments, rings):
    """Flower pot (a thin shell filled with soil) with a ball of foliage on the soil."""
    r, h = pot_radius, pot_radius * 1.8
    pot = [(0.0, 0.0), (0.8 * r, 0.0), (r, h), (0.92 * r, h), (0.9 * r, 0.85 * h), (0.0, 0.85 * h)]
    return (
        MeshBuilder().add(lathe(pot, segments=32), mat=0)
        # The ball sinks a little into the soil, so its pole is not on the soil's.
        .add(
            sphere(foliage_radius, segments, rings),
            mat=1,
            offset=(0.0, 0.0, 0.85 * h + 0.9 * foliage_radius),
        )
    )


def build_office():
    scene = new_scene()
    wall = diffuse("wall", WHITE)
    carpet = diffuse("carpet", (0.25, 0.27, 0.32))
    wood = diffuse("wood", (0.55, 0.38, 0.22))
    metal = diffuse("metal", (0.30, 0.30, 0.32))
    plastic = diffuse("dark_plastic", (0.05, 0.05, 0.06))
    fabric = diffuse("chair_fabric", (0.15, 0.22, 0.45))
    books = [
        diffuse(f"book_{i}", rgb)
        for i, rgb in enumerate(
            [(0.6, 0.1, 0.08), (0.1, 0.25, 0.5), (0.75, 0.65, 0.4), (0.12, 0.35, 0.15)], start=1
        )
    ]
    pot_mat = diffuse("terracotta", (0.55, 0.28, 0.16))
    leaves = diffuse("leaves", (0.10, 0.30, 0.08))
    light = emitter("ceiling_light", (1.0, 0.95, 0.85), 25.0)

    size = (12.0, 9.0, 3.0)  # x from -6 to 6, y from -4.5 to 4.5
    closed_room(scene, size, wall, carpet)

    # Two rows of four desks, chairs on the -Y side facing them.
    desk_mesh, chair_mesh = desk(), chair()
    n = 0
    for y in (-2.5, 0.5):
        for x in (-4.3, -2.6, -0.9, 0.8):
            n += 1
            desk_mesh.build(scene, f"desk_{n}", [wood, metal, plastic], location=(x, y, 0.0))
            chair_mesh.build(scene, f"chair_{n}", [fabric], location=(x, y - 0.75, 0.0))

    # Round pedestal meeting table with four chairs facing it.
    table = [
        (0.0, 0.0),
        (0.35, 0.0),
        (0.35, 0.03),
        (0.05, 0.05),
        (0.05, 0.70),
        (0.6, 0.70),
        (0.6, 0.74),
        (0.0, 0.74),
    ]
    table_at = Vector((3.8, 1.2, 0.0))
    single(lathe(table, segments=64), scene, "meeting_table", wood, location=table_at)
    for k in range(4):
        a = math.pi / 4 + k * math.pi / 2
        where = table_at + Vector((math.cos(a), math.sin(a), 0.0))  # 1 m from the centre
        chair_mesh.build(
            scene, f"chair_{n + k + 1}", [fabric], location=where, rotation_z=a + math.pi / 2
        )

    # Bookcases along the north and west walls, backs against the wall.
    rng = random.Random(7)
    for i in range(5):
        bookcase(rng).build(
            scene,
            f"bookcase_north_{i + 1}",
            [wood, *books],
            location=(-4.4 + 1.02 * i, 4.5 - 0.36, 0.0),
        )
        bookcase(rng).build(
            scene,
            f"bookcase_west_{i + 1}",
            [wood, *books],
            location=(-6.0 + 0.36, -2.8 + 1.02 * i, 0.0),
            rotation_z=math.pi / 2,
        )

    plant_mesh = plant(0.2, 0.35, segments=40, rings=20)
    for i, (x, y) in enumerate(
        [(-5.45, 3.95), (5.45, 3.95), (5.45, -3.95), (-5.45, -3.95)], start=1
    ):
        plant_mesh.build(scene, f"plant_{i}", [pot_mat, leaves], location=(x, y, 0.0), smooth=True)

    # Four hexagonal ceiling lights (6 triangles each) 1 cm below the ceiling.
    for i, (x, y) in enumerate([(-3.0, -2.25), (3.0, -2.25), (-3.0, 2.25), (3.0, 2.25)], start=1):
        single(
            polygon_down(0.45, 6),
            scene,
            f"ceiling_light_{i}",
            light,
            location=(x, y, size[2] - 0.01),
        )

    add_camera(scene, (5.6, -4.2, 2.3), (-2.0, 2.0, 0.8), lens=16.0)
    return scene


def sofa(width):
    """Box-built sofa facing -Y, `width` metres wide and 0.9 m deep, centred on the origin."""
    w = width / 2
    b = MeshBuilder()
    for x0, x1 in ((-w, -w + 0.18), (w - 0.18, w)):
        b.add(box((x0, -0.45, 0.0), (x1, 0.45, 0.65), skip=("-z",)))  # arms
    inner = w - 0.18
    b.add(box((-inner, -0.43, 0.05), (inner, 0.40, 0.40), skip=("-x", "+x")))  # base
    b.add(box((-inner, 0.25, 0.40), (inner, 0.45, 0.95), skip=("-x", "+x", "-z")))  # back
    halves = (
        ((-inner + 0.02, -0.01), (0.01, inner - 0.02))
        if width > 1.5
        else ((-inner + 0.02, inner - 0.02),)
    )
    for x0, x1 in halves:
        b.add(box((x0, -0.42, 0.40), (x1, 0.245, 0.55), skip=("-z",)), mat=1)  # seat cushion
        b.add(box((x0, 0.10, 0.55), (x1, 0.24, 0.90), skip=("-z",)), mat=1)  # back cushion
    return b


def build_living():
    scene = new_scene()
    wall = diffuse("wall", WHITE)
    floor_mat = diffuse("floorboards", (0.45, 0.30, 0.18))
    upholstery = diffuse("upholstery", (0.35, 0.38, 0.42))
    cushions = diffuse("cushions", (0.55, 0.45, 0.30))
    wood = diffuse("wood", (0.40, 0.26, 0.15))
    rug_mat = diffuse("rug", (0.50, 0.12, 0.10))
    ceramic = diffuse("ceramic", (0.70, 0.70, 0.65))
    shade_mat = diffuse("lamp_shade", (0.85, 0.80, 0.65))
    fruit = [
        diffuse(f"fruit_{i}", rgb)
        for i, rgb in enumerate(
            [(0.70, 0.12, 0.05), (0.80, 0.55, 0.05), (0.35, 0.55, 0.10)], start=1
        )
    ]
    blue = diffuse("blue_glaze", (0.10, 0.20, 0.55))
    dark = diffuse("dark_plastic", (0.05, 0.05, 0.06))
    light = emitter("area_light", (1.0, 0.95, 0.85), 20.0)

    size = (7.0, 5.5, 2.7)  # x from -3.5 to 3.5, y from -2.75 to 2.75
    closed_room(scene, size, wall, floor_mat)

    # Backs against the north and west walls.
    sofa(2.0).build(scene, "sofa", [upholstery, cushions], location=(0.0, 2.2, 0.0))
    sofa(1.0).build(
        scene, "armchair", [upholstery, cushions], location=(-2.9, 0.3, 0.0), rotation_z=math.pi / 2
    )
    single(
        box((-1.4, -1.0, 0.0), (1.4, 1.0, 0.01), skip=("-z",)),
        scene,
        "rug",
        rug_mat,
        location=(0.0, 0.5, 0.0),
    )

    table = MeshBuilder().add(box((-0.6, -0.35, 0.40), (0.6, 0.35, 0.45)))
    for x in (-0.54, 0.54):
        for y in (-0.29, 0.29):
            table.add(
                box((x - 0.02, y - 0.02, 0.01), (x + 0.02, y + 0.02, 0.40), skip=("-z", "+z"))
            )
    table.build(scene, "coffee_table", [wood], location=(0.0, 0.6, 0.0))

    # Fruit bowl on the coffee table: a thin hemispherical shell and a few spheres.
    bowl = [(0.0, 0.0)] + [
        (0.18 * math.sin(a), 0.14 - 0.14 * math.cos(a))
        for a in (math.pi / 2 * i / 16 for i in range(1, 17))
    ]
    bowl += [
        (0.17 * math.sin(a), 0.14 - 0.13 * math.cos(a))
        for a in (math.pi / 2 * i / 16 for i in range(16, 0, -1))
    ]
    bowl.append((0.0, 0.01))
    single(
        lathe(bowl, segments=64),
        scene,
        "fruit_bowl",
        ceramic,
        location=(0.2, 0.6, 0.45),
        smooth=True,
    )
    for i, (dx, dy) in enumerate(
        [(0.0, 0.0), (0.08, 0.05), (-0.07, 0.06), (0.06, -0.08), (-0.06, -0.06)]
    ):
        single(
            sphere(0.045, 32, 16),
            scene,
            f"fruit_{i + 1}",
            fruit[i % 3],
            location=(0.2 + dx, 0.6 + dy, 0.45 + 0.06 + 0.02 * (i > 0)),
            smooth=True,
        )

    # TV unit against the south wall.
    single(
        box((-0.9, -0.22, 0.0), (0.9, 0.22, 0.5), skip=("-z",)),
        scene,
        "tv_cabinet",
        wood,
        location=(0.0, -2.75 + 0.23, 0.0),
    )
    single(
        box((-0.6, -0.03, 0.5), (0.6, 0.03, 1.2), skip=("-z",)),
        scene,
        "tv",
        dark,
        location=(0.0, -2.6, 0.0),
    )

    # Tall vase (a thin shell with an S profile) on the cabinet's end.
    outer = [
        (0.09 + 0.05 * math.sin(2 * math.pi * t / 24 - 0.5), 0.6 * t / 24) for t in range(1, 25)
    ]
    vase = [(0.0, 0.0)] + outer + [(r - 0.01, z) for r, z in reversed(outer[1:])] + [(0.0, 0.035)]
    single(lathe(vase, segments=64), scene, "vase", blue, location=(0.7, -2.52, 0.5), smooth=True)

    # Two round side tables: one with a ring-shaped (torus) vase, one with a globe.
    side = [
        (0.0, 0.0),
        (0.25, 0.0),
        (0.25, 0.03),
        (0.04, 0.05),
        (0.04, 0.55),
        (0.3, 0.55),
        (0.3, 0.58),
        (0.0, 0.58),
    ]
    single(lathe(side, segments=64), scene, "side_table_north", wood, location=(1.6, 2.3, 0.0))
    single(
        torus(0.2, 0.06, 128, 48),
        scene,
        "torus_vase",
        ceramic,
        location=(1.6, 2.3, 0.64),
        smooth=True,
    )
    single(lathe(side, segments=64), scene, "side_table_east", wood, location=(2.8, -1.8, 0.0))
    single(sphere(0.2, 80, 40), scene, "globe", blue, location=(2.8, -1.8, 0.78), smooth=True)

    # Floor lamp: solid base and pole, and an open shade as a thin conical shell.
    stand = [(0.0, 0.0), (0.18, 0.0), (0.18, 0.03), (0.02, 0.04), (0.02, 1.45), (0.0, 1.45)]
    shade = [(0.25, 1.25), (0.16, 1.55), (0.15, 1.55), (0.24, 1.25)]
    (
        MeshBuilder()
        .add(lathe(stand, segments=48))
        .add(lathe(shade, segments=64, closed=True), mat=1)
        .build(scene, "floor_lamp", [dark, shade_mat], location=(-2.9, 2.2, 0.0), smooth=True)
    )

    pot_mat = diffuse("terracotta", (0.55, 0.28, 0.16))
    leaves = diffuse("leaves", (0.10, 0.30, 0.08))
    plant(0.18, 0.3, segments=48, rings=24).build(
        scene, "plant", [pot_mat, leaves], location=(-2.9, -2.2, 0.0), smooth=True
    )

    # The single area light: one quad 1 cm below the ceiling, facing down.
    single(rect_down(1.2, 0.8), scene, "area_light", light, location=(0.0, 0.3, size[2] - 0.01))

    add_camera(scene, (3.3, -0.6, 1.7), (-1.5, 0.9, 0.5), lens=16.0)
    return scene


def build_columns():
    scene = new_scene()
    white = diffuse("white", WHITE)
    light = emitter("light", (1.0, 1.0, 1.0), 1000.0)

    single(plane(8.0, 8.0), scene, "floor", white)
    # 7 x 7 thin columns, 0.5 m apart: thin occluders that alias under coarse projections.
    column = MeshBuilder().add(lathe([(0.05, 0.0), (0.05, 2.5), (0.0, 2.5)], segments=24))
    for i in range(7):
        for j in range(7):
            column.build(
                scene, f"column_{i}_{j}", [white], location=(-1.5 + 0.5 * i, -1.5 + 0.5 * j, 0.0)
            )

    # A small, bright panel high up beside the grid, facing its centre.
    lamp = single(rect_down(0.3, 0.3), scene, "light", light, location=(-3.0, -2.0, 3.5))
    lamp.rotation_euler = (
        (Vector((0.0, 0.0, 0.0)) - lamp.location).to_track_quat("-Z", "Y").to_euler()
    )

    add_camera(scene, (5.5, 5.0, 4.5), (0.0, 0.0, 0.6), lens=28.0)
    return scene


def uv_from_xy(obj, scale):
    """A UV map "UVMap" projected from the mesh's x and y (metres times ``scale``)."""
    layer = obj.data.uv_layers.new(name="UVMap")
    for loop in obj.data.loops:
        co = obj.data.vertices[loop.vertex_index].co
        layer.uv[loop.index].vector = (co.x * scale, co.y * scale)


def floorboards_image(name, size=64):
    """A packed sRGB image of planks in three browns, for the textured floor."""
    image = bpy.data.images.new(name, size, size)
    browns = [(0.45, 0.30, 0.18), (0.38, 0.25, 0.15), (0.52, 0.36, 0.22)]
    pixels = []
    for y in range(size):
        for x in range(size):
            plank = (x // 16 + (y // 32) * 2) % 3
            pixels += [*browns[plank], 1.0]
    image.pixels.foreach_set(pixels)
    image.pack()
    return image


def textured(name, image):
    mat = diffuse(name, (0.8, 0.8, 0.8))
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = image
    links.new(texture.outputs["Color"], nodes["Principled BSDF"].inputs["Base Color"])
    return mat


def build_interior():
    """A small interior modelled the way users model one, for issue-sized realism: walls as
    inward planes thickened by Solidify with a window cut by a Boolean, sunlight through the
    window, an area light, an emissive lamp shade, an image-textured floor, a sofa with
    Bevel and Subdivision Surface, a bookshelf by an Array, a vase by a Mirror, four chairs
    as linked duplicates, a table set kept in an excluded collection and instanced twice,
    a lamp cable as a curve and a sign as a text object."""
    scene = new_scene()
    wall = diffuse("wall", WHITE)
    wood = diffuse("wood", (0.40, 0.26, 0.15))
    fabric = diffuse("fabric", (0.35, 0.38, 0.42))
    ceramic = diffuse("ceramic", (0.10, 0.20, 0.55))
    dark = diffuse("dark", (0.05, 0.05, 0.06))
    shade = emitter("lamp_shade", (1.0, 0.85, 0.6), 6.0)
    floor_mat = textured("floorboards", floorboards_image("floorboards"))
    sx, sy, h = 3.0, 2.0, 2.7

    # Walls: four inward planes in one mesh, thickened outwards, a window cut through.
    verts, faces = box((-sx, -sy, 0.0), (sx, sy, h), skip=("-z", "+z"), inward=True)
    walls = MeshBuilder().add((verts, faces)).build(scene, "walls", [wall])
    solidify = walls.modifiers.new("Solidify", "SOLIDIFY")
    solidify.thickness, solidify.offset = 0.2, -1.0   # outwards, away from the normals
    cutter = single(box((1.2, -sy - 0.5, 1.0), (2.4, -sy + 0.5, 2.2)), scene, "window_cut", wall)
    cutter.hide_render, cutter.display_type = True, "WIRE"
    boolean = walls.modifiers.new("Window", "BOOLEAN")
    boolean.object, boolean.operation = cutter, "DIFFERENCE"
    floor = single(plane(2 * sx, 2 * sy), scene, "floor", floor_mat)
    uv_from_xy(floor, 0.5)
    single(rect_down(2 * sx, 2 * sy), scene, "ceiling", wall, location=(0.0, 0.0, h))

    add_light(scene, "sun", "SUN", 3.0, (0.0, 0.0, 5.0),
              rotation=(math.radians(55.0), 0.0, math.radians(-20.0)))
    area = add_light(scene, "ceiling_light", "AREA", 150.0, (-1.0, 0.5, h - 0.01))
    area.data.size = 0.6

    sofa_obj = single(box((-0.9, -0.35, 0.0), (0.9, 0.35, 0.6), skip=("-z",)), scene, "sofa",
                      fabric, location=(-0.8, sy - 0.5, 0.0))
    sofa_obj.modifiers.new("Bevel", "BEVEL").width = 0.05
    sofa_obj.modifiers.new("Subdivision", "SUBSURF").levels = 1

    shelf = single(box((0.0, 0.0, 0.0), (0.35, 0.3, 1.8), skip=("-z",)), scene, "bookshelf",
                   wood, location=(-sx + 0.05, -sy + 0.05, 0.0))
    array = shelf.modifiers.new("Array", "ARRAY")
    array.count, array.relative_offset_displace = 4, (1.05, 0.0, 0.0)

    vase = single(box((0.0, -0.08, 0.0), (0.08, 0.08, 0.35), skip=("-z",)), scene, "vase",
                  ceramic, location=(0.6, 0.0, 0.75))
    vase.modifiers.new("Mirror", "MIRROR").use_axis = (True, False, False)

    chair = single(box((-0.22, -0.22, 0.0), (0.22, 0.22, 0.45), skip=("-z",)), scene, "chair",
                   wood, location=(-0.1, -0.6, 0.0))
    for index, (x, y) in enumerate(((1.3, -0.6), (-0.1, 0.6), (1.3, 0.6)), start=1):
        twin = chair.copy()             # linked duplicates share the chair's mesh
        twin.name, twin.location = f"chair_{index}", (x, y, 0.0)
        scene.collection.objects.link(twin)
    single(box((-0.7, -0.4, 0.7), (0.7, 0.4, 0.75)), scene, "table", wood,
           location=(0.6, 0.0, 0.0))

    # A side-table set kept in an excluded collection and instanced twice.
    table_set = bpy.data.collections.new("side_table_set")
    scene.collection.children.link(table_set)
    for name, part in (("side_table", box((-0.25, -0.25, 0.0), (0.25, 0.25, 0.5), skip=("-z",))),
                       ("side_stool", box((0.35, -0.15, 0.0), (0.65, 0.15, 0.35), skip=("-z",)))):
        obj = single(part, scene, name, wood)
        scene.collection.objects.unlink(obj)
        table_set.objects.link(obj)
    bpy.context.view_layer.layer_collection.children["side_table_set"].exclude = True
    for name, location in (("side_set_west", (-2.4, 0.6, 0.0)), ("side_set_east", (2.2, 1.4, 0.0))):
        empty = bpy.data.objects.new(name, None)
        empty.instance_type, empty.instance_collection = "COLLECTION", table_set
        empty.location = location
        scene.collection.objects.link(empty)

    # A floor lamp: pole, and an open shade that glows on both sides.
    single(box((-0.02, -0.02, 0.0), (0.02, 0.02, 1.4)), scene, "lamp_pole", dark,
           location=(2.4, -1.4, 0.0))
    single(lathe([(0.22, 0.0), (0.15, 0.3)], 24), scene, "lamp_shade", shade,
           location=(2.4, -1.4, 1.3))
    curve = bpy.data.curves.new("lamp_cable", "CURVE")
    curve.dimensions, curve.bevel_depth = "3D", 0.01
    spline = curve.splines.new("POLY")
    spline.points.add(2)
    for point, co in zip(spline.points, ((2.4, -1.4, 0.01), (2.6, -1.7, 0.01), (2.9, -1.95, 0.3))):
        point.co = (*co, 1.0)
    cable = bpy.data.objects.new("lamp_cable", curve)
    cable.data.materials.append(dark)
    scene.collection.objects.link(cable)
    text = bpy.data.curves.new("sign", "FONT")
    text.body, text.extrude, text.size = "LUXEL", 0.02, 0.4
    sign = bpy.data.objects.new("sign", text)
    sign.data.materials.append(ceramic)
    sign.location, sign.rotation_euler = (-1.5, sy - 0.05, 1.6), (math.pi / 2, 0.0, math.pi)
    scene.collection.objects.link(sign)

    add_camera(scene, (2.7, 1.7, 1.9), (-1.0, -0.8, 0.6), lens=20.0)
    return scene


SCENES = {
    "cornell_box": build_cornell_box,
    "cornell_primitives": build_cornell_primitives,
    "temple": build_temple,
    "office": build_office,
    "living": build_living,
    "columns": build_columns,
    "interior": build_interior,
}
# Scenes built the way users build them: shared meshes and modifiers are the point.
AS_USERS_BUILD = {"interior"}


# --- checks and output ------------------------------------------------------------


def check_meshes(shared=False):
    """Raise if a mesh has coincident vertices or (near) zero-area faces, or more than one
    user unless ``shared``."""
    for mesh in bpy.data.meshes:
        tree = KDTree(len(mesh.vertices))
        for v in mesh.vertices:
            tree.insert(v.co, v.index)
        tree.balance()
        for v in mesh.vertices:
            if len(tree.find_range(v.co, 1e-5)) > 1:
                raise ValueError(f"{mesh.name}: duplicate vertex at {tuple(v.co)}")
        for p in mesh.polygons:
            if p.area < 1e-8:
                raise ValueError(f"{mesh.name}: degenerate face {p.index}")
        if mesh.users != 1 and not shared:
            raise ValueError(f"{mesh.name}: {mesh.users} users")


def triangle_count(scene):
    total = 0
    for obj in scene.objects:
        if obj.type == "MESH":
            obj.data.calc_loop_triangles()
            total += len(obj.data.loop_triangles)
    return total


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--output",
        default=os.path.dirname(os.path.abspath(__file__)),
        help="folder for the .blend files (default: this script's folder)",
    )
    parser.add_argument(
        "names",
        nargs="*",
        metavar="name",
        help=f'scenes to build: {", ".join(SCENES)} (default: all)',
    )
    args = parser.parse_args()
    unknown = set(args.names) - set(SCENES)
    if unknown:
        parser.error(f'unknown scene(s): {", ".join(sorted(unknown))}')
    os.makedirs(args.output, exist_ok=True)
    for name in args.names or SCENES:
        scene = SCENES[name]()
        check_meshes(shared=name in AS_USERS_BUILD)
        path = os.path.join(os.path.abspath(args.output), f"{name}.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path, compress=True)
        print(
            f"{name:12s} objects {len(scene.objects):4d}  triangles {triangle_count(scene):6d}  "
            f"size {os.path.getsize(path) / 1024:7.1f} KiB  {path}"
        )


if __name__ == "__main__":
    main()
