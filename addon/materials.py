"""Materials as Cycles sees them: each mesh's albedo and emission per lightmap texel.

evaluate_materials charts the lightmap atlas first (native.lightmap_atlas, the one the solver
then finds cached) and has Cycles bake every mesh copy's materials into it: DIFFUSE with only
the COLOR pass (the albedo a Cycles DIFFUSE bake multiplies its light by, whatever the node
tree: textures through any coordinates, procedurals, vertex colours, attributes, node groups,
mixes, the layers above a Principled BSDF's diffuse base), GLOSSY with only the COLOR pass
(what the glossy layers reflect: specular, coat, metal), EMIT (colour x strength) and, where
the glossy colour is not black, ROUGHNESS (how wide the glossy layers' lobe is). Each
page's images go to the solver as textures through the atlas UVs: the albedo is what the
lightmap shows (a Cycles DIFFUSE bake's colour), the albedo plus the glossy colour what the
surface reflects into the room, its glossy share in a lobe as wide as the roughness at the
triangle's centre (native/lobes.py; see docs/materials.md). Materials whose nodes
cannot vary over the surface bake at one sample per sub-texel, SUPERSAMPLE x SUPERSAMPLE a
texel, each texel the mean of those on a triangle; the others at MATERIAL_SAMPLES jittered
over the texel (Cycles' pixel filter averages what lies around its centre).

Cycles bakes temporary copies of the evaluated meshes, with temporary copies of their
materials, each alone in a temporary scene (those whose materials cannot vary joined into one
object): the user's scene, objects, materials, images, render settings and UV maps are never
edited, and every temporary block is removed, whatever happens."""
from contextlib import contextmanager
import ctypes
from dataclasses import dataclass, field, replace
import os
import sys

import bpy
import numpy as np

from ..native import SceneError, lightmap_atlas
from ..native.postprocess import fill_gutter
from . import node_trees
from .display import STATE_KEY, strip_display_nodes
from .writeback import collection_array, hold_render_uv, image_pixels

MATERIAL_SAMPLES = 32       # Cycles samples per texel of a material that varies
# A material that cannot vary over a surface bakes SUPERSAMPLE x SUPERSAMPLE sub-texels a
# texel: Cycles writes a pixel only where its centre lies on a triangle, and the solver's
# texels are every one a triangle touches (a letter's stroke, a cable, a chart's border): a
# strip half a texel wide is found, a narrower one takes its found neighbours' colour from
# the gutter fill (4 x 4 cost the office's evaluation 7 times 1 x 1's time, 2 x 2 twice and
# a half). One that varies bakes a pixel a texel, as Cycles' DIFFUSE bake samples it (its
# pixel filter about the centre), and the gutter fill gives the texels that only cross its
# surface their neighbours' colour.
SUPERSAMPLE = 2
MAX_ALBEDO = 0.999          # a diffuse surface cannot reflect everything (native checks < 1)
TEXTURE_TINT = 0.9999       # the solver multiplies the textures by it; it must stay below 1
TEMP_PREFIX = "Luxel Materials "
BAKE_UV = "Luxel Materials UV"
OUTSIDE_UV = -16.0          # where corners outside the atlas go: off every image
GUTTER_TEXELS = 3           # filled around each chart: partly covered texels and the
#                             bilinear filter at chart borders read real values
DEFAULT_COLOUR = (0.8, 0.8, 0.8, 1.0)   # what Cycles shows for an empty material slot


@dataclass
class _Unevaluable:
    """Where one kind of problem (node_trees.unevaluable) was found: its images or nodes
    and the materials holding them, each once, in the order met (dicts as ordered sets)."""
    subjects: dict = field(default_factory=dict)
    materials: dict = field(default_factory=dict)


@dataclass
class _Bake:
    """The temporary blocks of one evaluation, removed by release()."""
    scene: object = None
    objects: list = field(default_factory=list)
    meshes: list = field(default_factory=list)
    materials: list = field(default_factory=list)
    images: list = field(default_factory=list)

    def release(self):
        for obj in self.objects:
            bpy.data.objects.remove(obj)
        for kind, blocks in ((bpy.data.meshes, self.meshes), (bpy.data.materials, self.materials),
                             (bpy.data.images, self.images)):
            for block in blocks:
                kind.remove(block)
        if self.scene is not None:
            bpy.data.scenes.remove(self.scene)
        self.objects, self.meshes, self.materials, self.images = [], [], [], []
        self.scene = None

    def remove(self, obj):
        """Remove a temporary object and its mesh now."""
        mesh = obj.data
        self.objects.remove(obj)
        bpy.data.objects.remove(obj)
        self.meshes.remove(mesh)
        bpy.data.meshes.remove(mesh)


@dataclass
class _Copy:
    """A temporary object of one Surface, baked into images of its box on its page (``low``,
    ``size``: whole texels), in the group of its sample count."""
    obj: object
    page: int
    low: np.ndarray
    size: np.ndarray
    varies: bool
    emits: bool


def evaluate_materials(depsgraph, export, settings):
    """Replace ``export.scene``'s stand-in materials (export.Export) with Cycles' evaluation per
    texel of the atlas that ``settings`` chart; add the warnings of what Cycles cannot
    evaluate as Luxel needs it, and the materials' mean emission (export.emission_of_material,
    for the display). Returns the atlas."""
    scene = export.scene
    atlas = lightmap_atlas(scene, settings)
    count = len(scene.triangles)
    own = atlas.triangles < count                # the back faces' copies read their fronts
    row_of = np.full(count, -1)
    row_of[atlas.triangles[own]] = np.nonzero(own)[0]
    corner_uv = atlas.uv()
    bake = _Bake()
    try:
        copies = _make_copies(depsgraph, export, atlas, row_of, bake)
        albedo, glossy, emission, roughness = _bake_pages(copies, atlas, bake)
    finally:
        bake.release()
    _check_range(export, atlas, albedo, emission)
    reflectance = [np.clip(a + g, 0.0, MAX_ALBEDO) for a, g in zip(albedo, glossy)]
    meshes = np.zeros(count, dtype=bool)
    for surface in export.surfaces:
        meshes[surface.first_triangle:surface.first_triangle + len(surface.loops)] = True
    charted = meshes & (row_of >= 0)
    page = np.where(charted, atlas.page[row_of], -1)
    uv = np.zeros((count, 3, 2))
    uv[charted] = corner_uv[row_of[charted]]
    emits = charted & (scene.emission.max(axis=1) > 0.0)
    centre = uv.mean(axis=1) * np.array([atlas.width, atlas.height])
    x, y = (np.clip(centre[:, axis].astype(np.int64), 0, size - 1)
            for axis, size in ((0, atlas.width), (1, atlas.height)))
    rough = np.ones(count)
    rough[charted] = np.asarray(roughness)[page[charted], y[charted], x[charted]]
    tinted = np.where(charted[:, None], TEXTURE_TINT, scene.albedo)
    export.scene = replace(
        scene, albedo=tinted, albedo_uv=uv, albedo_texture_index=page, albedo_textures=albedo,
        reflectance=tinted, reflectance_texture_index=page, reflectance_textures=reflectance,
        emission_texture_index=np.where(emits, page, -1), emission_textures=emission,
        roughness=np.clip(rough, 0.0, 1.0), glossy_fresnel=True)
    export.emission_of_material = _mean_emission(export, atlas, row_of, emission)
    return atlas


def instance_key(instance):
    """What tells a depsgraph instance apart from the others, from one iteration to the next."""
    instancer = instance.parent.original.name if instance.is_instance else ""
    return (instance.object.original.name, instancer, tuple(instance.persistent_id))


# ------------------------------------------------------------------------ the copies
def _make_copies(depsgraph, export, atlas, row_of, bake):
    """A temporary object per charted Surface: its evaluated mesh (every attribute kept) at
    its place, with its place in the atlas as BAKE_UV (in its own box of texels: Cycles bakes
    each object over its whole image) and copies of its materials whose active node is an
    image of its box."""
    bake.scene = bpy.data.scenes.new(TEMP_PREFIX + "Scene")
    surfaces = {surface.key: surface for surface in export.surfaces
                if atlas.object_page[surface.object_index] >= 0}
    copies, unevaluable = [], {}   # problem: _Unevaluable
    found = []
    for instance in depsgraph.object_instances:
        surface = surfaces.pop(instance_key(instance), None)
        if surface is None:
            continue
        mesh = bpy.data.meshes.new_from_object(instance.object, preserve_all_data_layers=True,
                                               depsgraph=depsgraph)
        bake.meshes.append(mesh)
        if len(mesh.loops) != surface.corners:     # not the mesh the export saw
            surfaces[surface.key] = surface
            continue
        found.append((surface, mesh, instance.matrix_world.copy()))
    # Instances Blender cannot hand over as meshes of their own (some that geometry nodes
    # make): their exported triangles, without the mesh's attributes.
    for surface in surfaces.values():
        mesh = _triangle_mesh(export.scene, surface)
        bake.meshes.append(mesh)
        found.append((surface, mesh, None))
        name = export.scene.object_names[surface.object_index]
        export.warnings.append(f"'{name}': Blender does not give its evaluated mesh apart, so "
                               "its materials were evaluated without its UV maps and "
                               "attributes (realize its instances to bake them)")
    for surface, mesh, matrix in found:
        page = int(atlas.object_page[surface.object_index])
        rows = row_of[surface.first_triangle + np.arange(len(surface.loops))]
        texels = atlas.texels[rows[rows >= 0]].reshape(-1, 2)
        low = np.floor(texels.min(axis=0)).astype(int)
        size = np.maximum(np.ceil(texels.max(axis=0)).astype(int) - low, 1)
        corners = np.full((len(rows), 3, 2), OUTSIDE_UV)
        corners[rows >= 0] = (atlas.texels[rows[rows >= 0]] - low) / size
        _set_bake_uv(mesh, surface, corners, export.scene, in_loops=matrix is not None)
        obj = bpy.data.objects.new(TEMP_PREFIX + mesh.name, mesh)
        bake.objects.append(obj)
        if matrix is not None:
            obj.matrix_world = matrix
        originals = [None if name is None else bpy.data.materials[name]
                     for name in surface.materials]
        targets = {}
        for slot, original in enumerate(originals):
            if original not in targets:
                targets[original] = _baking_material(original, bake)
            if slot < len(mesh.materials):
                mesh.materials[slot] = targets[original]
            else:
                mesh.materials.append(targets[original])
        used = [originals[slot] for slot in np.unique(surface.slot)
                if originals[slot] is not None]
        for original in used:
            for problem, subject in node_trees.unevaluable(original):
                found = unevaluable.setdefault(problem, _Unevaluable())
                found.subjects[subject] = found.materials[original.name] = None
        copies.append(_Copy(obj, page, low, size, any(node_trees.varies(m) for m in used),
                            any(node_trees.may_emit(m) for m in used)))
    # One warning per kind of problem: an imported level's hundred materials missing their
    # images would otherwise bury every other warning.
    export.warnings += [problem.format(images=quoted_names("image", found.subjects),
                                       nodes=quoted_names("node", found.subjects),
                                       materials=quoted_names("material", found.materials))
                        for problem, found in unevaluable.items()]
    export.warnings[:] = list(dict.fromkeys(export.warnings))
    return copies


def _triangle_mesh(scene, surface):
    """A mesh of the surface's exported triangles (world space), one corner each, with their
    material slots."""
    triangles = surface.first_triangle + np.arange(len(surface.loops))
    corners = scene.vertices[scene.triangles[triangles]].reshape(-1, 3)
    mesh = bpy.data.meshes.new(TEMP_PREFIX + scene.object_names[surface.object_index])
    mesh.from_pydata(corners.tolist(), [], np.arange(len(corners)).reshape(-1, 3).tolist())
    mesh.polygons.foreach_set("material_index", surface.slot.astype(np.int32))
    for _ in surface.materials:
        mesh.materials.append(None)
    return mesh


def _set_bake_uv(mesh, surface, corners, scene, *, in_loops):
    """BAKE_UV: ``corners`` (T, 3, 2) at the surface's corners in the evaluated mesh
    (``in_loops``), or at the corners of _triangle_mesh's triangles, in order."""
    if len(mesh.uv_layers) >= 8:
        name = scene.object_names[surface.object_index]
        raise SceneError(f"object '{name}' has 8 UV maps, Blender's limit, and Luxel needs one "
                         "more to evaluate its materials: remove one", name)
    uv = np.full((len(mesh.loops), 2), OUTSIDE_UV)
    if in_loops:
        uv[surface.loops.ravel()] = corners.reshape(-1, 2)
    else:
        uv[:] = corners.reshape(-1, 2)
    # The render map stays the user's, or where the mesh has none, the all-zero map that
    # stands for none: their materials read what they read in a render.
    hold_render_uv(mesh)
    layer = mesh.uv_layers.new(name=BAKE_UV, do_init=False)
    layer.uv.foreach_set("vector", uv.astype(np.float32).ravel())
    mesh.uv_layers.active = layer


def _baking_material(original, bake):
    """A copy of ``original`` (Blender's default surface for an empty slot) without Luxel's
    display nodes, whose active node is the image Cycles bakes into (set per pass)."""
    if original is None:
        material = bpy.data.materials.new(TEMP_PREFIX + "Default")
        tree = material.node_tree
        tree.nodes.clear()
        diffuse = tree.nodes.new('ShaderNodeBsdfDiffuse')
        diffuse.inputs["Color"].default_value = DEFAULT_COLOUR
        output = tree.nodes.new('ShaderNodeOutputMaterial')
        tree.links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])
    else:
        material = original.copy()
        material.name = TEMP_PREFIX + original.name
        if STATE_KEY in material:
            strip_display_nodes(material)
    bake.materials.append(material)
    if material.node_tree is None:      # a material without nodes: its viewport colour
        material.use_nodes = True
        tree = material.node_tree
        principled = next(n for n in tree.nodes if n.bl_idname == 'ShaderNodeBsdfPrincipled')
        principled.inputs["Base Color"].default_value = (*original.diffuse_color[:3], 1.0)
    target = material.node_tree.nodes.new('ShaderNodeTexImage')
    target.name = TEMP_PREFIX + "Target"
    material.node_tree.nodes.active = target
    return material


# ------------------------------------------------------------------------- the bakes
def _bake_pages(copies, atlas, bake):
    """Per page, the albedo, glossy colour and emission (H, W, 3) and the roughness (H, W; 1
    where nothing is glossy), row 0 at v = 0: each object's box pasted where Cycles baked a
    texel or, for a material that cannot vary, one of its sub-texels (texel_means), the
    gutters around the charts filled."""
    settings = bake.scene
    settings.render.engine = 'CYCLES'
    cycles = settings.cycles
    cycles.device = 'CPU'
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = 0
    view_layer = settings.view_layers[0]
    passes = []
    for kind in ('DIFFUSE', 'GLOSSY', 'EMIT', 'ROUGHNESS'):
        chosen = copies
        if kind == 'EMIT':
            chosen = [copy for copy in copies if copy.emits]
        elif kind == 'ROUGHNESS':
            chosen = [copy for copy in copies if _is_glossy(copy, passes[1])]
        pages = np.zeros((atlas.page_count, atlas.height, atlas.width, 4), dtype=np.float32)
        images = {}
        for copy in chosen:
            width, height = (int(n) * _supersample(copy) for n in copy.size)
            image = images[id(copy)] = bpy.data.images.new(
                f"{TEMP_PREFIX}{kind}", width, height, alpha=True, float_buffer=True)
            bake.images.append(image)
            image.colorspace_settings.name = 'Linear Rec.709'
            image.pixels.foreach_set(np.zeros(len(image.pixels), dtype=np.float32))
            for material in copy.obj.data.materials:
                material.node_tree.nodes.active.image = image
        # One object at a time in the scene: Cycles syncs the whole scene for each object it
        # bakes, and these passes need no light from the others.
        for obj, samples in _bake_objects(chosen, bake):
            cycles.samples = samples
            settings.collection.objects.link(obj)
            try:
                with bpy.context.temp_override(scene=settings, view_layer=view_layer,
                                               selected_objects=[obj],
                                               selected_editable_objects=[obj],
                                               active_object=obj, object=obj):
                    with bake_reports_silenced():
                        bpy.ops.object.bake(type=kind, pass_filter={'COLOR'}, uv_layer=BAKE_UV,
                                            margin=0, use_clear=False,
                                            target='IMAGE_TEXTURES',
                                            use_selected_to_active=False, use_cage=False)
            finally:
                settings.collection.objects.unlink(obj)
        for copy in chosen:
            pixels = texel_means(image_pixels(images[id(copy)]), _supersample(copy))
            height, width = pixels.shape[:2]
            baked = pixels[..., 3] > 0.0
            (x, y), page = copy.low, copy.page
            box = pages[page, y:y + height, x:x + width]
            box[baked] = np.concatenate([pixels[baked][:, :3],
                                         np.ones((int(baked.sum()), 1), np.float32)], axis=1)
        if kind == 'ROUGHNESS':   # one value; 1 where nothing is glossy
            passes.append(np.where(pages[..., 3] > 0.0, pages[..., 0], 1.0))
            continue
        for page in pages:
            fill_gutter(page, GUTTER_TEXELS)
        passes.append([page[..., :3] for page in pages])
    return passes


def _bake_objects(copies, bake):
    """(object, samples) for each Cycles bake of ``copies``: a material that varies, its copy
    alone at MATERIAL_SAMPLES; those that cannot vary joined into one object (_joined) at
    one sample, as their copies read nothing of their meshes. Each bake's fixed cost (the
    scene's sync, the kernels' set-up), not the texels, was most of their time in a scene
    of many objects."""
    constant = [copy for copy in copies if not copy.varies]
    if len(constant) > 1:
        joined = _joined(constant, bake)
        yield joined, 1
        bake.remove(joined)     # as big as the copies' meshes: not kept for the next pass
    elif constant:
        yield constant[0].obj, 1
    for copy in copies:
        if copy.varies:
            yield copy.obj, MATERIAL_SAMPLES


def _joined(copies, bake):
    """A temporary object of the copies' meshes in world space, each face with its BAKE_UV
    corners and its copy's materials (whose active nodes are its copy's images): a bake of
    it writes each copy's images as a bake of the copy would."""
    positions, corners, starts, slots, uv, materials = [], [], [], [], [], []
    vertex_count = corner_count = 0
    for copy in copies:
        mesh, matrix = copy.obj.data, np.array(copy.obj.matrix_world, dtype=np.float64)
        co = collection_array(mesh.vertices, "co", np.float64, (-1, 3))
        positions.append(co @ matrix[:3, :3].T + matrix[:3, 3])
        corners.append(collection_array(mesh.loops, "vertex_index", np.int32, (-1,))
                       + vertex_count)
        starts.append(collection_array(mesh.polygons, "loop_start", np.int32, (-1,))
                      + corner_count)
        # Blender clamps a face's slot to the mesh's last: here that would be the next copy's.
        slot = collection_array(mesh.polygons, "material_index", np.int32, (-1,))
        slots.append(np.minimum(slot, len(mesh.materials) - 1) + len(materials))
        uv.append(collection_array(mesh.uv_layers[BAKE_UV].uv, "vector", np.float32, (-1, 2)))
        materials += list(mesh.materials)
        vertex_count += len(mesh.vertices)
        corner_count += len(mesh.loops)
    joined = bpy.data.meshes.new(TEMP_PREFIX + "Joined")
    bake.meshes.append(joined)
    joined.vertices.add(vertex_count)
    joined.vertices.foreach_set("co", np.concatenate(positions).astype(np.float32).ravel())
    joined.loops.add(corner_count)
    joined.loops.foreach_set("vertex_index", np.concatenate(corners))
    starts = np.concatenate(starts)
    joined.polygons.add(len(starts))
    joined.polygons.foreach_set("loop_start", starts)
    joined.polygons.foreach_set("material_index", np.concatenate(slots))
    joined.update()
    layer = joined.uv_layers.new(name=BAKE_UV, do_init=False)
    layer.uv.foreach_set("vector", np.concatenate(uv).ravel())
    joined.uv_layers.active = layer
    for material in materials:
        joined.materials.append(material)
    obj = bpy.data.objects.new(TEMP_PREFIX + "Joined", joined)
    bake.objects.append(obj)
    return obj


def _supersample(copy):
    return 1 if copy.varies else SUPERSAMPLE


def texel_means(pixels, supersample):
    """(H, W, 4) of an (H s, W s, 4) Cycles bake, s = ``supersample``: each texel's mean over
    its sub-texels Cycles covered (their centres on a triangle), alpha their share."""
    if supersample == 1:
        return pixels
    height, width = pixels.shape[0] // supersample, pixels.shape[1] // supersample
    blocks = pixels.reshape(height, supersample, width, supersample, 4)
    covered = blocks[..., 3] > 0.0
    count = covered.sum(axis=(1, 3), dtype=np.float32)
    colour = np.where(covered[..., None], blocks[..., :3], np.float32(0.0)).sum(
        axis=3, dtype=np.float32).sum(axis=1)
    colour /= np.maximum(count, 1.0)[..., None]
    return np.concatenate([colour, (count / supersample ** 2)[..., None]], axis=2)


def _is_glossy(copy, glossy):
    """Whether any texel of ``copy``'s box has a glossy colour."""
    (x, y), (width, height) = copy.low, (int(n) for n in copy.size)
    return bool(glossy[copy.page][y:y + height, x:x + width].max(initial=0.0) > 0.0)


def _check_range(export, atlas, albedo, emission):
    """Albedo into [0, MAX_ALBEDO] and emission to 0 or more, with a warning naming the object
    and its materials where Cycles gave more or less."""
    scene = export.scene
    # The back faces' copies (after the scene's triangles) are their originals' objects'.
    object_of = np.concatenate([scene.object_index,
                                scene.object_index[scene.back_face_originals()]])
    for obj, page in enumerate(atlas.object_page):
        if page < 0:
            continue
        rows = np.nonzero(object_of[atlas.triangles] == obj)[0]
        low = np.floor(atlas.texels[rows].reshape(-1, 2).min(axis=0)).astype(int)
        high = np.ceil(atlas.texels[rows].reshape(-1, 2).max(axis=0)).astype(int)
        box = (slice(low[1], high[1]), slice(low[0], high[0]))
        materials = sorted({m for surface in export.surfaces if surface.object_index == obj
                            for m in surface.materials if m is not None})
        name = f"'{scene.object_names[obj]}'" + (
            f" ({quoted_names('material', materials)})" if materials else "")
        if albedo[page][box].max(initial=0.0) > MAX_ALBEDO:
            export.warnings.append(f"{name} reflects more than {MAX_ALBEDO} of the light in "
                                   "places (a colour of 1 or more): lowered to "
                                   f"{MAX_ALBEDO}, since a surface cannot reflect all light")
        if albedo[page][box].min(initial=0.0) < 0.0:
            export.warnings.append(f"{name} reflects negative light in places (a negative "
                                   "colour): raised to 0")
        if emission[page][box].min(initial=0.0) < 0.0:
            export.warnings.append(f"{name} emits negative light in places (a negative "
                                   "emission strength): raised to 0; set it to 0 or more")
    for page in range(atlas.page_count):
        np.clip(albedo[page], 0.0, MAX_ALBEDO, out=albedo[page])
        np.maximum(emission[page], 0.0, out=emission[page])


def _mean_emission(export, atlas, row_of, emission):
    """{material name: its mean emitted radiance}, area-weighted over its emitting triangles'
    centres (what the display adds to the baked light)."""
    scene = export.scene
    sums = {}
    for surface in export.surfaces:
        triangles = surface.first_triangle + np.arange(len(surface.loops))
        rows = row_of[triangles]
        chosen = (rows >= 0) & (scene.emission[triangles].max(axis=1) > 0.0)
        if not chosen.any():
            continue
        centre = atlas.texels[rows[chosen]].mean(axis=1).astype(int)
        page = atlas.page[rows[chosen]]
        values = np.array([emission[p][y, x] for p, (x, y) in zip(page, centre)])
        area = scene.triangle_area[triangles[chosen]]
        for slot in np.unique(surface.slot[chosen]):
            name = surface.materials[slot]
            mine = surface.slot[chosen] == slot
            total, weight = sums.get(name, (np.zeros(3), 0.0))
            sums[name] = (total + (values[mine] * area[mine, None]).sum(axis=0),
                          weight + area[mine].sum())
    return {name: tuple(total / weight) for name, (total, weight) in sums.items()
            if name is not None and weight > 0.0 and total.max() > 0.0}


def quoted_names(noun, names, most=3):
    """materials 'a', 'b', 'c' and 4 more (material 'a' alone): a list a warning can hold."""
    names = list(names)
    shown = ", ".join(f"'{name}'" for name in names[:most])
    return (f"{noun}{'s' if len(names) > 1 else ''} {shown}"
            + (f" and {len(names) - most} more" if len(names) > most else ""))


@contextmanager
def bake_reports_silenced():
    """In the background Blender prints every bake's "Baking map saved to internal image"
    on stdout: Luxel's temporary images', which it reads and removes. Blender's stdout goes
    to the null device for the bake (errors still raise); where the C library cannot be
    flushed, it is left as it is."""
    try:
        flush = ctypes.CDLL(None).fflush
    except (OSError, AttributeError, TypeError):
        flush = None
    if not bpy.app.background or flush is None:
        yield
        return
    sys.stdout.flush()
    kept = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        flush(None)
        os.dup2(kept, 1)
        os.close(kept)
