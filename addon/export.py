"""Blender scene -> native.Scene, through the evaluated depsgraph: world-space triangles with
modifiers and instances applied, Blender's lights and the world colour in Cycles' units
(lights.py), and for each mesh its Surface: the corners and material slots that materials.py
has Cycles evaluate per lightmap texel. What cannot be mapped is approximated and reported."""
from dataclasses import dataclass, field
import itertools
import time

import bpy
import numpy as np

from ..native import PointLight, Scene, SceneError, SetUpProgress
from ..native.charting import overlapping_faces
from ..native.geometry import unique_rows
from ..native.scene import UV_TOLERANCE, triangle_areas
from . import display
from .lights import AreaLight, light_of, sky_of
from .materials import instance_key
from .node_trees import may_emit
from .writeback import MODIFIER, UV_MAP, UV_MAP_BACK, collection_array

DEFAULT_ALBEDO = (0.8, 0.8, 0.8)   # what Cycles shows for an empty material slot
# export_steps reads objects for this long between its pauses (a modal bake's timer ticks):
# short for Esc, long enough that walking again past the instances done costs little.
EXPORT_PIECE_SECONDS = 0.05
EXPORT_STAGE = "exporting the scene"
# A mesh's materials until materials.evaluate_materials gives Cycles' own per texel: the
# default grey, and this emission where a material may emit (it decides which triangles are
# emitters, hence the atlas, before the evaluation).
MAY_EMIT = (1.0, 1.0, 1.0)


@dataclass
class Receiver:
    """One shown copy of an object that gets a lightmap: its triangles in the scene and their
    corners in its evaluated mesh. ``instancer_name`` is the object whose instance shows it
    (the object itself when shown by itself): Blender's Attribute node tells copies apart
    by it. ``uv_source`` is 'MESH' where the evaluated mesh has the object's own mesh's
    corners (the lightmap UV map goes into the mesh) and 'SNAPSHOT' where modifiers, or a
    curve, text or surface, make new ones (a modifier of Luxel's adds the UV map at the end
    of the stack, from a snapshot of the evaluated corners' UVs)."""
    object_name: str
    instancer_name: str
    object_index: int
    layout: int                 # copies of one mesh share one chart layout
    first_triangle: int
    loops: np.ndarray           # (T, 3) corner indices of each exported triangle
    corner_count: int           # corners of the evaluated mesh
    uv_source: str
    back_faces: bool = False    # its back faces are solved, and shown (UV_MAP_BACK)


@dataclass
class Surface:
    """One mesh copy's triangles as Blender shades them: ``key`` (instance_key) finds its
    evaluated object in the depsgraph again, ``loops`` (T, 3) are the corners of its
    triangles (from ``first_triangle`` on) in the evaluated mesh of ``corners`` corners,
    ``slot`` (T,) their material slots, ``materials`` the slots' material names (None:
    empty)."""
    key: tuple
    object_index: int
    first_triangle: int
    loops: np.ndarray
    corners: int
    slot: np.ndarray
    materials: list


@dataclass
class Export:
    """The scene, its shown copies and its meshes' surfaces. The meshes' albedo and emission
    are stand-ins (DEFAULT_ALBEDO, MAY_EMIT) until materials.evaluate_materials."""
    scene: Scene
    receivers: list
    surfaces: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    emission_of_material: dict = field(default_factory=dict)


@dataclass
class _Inward:
    """A closed mesh's part of the collector whose faces all point inwards."""
    name: str
    part: int                   # index into the collector's per-object lists
    surface: Surface
    receiver: Receiver = None


class _Collector:
    def __init__(self):
        self.vertices, self.triangles, self.normals = [], [], []
        self.albedo, self.emission, self.two_sided = [], [], []
        self.receive, self.occlude, self.object_index = [], [], []
        self.receive_back = []
        self.polygon, self.polygon_count = [], 0
        self.lightmap_uv = []
        self.object_names, self.texel_scale = [], []
        self.layout, self.slot, self.block = [], [], []
        self.vertex_count = 0
        self.triangle_count = 0

    def add_object(self, name, texel_scale=1.0, layout=None, slot=None, block=None):
        """A solver object; ``layout``, ``slot`` and ``block`` (any hashable keys) say how it
        shares charts and placement with others (native.Scene.object_layout); by default it
        shares nothing."""
        index = len(self.object_names)
        self.object_names.append(name)
        self.texel_scale.append(texel_scale)
        for keys, key in ((self.layout, layout), (self.slot, slot), (self.block, block)):
            keys.append(("own", index) if key is None else key)
        return index

    def add(self, vertices, normals, triangles, obj, albedo, emission, two_sided, receive,
            occlude, receive_back=False, polygon=None, lightmap_uv=None):
        count = len(triangles)
        self.lightmap_uv.append(np.full((count, 3, 2), np.nan) if lightmap_uv is None
                                else lightmap_uv)
        self.vertices.append(vertices)
        self.normals.append(normals)
        self.triangles.append(triangles + self.vertex_count)
        self.vertex_count += len(vertices)
        self.albedo.append(albedo)
        self.emission.append(emission)
        self.two_sided.append(np.broadcast_to(two_sided, count))
        self.receive.append(np.broadcast_to(receive, count))
        self.occlude.append(np.broadcast_to(occlude, count))
        self.receive_back.append(np.broadcast_to(receive_back, count))
        # Faces numbered across the scene: after the faces of the objects added before.
        self.polygon.append(np.full(count, -1) if polygon is None
                            else polygon + self.polygon_count)
        self.polygon_count += 0 if polygon is None else int(polygon.max(initial=-1)) + 1
        self.object_index.append(np.full(count, obj))
        first = self.triangle_count
        self.triangle_count += count
        return first


RENDERABLE = {'MESH', 'CURVE', 'SURFACE', 'META', 'FONT', 'LIGHT'}
# Curves, text and surfaces come through the depsgraph as their evaluated meshes, instances
# of themselves: the objects are left out, or they would be exported twice.
AS_EVALUATED_MESH = {'CURVE', 'SURFACE', 'FONT'}


def export_scene(context, depsgraph=None):
    """Export what renders, in one call: export_steps's pieces run to the end."""
    pieces = export_steps(context, depsgraph)
    while True:
        try:
            next(pieces)
        except StopIteration as end:
            return end.value


def export_steps(context, depsgraph=None):
    """Export what renders: objects hidden from render (themselves or through a collection)
    are skipped, instances expanded. A generator of pieces, each exporting the objects it
    reaches in EXPORT_PIECE_SECONDS; after each but the last it yields a SetUpProgress (the
    share of the instances done), and it returns the Export. Only the scene, the depsgraph
    and the view layer's exclusions are read from ``context``, now."""
    return _export_pieces(context.scene, depsgraph or context.evaluated_depsgraph_get(),
                          _excluded_objects(context.view_layer))


def _export_pieces(scene, depsgraph, excluded):
    exporter = _Exporter(scene)
    exported = set()
    total = max(len(depsgraph.object_instances), 1)
    done = 0
    while True:
        # An instance lives only while the depsgraph is walked, and Blender's event loop runs
        # between pieces: each piece walks again, past the instances already done. materials.py
        # finds the instances in this order.
        deadline = time.perf_counter() + EXPORT_PIECE_SECONDS
        for instance in itertools.islice(depsgraph.object_instances, done, None):
            exporter.add_instance(instance)
            exported.add(instance.object.original.name)
            done += 1
            if time.perf_counter() > deadline:
                break
        else:
            break
        yield SetUpProgress(stage=EXPORT_STAGE, fraction=min(done / total, 1.0))
    # The viewport's depsgraph leaves out objects hidden in the viewport, though they render.
    for obj in scene.objects:
        if (obj.type in RENDERABLE and obj.name not in exported and not obj.hide_render
                and obj.name not in exporter.hidden_by_collection
                and obj.name not in excluded):
            exporter.warn(f"'{obj.name}' renders but is hidden in the viewport, so it was not "
                          "baked: unhide it (eye or screen icon in the outliner) to include it")
    return exporter.finish()


class _Exporter:
    def __init__(self, scene):
        self.blender_scene = scene
        self.collector = _Collector()
        self.lights = []
        self.receivers = []
        self.surfaces = []
        self.warnings = []
        self.shown_copies = set()
        self.inward = []        # closed meshes whose normals point inwards (_Inward)
        self.faceless = []      # meshes without faces: reported unless they instance
        self.instancers = set()
        self.hidden_by_collection = {obj.name for collection in bpy.data.collections
                                     if collection.hide_render
                                     for obj in collection.all_objects}

    def warn(self, message):
        if message not in self.warnings:
            self.warnings.append(message)

    # ------------------------------------------------------------------ objects
    def add_instance(self, instance):
        obj = instance.object
        original = obj.original
        if original.hide_render or original.name in self.hidden_by_collection:
            return
        # A curve's or a text's evaluated mesh is an instance of the object itself.
        instancer = instance.parent.original if instance.is_instance else original
        if instance.is_instance:
            self.instancers.add(instancer.name)
        if instancer.hide_render or instancer.name in self.hidden_by_collection:
            return
        matrix = np.array(instance.matrix_world, dtype=np.float64)
        if obj.type == 'LIGHT':
            self.add_light(obj, matrix)
        elif obj.type in {'MESH', 'META'} or (obj.type in AS_EVALUATED_MESH
                                               and instance.is_instance):
            name = original.name
            if instancer != original:
                name = f"{instancer.name}/{original.name}"
            # Geometry nodes' instances come as instances of the object that makes them.
            made_by_nodes = instance.is_instance and original.type == 'MESH' and (
                instancer == original)
            self.add_mesh_object(obj, name, matrix, instancer, instance_key(instance),
                                 made_by_nodes)

    def add_mesh_object(self, obj, name, matrix, instancer, key, made_by_nodes=False):
        original = obj.original
        try:
            mesh = obj.to_mesh()
        except RuntimeError:
            return
        try:
            if mesh is None or not len(mesh.polygons):
                if original.type == 'MESH':
                    self.faceless.append(name)
                return
            self._add_mesh(obj, mesh, name, matrix, instancer, key, made_by_nodes)
        finally:
            obj.to_mesh_clear()

    def _placement(self, obj, mesh, name, instancer, receive_back, made_by_nodes):
        """The layout, slot and block keys of one shown copy of ``obj`` (see
        Collector.add_object), its UV source, and whether it shows a lightmap."""
        original = obj.original
        settings = original.luxel
        modified = [m for m in original.modifiers if m.name != MODIFIER and m.show_render]
        same_corners = (original.type == 'MESH' and len(mesh.loops) == len(original.data.loops)
                        and len(mesh.polygons) == len(original.data.polygons))
        uv_source = 'MESH' if same_corners else 'SNAPSHOT'
        # Copies of one mesh share its charts: a mesh's objects without modifiers, and every
        # instance of one object (they show its one evaluated mesh).
        shared = ("mesh", original.data.name) if same_corners and not modified else (
            "object", original.name)
        # A mirrored copy winds its triangles the other way: its corners do not match.
        mirrored = bool(np.linalg.det(np.array(obj.matrix_world)[:3, :3]) < 0)
        source = ("uv", settings.source_uv_map) if settings.uv_source == 'MAP' else ("charts",)
        layout = shared + source + (settings.resolution_scale, receive_back, mirrored)
        slot, block = ("slot", original.name), ("block", instancer.name)
        shows = settings.receive
        if original.type == 'META':
            self.warn(f"'{name}' is a metaball: it reflects light and casts shadows but shows "
                      "no lightmap, since a metaball has no UV map (Object > Convert > Mesh "
                      "on a copy to bake one)")
            shows = False
        elif made_by_nodes:
            self.warn(f"'{name}' shows instances made by geometry nodes: each reflects its "
                      "own light, but Blender's materials cannot tell them apart, so none "
                      "shows a lightmap; add a Realize Instances node at the end of its node "
                      "tree to bake each copy")
            slot = block = None
            shows = False
        elif (slot, block) in self.shown_copies:
            # Blender's materials see an instance's object and its top instancer only.
            self.warn(f"'{name}' is shown more than once by '{instancer.name}' (vertex, face "
                      "or particle instancing, or a collection instanced twice inside it): "
                      "each copy reflects its own light, but the materials can show only the "
                      "first one's lightmap; instance the collection from separate empties to "
                      "show each")
            slot = block = None
            shows = False
        layers = original.data.uv_layers if original.type == 'MESH' else ()
        needed = {UV_MAP, UV_MAP_BACK} if receive_back else {UV_MAP}
        free = 8 - len([layer for layer in layers if layer.name not in needed])
        if shows and uv_source == 'MESH' and free < len(needed):
            fix = " or set Back Faces to Off" if receive_back else ""
            raise SceneError(f"object '{name}' has {8 - free} UV maps of its own and Luxel "
                             f"needs {len(needed)}, over Blender's limit of 8: remove "
                             f"{len(needed) - free}{fix}", name)
        if shows:
            self.shown_copies.add((slot, block))
        return layout, slot, block, uv_source, shows

    def _add_mesh(self, obj, mesh, name, matrix, instancer, key, made_by_nodes):
        original = obj.original
        texel_scale, back_faces = original.luxel.resolution_scale, original.luxel.back_faces
        triangles_count = len(mesh.loop_triangles)
        if triangles_count == 0:
            return
        loops = collection_array(mesh.loop_triangles, "loops", np.int64, (triangles_count, 3))
        material_index = collection_array(mesh.loop_triangles, "material_index", np.int64, (-1,))
        polygon = collection_array(mesh.loop_triangles, "polygon_index", np.int64, (-1,))
        loop_vertex = collection_array(mesh.loops, "vertex_index", np.int64, (-1,))
        positions = collection_array(mesh.vertices, "co", np.float64, (-1, 3))
        corner_normals = collection_array(mesh.corner_normals, "vector", np.float64, (-1, 3))

        linear = matrix[:3, :3]
        positions = positions @ linear.T + matrix[:3, 3]
        normal_matrix = np.linalg.inv(linear).T
        corner_normals = corner_normals @ normal_matrix.T
        lengths = np.linalg.norm(corner_normals, axis=1, keepdims=True)
        corner_normals = np.divide(corner_normals, lengths, out=np.zeros_like(corner_normals),
                                   where=lengths > 0)
        if np.linalg.det(linear) < 0:       # mirrored: keep the front faces in front
            loops = loops[:, ::-1].copy()
        usable = self._usable_triangles(positions[loop_vertex[loops]], name)
        if not usable.any():
            return
        loops, material_index, polygon = loops[usable], material_index[usable], polygon[usable]
        triangles_count = len(loops)

        # One solver vertex per (mesh vertex, corner normal): sharp edges split, smooth ones
        # stay shared so that charts stay connected.
        used_loops = loops.ravel()
        keys = np.column_stack([loop_vertex[used_loops],
                                np.round(corner_normals[used_loops] * 1e4).astype(np.int64)])
        _, first, inverse = unique_rows(keys, return_index=True, return_inverse=True)
        vertex_loops = used_loops[first]
        vertices = positions[loop_vertex[vertex_loops]]
        normals = corner_normals[vertex_loops]
        triangles = inverse.reshape(-1, 3)

        # Luxel's material on empty slots (Show Baked Lighting) is no material of theirs.
        slots = [None if display.is_fill(slot.material) else slot.material
                 for slot in obj.material_slots] or [None]
        material_index = np.clip(material_index, 0, len(slots) - 1)
        if any(slots[slot] is None for slot in np.unique(material_index)):
            self.warn(f"'{name}' has faces without a material (no material, or an empty "
                      "slot): they are baked as Blender's default grey, albedo "
                      f"{DEFAULT_ALBEDO[0]}; assign a material to choose their colour")
        emits = np.array([material is not None and may_emit(material.original)
                          for material in slots])[material_index]
        albedo = np.tile(DEFAULT_ALBEDO, (triangles_count, 1))
        emission = np.where(emits[:, None], MAY_EMIT, 0.0)
        receive_back = back_faces == 'ON' or (back_faces == 'AUTO' and emission.max() > 0.0
                                              and _is_open(loop_vertex[loops]))
        lightmap_uv = None
        if original.luxel.uv_source == 'MAP':
            lightmap_uv = self._own_lightmap_uv(mesh, original.luxel.source_uv_map, name,
                                                loops, polygon)
        layout, slot, block, uv_source, shows = self._placement(
            obj, mesh, name, instancer, receive_back, made_by_nodes)
        object_index = self.collector.add_object(name, texel_scale, layout, slot, block)
        # Every surface receives in the solver, so that it reflects; only those whose object
        # asks for one show a lightmap.
        first = self.collector.add(vertices, normals, triangles, object_index, albedo, emission,
                                   True, True, True, receive_back, polygon, lightmap_uv)
        surface = Surface(key, object_index, first, loops, len(mesh.loops), material_index,
                          [None if m is None else m.original.name for m in slots])
        self.surfaces.append(surface)
        receiver = None
        if shows:
            receiver = Receiver(original.name, instancer.name, object_index,
                                self.collector.layout[object_index], first, loops,
                                len(mesh.loops), uv_source, bool(receive_back))
            self.receivers.append(receiver)
        closed = not _is_open(loop_vertex[loops])
        if closed and _signed_volume(vertices[triangles]) < 0.0:
            self.inward.append(_Inward(name, len(self.collector.triangles) - 1, surface,
                                       receiver))

    def _own_lightmap_uv(self, mesh, uv_map, name, loops, polygon):
        """The corners (T, 3, 2) of the object's own lightmap UV map, refused (before anything
        changes) where the map is missing, leaves [0, 1] or has faces that overlap."""
        fix = "or set UV Source to Luxel's Charts (Object > Luxel Lightmap)"
        if not uv_map or uv_map == UV_MAP:
            problem = "none is chosen" if not uv_map else "the one chosen is Luxel's own"
            raise SceneError(f"object '{name}': UV Source is a UV map but {problem}: choose "
                             f"one of the mesh's, {fix}", name)
        layer = mesh.uv_layers.get(uv_map)
        if layer is None:
            raise SceneError(f"object '{name}' has no UV map '{uv_map}' (after its modifiers): "
                             f"choose one it has, {fix}", name)
        corners = collection_array(layer.uv, "vector", np.float64, (-1, 2))[loops]
        outside = ((corners < -UV_TOLERANCE) | (corners > 1.0 + UV_TOLERANCE)).any(axis=(1, 2))
        if outside.any():
            raise SceneError(f"object '{name}': UV map '{uv_map}' has {_faces(polygon[outside])} "
                             "outside the [0, 1] square: scale the islands into it (UV > Pack "
                             f"Islands), {fix}", name)
        overlapping = overlapping_faces(corners, polygon)
        if overlapping.any():
            raise SceneError(f"object '{name}': UV map '{uv_map}' has "
                             f"{_faces(polygon[overlapping])} overlapping others, and a lightmap "
                             "needs texels of its own for each face: unwrap into a new map (UV > Lightmap "
                             f"Pack, or Smart UV Project and Pack Islands), {fix}", name)
        return corners

    def _usable_triangles(self, corners, name):
        """Triangles the solver accepts: finite corners and an area above native.Scene's
        degenerate limit. The others are skipped with one warning naming the object."""
        finite = np.isfinite(corners).all(axis=(1, 2))
        degenerate = finite & triangle_areas(np.where(finite[:, None, None], corners, 0.0))[1]
        usable = finite & ~degenerate
        if usable.all():
            return usable
        found = ", ".join(f"{count} {what}" for count, what in (
            (int(degenerate.sum()), "with zero area"),
            (int((~finite).sum()), "with a vertex that is not a finite number")) if count)
        fix = ("fix the mesh in Edit Mode: Mesh > Clean Up > Merge by Distance and Delete "
               "Loose, and delete vertices at invalid positions")
        if usable.any():
            self.warn(f"'{name}': {int((~usable).sum())} of its {len(usable)} triangles were "
                      f"skipped ({found}); {fix}")
        else:
            self.warn(f"'{name}' was skipped: none of its triangles can be baked ({found}); "
                      f"{fix}")
        return usable

    # ------------------------------------------------------------------- lights
    def add_light(self, obj, matrix):
        light = light_of(obj, matrix, self.warn)
        if isinstance(light, AreaLight):
            count = len(light.triangles)
            index = self.collector.add_object(light.name)
            self.collector.add(light.vertices, np.tile(light.normal, (len(light.vertices), 1)),
                               light.triangles, index, np.zeros((count, 3)),
                               np.tile(light.radiance, (count, 1)), two_sided=False,
                               receive=False, occlude=False)
        elif light is not None:
            self.lights.append(light)

    def turn_outwards(self):
        """A closed mesh whose normals point inwards is baked on its outside, unless its inside
        is seen: it emits (a furnace, a room whose walls glow), or it holds a light, the
        camera or another object's centre (a room modelled as a box seen from within)."""
        c = self.collector
        inside_points = [np.asarray(light.position) for light in self.lights
                         if isinstance(light, PointLight)]
        camera = self.blender_scene.camera
        if camera is not None:
            inside_points.append(np.array(camera.matrix_world.translation))
        centres = [vertices.mean(axis=0) for vertices in c.vertices]
        for inward in self.inward:
            if c.emission[inward.part].max() > 0.0:
                continue
            corners = c.vertices[inward.part]
            low, high = corners.min(axis=0), corners.max(axis=0)
            margin = 0.01 * (high - low)
            points = inside_points + [centre for part, centre in enumerate(centres)
                                      if part != inward.part]
            if any(((point > low + margin) & (point < high - margin)).all()
                   for point in points):
                continue
            c.triangles[inward.part] = c.triangles[inward.part][:, ::-1].copy()
            c.normals[inward.part] = -c.normals[inward.part]
            c.lightmap_uv[inward.part] = c.lightmap_uv[inward.part][:, ::-1].copy()
            inward.surface.loops = inward.surface.loops[:, ::-1].copy()
            if inward.receiver is not None:
                inward.receiver.loops = inward.receiver.loops[:, ::-1].copy()
            self.warn(f"'{inward.name}' is a closed mesh whose normals point inwards, with "
                      "nothing inside it (no light, camera or object) and no emission: it was "
                      "baked on its outside, the side that is seen; "
                      "recalculate its normals (Edit Mode: Mesh > Normals > Recalculate "
                      "Outside) so that every renderer agrees")

    def finish(self):
        # An instancer's own points or empty geometry do not render.
        for name in self.faceless:
            if name not in self.instancers:
                self.warn(f"'{name}' is a mesh without faces: it renders nothing and was "
                          "skipped (add faces, or hide it from render)")
        c = self.collector
        if not c.triangles:
            raise SceneError("the scene has no visible mesh to bake: add a mesh, or make one "
                             "renderable (its camera icon in the outliner)")
        self.turn_outwards()
        numbered = lambda keys: np.unique([repr(key) for key in keys], return_inverse=True)[1]
        layout = numbered(c.layout)
        for receiver in self.receivers:
            receiver.layout = int(layout[receiver.object_index])
        scene = Scene(
            vertices=np.concatenate(c.vertices), triangles=np.concatenate(c.triangles),
            normals=np.concatenate(c.normals), albedo=np.concatenate(c.albedo),
            emission=np.concatenate(c.emission),
            emission_two_sided=np.concatenate(c.two_sided),
            receive=np.concatenate(c.receive), occlude=np.concatenate(c.occlude),
            receive_back=np.concatenate(c.receive_back), polygon=np.concatenate(c.polygon),
            object_index=np.concatenate(c.object_index), object_names=c.object_names,
            object_texel_scale=c.texel_scale, object_layout=layout,
            object_slot=numbered(c.slot), object_block=numbered(c.block),
            lightmap_uv=(np.concatenate(c.lightmap_uv) if any(
                np.isfinite(uv).any() for uv in c.lightmap_uv) else None),
            lights=self.lights, sky=sky_of(self.blender_scene.world, self.warn))
        return Export(scene, self.receivers, self.surfaces, self.warnings)


# ---------------------------------------------------------------------- helpers
def _faces(polygon):
    count = len(np.unique(polygon))
    return f"{count} face{'' if count == 1 else 's'}"


def _excluded_objects(view_layer):
    """Objects only in collections excluded from the view layer (where collections that are
    instanced usually live): they render through their instances, if at all."""
    shown, excluded = set(), set()

    def visit(layer_collection):
        target = excluded if layer_collection.exclude else shown
        target.update(obj.name for obj in layer_collection.collection.objects)
        if not layer_collection.exclude:
            for child in layer_collection.children:
                visit(child)
        else:
            for child in layer_collection.collection.children_recursive:
                excluded.update(obj.name for obj in child.objects)
    visit(view_layer.layer_collection)
    return excluded - shown


def _signed_volume(corners):
    """Volume enclosed by triangles (T, 3, 3): negative where their fronts face inwards."""
    return float(np.einsum("ij,ij->i", corners[:, 0],
                           np.cross(corners[:, 1], corners[:, 2])).sum() / 6.0)


def _is_open(corners):
    """Whether a mesh (triangles as mesh vertex indices) has an edge used by one face only:
    a sheet, whose back can face the room, not a solid's inside."""
    edges = np.sort(corners[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = unique_rows(edges, return_counts=True)
    return bool((counts == 1).any())

