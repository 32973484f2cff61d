"""A Cycles reference for Luxel's lightmaps: after a Luxel bake, each receiving object is baked
again with Cycles (CPU, type DIFFUSE, pass filter DIRECT + INDIRECT + COLOR: the reflected
diffuse radiance, the quantity a Luxel texel holds) into the same lightmap UV layout, so the two
can be compared texel by texel or as per-object means.

The user's file is left as it was: Cycles bakes into temporary copies of the objects'
materials (the user's node trees are never edited), and the render and bake settings, the
selection, the active object and the material slots come back, whatever happens."""
from dataclasses import dataclass

import bpy
import numpy as np

from ..native.evaluation.texel_error import texel_noise
from .display import STATE_KEY, is_fill, strip_display_nodes
from .export import DEFAULT_ALBEDO
from .materials import bake_reports_silenced, texel_means
from .writeback import (INSTANCER_OFFSET, OBJECT_OFFSET, UV_MAP, image_name, image_pixels,
                        snapshot_of)

PASS_FILTER = {'DIRECT', 'INDIRECT', 'COLOR'}
TEMP_PREFIX = "Luxel Reference "


def receivers(scene, objects=None):
    """The meshes a Luxel bake gave a lightmap that a Cycles bake can reach in place: their
    own UV map holds their whole place on the page (no modifier of Luxel's, no other copy of
    their mesh, no offset), optionally restricted to ``objects`` (objects or names)."""
    if objects is None:
        candidates = list(scene.objects)
    else:
        candidates = [scene.objects[o] if isinstance(o, str) else o for o in objects]
    return [obj for obj in candidates if _in_place(obj)]


def _in_place(obj):
    if obj.type != 'MESH' or not obj.luxel.uv_map or obj.luxel.image is None:
        return False
    offsets = [obj.get(key) for key in (OBJECT_OFFSET, INSTANCER_OFFSET)]
    return (snapshot_of(obj) is None and obj.data.users == 1
            and all(o is not None and not any(o[:2]) for o in offsets))


@dataclass
class _Copy:
    """One shown copy of an object, as the depsgraph lists it."""
    key: str            # the solver's name: "instancer/object", or the object's own
    original: str
    instancer: str
    matrix: object      # mathutils.Matrix, world space
    shown: bool         # it has a lightmap (else it only stands in for light and shadow)


def cycles_reference(context, samples=256, bounces=32, objects=None, seed=0, copies=False,
                     pass_filter=PASS_FILTER, supersample=1):
    """Bake each receiving object with Cycles into a temporary float image the size of its
    lightmap. Returns {object name: (H, W, 4) float32 array}, row 0 at the bottom (v = 0), like
    Luxel's pages; alpha is 1 where Cycles wrote a texel (a texel centre inside one of the
    object's UV triangles) and 0 elsewhere, so alpha is the object's coverage mask.

    With ``copies``, every other shown copy too (objects shown through Luxel's modifier,
    curves and text, copies of one mesh, instances), keyed by the solver's name
    ("instancer/object" for an instance): the objects an instancer shows are swapped, for
    the bake, for stand-ins made of their evaluated meshes at their places, whose lightmap
    UVs carry their offsets (see luxel_page).

    ``pass_filter`` {'COLOR'} bakes the albedo instead: the diffuse colour Cycles multiplies
    the light by.

    With ``supersample`` s > 1, Cycles bakes the same UVs into images s times as wide and
    high, and each texel gets the mean of its s x s sub-texels that Cycles covered, alpha
    their covered share: the mean over the texel's surface, as a Luxel texel holds it. At
    s = 1 Cycles samples a texel only on the triangle under its centre, whose normal alone
    it shades with: where a texel spans a bend (a cable narrower than a texel) its value is
    that of one facet, and it is missing where no triangle covers its centre."""
    scene = context.scene
    targets = receivers(scene, objects)
    if context.mode != 'OBJECT':
        raise RuntimeError("the Cycles reference bake needs Object Mode")
    restore = SettingsSnapshot(scene)
    view_layer = context.view_layer
    selected = [obj for obj in view_layer.objects if obj.select_get()]
    active = view_layer.objects.active
    temporary_materials, temporary_images, slot_changes, added_slots = [], [], [], []
    preview_changes, stand_ins, hidden = [], [], []
    keys = [obj.name for obj in targets]
    results = {}
    try:
        configure_cycles(scene, samples, bounces, seed)
        _hide_luxel_preview(temporary_materials, preview_changes)
        if copies:
            for key, stand_in in _stand_ins(context, set(keys), stand_ins, hidden):
                keys.append(key)
                targets.append(stand_in)
        for key, obj in zip(keys, targets):
            width, height = luxel_page(scene, key).size
            image = bpy.data.images.new(TEMP_PREFIX + key, width * supersample,
                                        height * supersample, alpha=True, float_buffer=True)
            temporary_images.append(image)
            image.colorspace_settings.name = 'Linear Rec.709'
            _point_materials_at(obj, image, temporary_materials, slot_changes, added_slots)
        # One bake for all: each selected object goes into its own materials' active image,
        # and Cycles builds the scene once instead of once per object.
        for other in view_layer.objects:
            if other.select_get() != (other in targets):
                other.select_set(other in targets)
        view_layer.objects.active = targets[0] if targets else None
        if targets:
            with bake_reports_silenced():
                bpy.ops.object.bake(type='DIFFUSE', pass_filter=set(pass_filter),
                                    uv_layer=UV_MAP, margin=0, use_clear=True,
                                    target='IMAGE_TEXTURES', use_selected_to_active=False,
                                    use_cage=False)
        for key, image in zip(keys, temporary_images):
            width, height = image.size
            pixels = np.empty(width * height * 4, dtype=np.float32)
            image.pixels.foreach_get(pixels)
            results[key] = texel_means(pixels.reshape(height, width, 4), supersample)
    finally:
        _restore_slots(slot_changes, added_slots)
        _restore_slots(preview_changes, [])
        for obj in stand_ins:
            data = obj.data
            bpy.data.objects.remove(obj)
            if isinstance(data, bpy.types.Mesh) and data.users == 0:
                bpy.data.meshes.remove(data)
        for obj in hidden:
            obj.hide_render = False
        for material in temporary_materials:
            bpy.data.materials.remove(material)
        for image in temporary_images:
            bpy.data.images.remove(image)
        for obj in view_layer.objects:
            want = obj in selected
            if obj.select_get() != want:
                obj.select_set(want)
        view_layer.objects.active = active
        restore()
    return results


def luxel_page(scene, key):
    """The Luxel page image a shown copy's lightmap is on (key: an object's name, or the
    solver's "instancer/object")."""
    obj = bpy.data.objects.get(key)
    if obj is not None and _in_place(obj):
        return obj.luxel.image
    # An object's own name first: names may hold "/" too.
    instancer = obj if obj is not None else bpy.data.objects[key.rsplit("/", 1)[0]]
    page = int(instancer[INSTANCER_OFFSET][2]) - 1
    return bpy.data.images[image_name(scene, page)]


def _stand_ins(context, in_place, made, hidden):
    """Swap each instancer (an object shown by itself included) that shows a copy a Cycles
    bake cannot reach in place for stand-ins of everything it shows; returns [(key,
    stand-in)] for the shown copies. ``made`` and ``hidden`` collect what to remove and
    unhide, also when this fails half-way."""
    scene = context.scene
    depsgraph = context.evaluated_depsgraph_get()
    found = []
    for instance in depsgraph.object_instances:
        original = instance.object.original
        if original.type not in {'MESH', 'CURVE', 'SURFACE', 'FONT', 'LIGHT'}:
            continue
        if original.type in {'CURVE', 'SURFACE', 'FONT'} and not instance.is_instance:
            continue        # a curve's surface comes as an instance of itself
        instancer = instance.parent.original if instance.is_instance else original
        key = original.name if instancer == original else f"{instancer.name}/{original.name}"
        shown = OBJECT_OFFSET in original and original.luxel.image is not None
        found.append(_Copy(key, original.name, instancer.name,
                           instance.matrix_world.copy(), shown))
    swapped = {copy.instancer for copy in found if copy.shown and copy.key not in in_place}
    meshes, shown = {}, []
    for copy in found:
        if copy.instancer not in swapped:
            continue
        original = bpy.data.objects[copy.original]
        if original.type == 'LIGHT':
            stand_in = bpy.data.objects.new(TEMP_PREFIX + copy.key, original.data)
        else:
            if copy.original not in meshes:
                meshes[copy.original] = bpy.data.meshes.new_from_object(
                    original.evaluated_get(depsgraph), preserve_all_data_layers=True,
                    depsgraph=depsgraph)
            mesh = meshes[copy.original].copy()
            if copy.shown:
                _move_uvs(mesh, original, bpy.data.objects[copy.instancer])
            stand_in = bpy.data.objects.new(TEMP_PREFIX + copy.key, mesh)
        scene.collection.objects.link(stand_in)
        stand_in.matrix_world = copy.matrix
        made.append(stand_in)
        if copy.shown and original.type != 'LIGHT':
            shown.append((copy.key, stand_in))
    for mesh in meshes.values():
        bpy.data.meshes.remove(mesh)
    for name in swapped:
        instancer = bpy.data.objects[name]
        if not instancer.hide_render:
            instancer.hide_render = True
            hidden.append(instancer)
    return shown


def _move_uvs(mesh, obj, instancer):
    """A shown copy's lightmap UVs plus its offsets: its place on the page."""
    offset = np.array(obj[OBJECT_OFFSET][:2]) + np.array(instancer[INSTANCER_OFFSET][:2])
    uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers[UV_MAP].uv.foreach_get("vector", uv)
    # A new layer, the mesh's active one: copies of one mesh share its arrays (see
    # writeback._set_uvs), and Blender 5.2's bake wants an active UV map, which the
    # attribute a modifier stored is not.
    mesh.uv_layers.remove(mesh.uv_layers[UV_MAP])
    layer = mesh.uv_layers.new(name=UV_MAP, do_init=False)
    layer.uv.foreach_set("vector", (uv.reshape(-1, 2) + offset).ravel())
    mesh.uv_layers.active = layer


# ------------------------------------------------------------------------- per-object means
@dataclass
class ObjectMean:
    """Mean RGB reflected radiance of one object over the texels Cycles covered."""
    name: str
    texels: int
    luxel: np.ndarray       # (3,)
    cycles: np.ndarray      # (3,)
    cycles_error: np.ndarray  # (3,) standard error of Cycles' mean estimated from its texel
    #                           noise (rough: see _standard_error)

    @property
    def ratio(self):
        return np.divide(self.luxel, self.cycles, out=np.full(3, np.nan),
                         where=self.cycles > 0)


def luxel_lightmap(obj):
    """The object's Luxel page as an (H, W, 4) float32 array, row 0 at the bottom."""
    return image_pixels(obj.luxel.image)


def object_means(reference, luxel_pages=None):
    """{name: ObjectMean} for the Cycles bakes in ``reference`` (cycles_reference's result) and
    Luxel's lightmaps (``luxel_pages`` {name: (H, W, 4)}; by default each object's own lightmap
    image), both averaged over the same texels: those Cycles covered (alpha > 0)."""
    means = {}
    for name, cycles in reference.items():
        luxel = (luxel_pages[name] if luxel_pages is not None
                 else image_pixels(luxel_page(bpy.context.scene, name)))
        if luxel.shape != cycles.shape:
            raise ValueError(f"'{name}': Luxel's lightmap is {luxel.shape[:2]}, the Cycles bake "
                             f"{cycles.shape[:2]}")
        covered = cycles[..., 3] > 0.0
        count = int(covered.sum())
        if count == 0:
            nan = np.full(3, np.nan)
            means[name] = ObjectMean(name, 0, nan, nan, nan)
            continue
        means[name] = ObjectMean(name, count,
                                 luxel[covered][:, :3].astype(np.float64).mean(axis=0),
                                 cycles[covered][:, :3].astype(np.float64).mean(axis=0),
                                 _standard_error(cycles, covered))
    return means


def _standard_error(pixels, covered):
    """Standard error of the mean over ``covered`` from the texels' estimated noise (see
    native.evaluation.texel_error.texel_noise): a rough guide (within a factor of a few), for diagnostics,
    not a bound."""
    return texel_noise(pixels, covered) / np.sqrt(max(int(covered.sum()), 1))


# ------------------------------------------------------------------------------- internals
def configure_cycles(scene, samples, bounces, seed):
    scene.render.engine = 'CYCLES'
    cycles = scene.cycles
    cycles.device = 'CPU'
    cycles.samples = samples
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    cycles.max_bounces = bounces
    cycles.diffuse_bounces = bounces
    cycles.glossy_bounces = bounces
    # Filter Glossy (1 by default) blurs glossy lobes met after a diffuse bounce, and the
    # blurred lobes reflect less: a room of Blender's default Principled BSDF came out
    # 4.5-8 % darker than with it off (docs/glossy-layers.md).
    cycles.blur_glossy = 0.0
    cycles.caustics_reflective = True
    cycles.seed = seed
    cycles.use_animated_seed = False
    cycles.time_limit = 0.0
    cycles.sample_offset = 0
    cycles.bake_type = 'DIFFUSE'
    bake = scene.render.bake
    bake.use_pass_direct = bake.use_pass_indirect = bake.use_pass_color = True
    bake.margin = 0
    bake.use_clear = True
    bake.target = 'IMAGE_TEXTURES'
    bake.use_selected_to_active = False


def _point_materials_at(obj, image, temporary_materials, slot_changes, added_slots):
    """Give every slot of ``obj`` a temporary copy of its material whose active node is an
    image texture of ``image`` (Cycles bakes into the active image node of each material)."""
    copies = {}
    if len(obj.material_slots) == 0:
        obj.data.materials.append(None)
        added_slots.append(obj)
    for index, slot in enumerate(obj.material_slots):
        original = slot.material
        if original not in copies:
            copies[original] = _baking_material(original, image)
            temporary_materials.append(copies[original])
        slot_changes.append((obj, index, original))
        slot.material = copies[original]


def _baking_material(original, image):
    if original is None:
        material = bpy.data.materials.new(TEMP_PREFIX + "Default")
        nodes, links = material.node_tree.nodes, material.node_tree.links
        nodes.clear()
        diffuse = nodes.new('ShaderNodeBsdfDiffuse')
        diffuse.inputs["Color"].default_value = (*DEFAULT_ALBEDO, 1.0)
        output = nodes.new('ShaderNodeOutputMaterial')
        links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])
    else:
        material = original.copy()
        material.name = TEMP_PREFIX + original.name
    tree = material.node_tree
    target = tree.nodes.new('ShaderNodeTexImage')
    target.name = target.label = TEMP_PREFIX + "Target"
    target.image = image
    tree.nodes.active = target
    return material


def _hide_luxel_preview(temporary_materials, slot_changes):
    """With Show Baked Lighting on, the baked objects' materials show their lightmaps as
    emission: every object gets a copy of its material without Luxel's nodes while Cycles
    bakes, and Luxel's material on empty slots is taken out, so that Cycles sees the user's
    shading everywhere."""
    clean = {}
    for obj in bpy.data.objects:
        if obj.library is not None:
            continue
        for index, slot in enumerate(obj.material_slots):
            material = slot.material
            if material is None or STATE_KEY not in material:
                continue
            if is_fill(material):   # Luxel's on an empty slot: no material of the user's
                slot_changes.append((obj, index, material))
                slot.material = None
                continue
            if material not in clean:
                clean[material] = _without_preview(material)
                temporary_materials.append(clean[material])
            slot_changes.append((obj, index, material))
            slot.material = clean[material]


def _without_preview(original):
    material = original.copy()
    material.name = TEMP_PREFIX + original.name
    strip_display_nodes(material)
    return material


def _restore_slots(slot_changes, added_slots):
    while slot_changes:
        obj, index, original = slot_changes.pop()
        obj.material_slots[index].material = original
    while added_slots:
        obj = added_slots.pop()
        obj.data.materials.clear()      # it had none (pop() leaves the object a slot)


class SettingsSnapshot:
    """The render engine and every plain setting of Cycles and of the bake panel (or of the
    given property groups), put back by calling the snapshot (only what changed is written
    back)."""

    def __init__(self, scene, groups=None):
        self.scene = scene
        self.engine = scene.render.engine
        if groups is None:
            groups = (scene.cycles, scene.render.bake)
        self.groups = [(group, _plain_properties(group)) for group in groups]

    def __call__(self):
        for group, values in self.groups:
            for name, value in values.items():
                if _value(group, name) != value:
                    try:
                        setattr(group, name, value)
                    except (AttributeError, TypeError, ValueError):
                        pass
        if self.scene.render.engine != self.engine:
            self.scene.render.engine = self.engine


def _plain_properties(group):
    values = {}
    for prop in group.bl_rna.properties:
        if prop.identifier == "rna_type" or prop.is_readonly or prop.type in {'POINTER',
                                                                             'COLLECTION'}:
            continue
        values[prop.identifier] = _value(group, prop.identifier)
    return values


def _value(group, name):
    value = getattr(group, name)
    if isinstance(value, (set, frozenset)):     # enum flags
        return set(value)
    if hasattr(value, "__len__") and not isinstance(value, str):
        return tuple(value)
    return value
