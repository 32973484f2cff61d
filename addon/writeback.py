"""Bake results into the .blend: one float image per atlas page (packed, or EXR files next to
the .blend) and one of the irradiance that page reflects (what glTF export writes), a lightmap
UV map on each receiving mesh, and each object's ``luxel`` record.
The new images and files are made beside the old ones and replace them only once everything
is written; a failure on the way (a full disk) undoes what was made, so the .blend and the
lightmap folder are left as they were."""
import os
import tempfile

import bpy
import numpy as np

from ..native import LuxelError, SettingsError, write_exr

UV_MAP = "LuxelLightmap"
UV_MAP_BACK = "LuxelLightmapBack"   # where back faces that are solved find their texels
# A mesh without a UV map renders its UV coordinates as 0 (Texture Coordinate > UV), and the
# first map it gets becomes the one its materials read: an all-zero map made first keeps that
# look (hold_render_uv). On the mesh, PLACEHOLDER_KEY names it; it goes with the lightmap's
# map unless the user has filled it since.
PLACEHOLDER_UV = "UVMap"
PLACEHOLDER_KEY = "luxel_placeholder_uv"
PAGE_KEY = "luxel_page"          # ID property marking Luxel's images, with their page number
IRRADIANCE_KEY = "luxel_irradiance_page"    # the same on the pages of irradiance
# On objects: their slot's offset, and 1 for "baked" (2: with its back faces' texels too).
OBJECT_OFFSET = "luxel_object"
INSTANCER_OFFSET = "luxel_instancer"  # on instancers and objects: block offset, page + 1
SNAPSHOT_PREFIX = "Luxel UV "    # the vertex-only meshes holding evaluated corners' UVs
SNAPSHOT_ATTRIBUTE = "luxel_uv"
SNAPSHOT_BACK_ATTRIBUTE = "luxel_uv_back"
NODE_GROUP = "Luxel Lightmap UV"
MODIFIER = "Luxel Lightmap"     # the modifier of Luxel's that adds the lightmap UV map
STALE_UV = -1000.0               # where a stale snapshot puts the UVs: off every page


def image_name(scene, page, *, irradiance=False):
    return f"Luxel {scene.name} {page}" + (" Irradiance" if irradiance else "")


def irradiance_images(scene):
    """{page number: image} of the bake's irradiance pages."""
    return {image[IRRADIANCE_KEY]: image for image in bpy.data.images
            if IRRADIANCE_KEY in image and image.name.startswith(image_name(scene, ""))}


def collection_array(collection, attribute, dtype, shape):
    """A Blender collection's ``attribute`` of every item (foreach_get) as an array of
    ``shape`` (its first axis the items, -1 for their count)."""
    width = int(np.prod(shape[1:])) if len(shape) > 1 else 1
    flat = np.empty(len(collection) * width, dtype=dtype)
    collection.foreach_get(attribute, flat)
    return flat.reshape(shape)


def image_pixels(image):
    """An image's pixels as an (H, W, 4) float32 array, row 0 at v = 0."""
    width, height = image.size
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(height, width, 4)


def lightmap_directory(scene):
    """Absolute folder for EXR output; an error before anything is written if it can't be."""
    settings = scene.luxel
    if settings.directory.startswith("//") and not bpy.data.filepath:
        raise SettingsError("the .blend is not saved, so the lightmap folder "
                            f"'{settings.directory}' has no place: save the file first, or set "
                            "Output to 'Pack into .blend'")
    directory = os.path.abspath(bpy.path.abspath(settings.directory))
    if not writable(directory):
        raise SettingsError(f"the lightmap folder '{directory}' cannot be written: choose a "
                            "folder you may write to (Render properties > Luxel Lightmaps > "
                            "Folder, or --output), or set Output to 'Pack into .blend'")
    return directory


def write_back(scene, export, atlas, pages, irradiance):
    """Store ``pages`` and ``irradiance`` ((H, W, 4) arrays, row 0 at v = 0: Solver.result()
    and result(reflected=False)) and the atlas UVs in the .blend; returns the pages' images."""
    settings = scene.luxel
    directory = lightmap_directory(scene) if settings.output == 'FILES' else None
    for receiver in export.receivers:
        if bpy.data.objects.get(receiver.object_name) is None:
            raise SettingsError(f"object '{receiver.object_name}' vanished during the bake; "
                                "bake again")
    previous = {image.name for image in _page_images(scene)}
    undo = []           # what to do, last first, to take back each change made so far
    try:
        if directory is not None:
            _make_directory(directory, undo)
        images = [_page_image(scene, index, page, directory, undo)
                  for index, page in enumerate(pages)]
        arriving = [_page_image(scene, index, page, directory, undo, irradiance=True)
                    for index, page in enumerate(irradiance)]
        baked = _write_receivers(export, atlas, images, undo)
    except BaseException:
        for action in reversed(undo):
            action()
        raise

    # Everything is written: the new results take the old ones' place.
    for image in images + arriving:
        _replace_page(scene, image, directory)
    for obj in scene.objects:
        if obj.name not in baked and (obj.luxel.uv_map or OBJECT_OFFSET in obj
                                      or INSTANCER_OFFSET in obj):
            clear_object(obj)
    for name in previous - {image.name for image in images + arriving}:
        bpy.data.images.remove(bpy.data.images[name])
    return images


def _write_receivers(export, atlas, images, undo):
    """The lightmap UV maps, offsets and ``luxel`` records of the receivers; returns the
    names of the objects and instancers written.

    A layout's UV map holds its charts from their layout's corner; each object adds the
    offset of its slot (``luxel_object``, read by the Attribute node as Object) and each
    instancer, or object shown by itself, that of its block and its page plus one
    (``luxel_instancer``, read as Instancer, which falls back to the object's own). A layout
    shown once has its whole place in the UV map, so that what reads the UV map alone
    (Workbench, a Cycles bake) finds it."""
    count = len(export.scene.triangles)
    row_of_triangle, row_of_back = np.full(count, -1), np.full(count, -1)
    # Back faces solved on texels of their own come after the scene's triangles, wound the
    # other way (Scene.with_back_faces).
    front = atlas.triangles < count
    row_of_triangle[atlas.triangles[front]] = np.nonzero(front)[0]
    originals = export.scene.back_face_originals()
    row_of_back[originals[atlas.triangles[~front] - count]] = np.nonzero(~front)[0]
    page_size = np.array([atlas.width, atlas.height], dtype=np.float64)
    shown = {}
    for receiver in export.receivers:
        shown.setdefault(receiver.layout, []).append(receiver)
    written = set()
    for receivers in shown.values():
        whole = len(receivers) == 1
        first = receivers[0]
        triangles = slice(first.first_triangle, first.first_triangle + len(first.loops))
        origin = np.zeros(2) if whole else atlas.object_origin[first.object_index]
        uv = (atlas.texels[row_of_triangle[triangles]] - origin) / page_size
        back_rows = row_of_back[triangles]
        back_uv = None
        if first.back_faces and (back_rows >= 0).all():
            back_uv = (atlas.texels[back_rows][:, ::-1] - origin) / page_size
        for receiver in receivers:
            obj = bpy.data.objects.get(receiver.object_name)
            instancer = bpy.data.objects.get(receiver.instancer_name)
            page = int(atlas.object_page[receiver.object_index])
            offset = atlas.object_offset[receiver.object_index]
            block = atlas.object_origin[receiver.object_index] - offset
            if whole:
                offset, block = np.zeros(2), np.zeros(2)
            if obj.name not in written:
                _write_uvs(obj, receiver, uv, back_uv, undo)
                _set_property(obj, OBJECT_OFFSET,
                              [*(offset / page_size), 1.0 if back_uv is None else 2.0], undo)
                undo.append(lambda obj=obj, record=(obj.luxel.image, obj.luxel.uv_map):
                            _set_record(obj, *record))
                _set_record(obj, images[page], UV_MAP)
                written.add(obj.name)
            _set_property(instancer, INSTANCER_OFFSET, [*(block / page_size), page + 1.0],
                          undo)
            written.add(instancer.name)
    return written


def _set_property(obj, key, value, undo):
    before = obj.get(key)
    undo.append(lambda: obj.__setitem__(key, before) if before is not None
                else obj.pop(key, None))
    obj[key] = value


def _write_uvs(obj, receiver, triangle_uv, back_uv, undo):
    # The lightmap's map, in the mesh or added by Luxel's modifier, must not become the one
    # the materials read where the mesh has none.
    if isinstance(obj.data, bpy.types.Mesh):
        placeholder = hold_render_uv(obj.data)
        if placeholder is not None:
            obj.data[PLACEHOLDER_KEY] = placeholder.name
            undo.append(lambda mesh=obj.data: _remove_placeholder(mesh))
    if receiver.uv_source == 'MESH':
        _remove_snapshot(obj)
        _write_uv_map(obj.data, UV_MAP, receiver.loops, triangle_uv, undo)
        if back_uv is not None:
            _write_uv_map(obj.data, UV_MAP_BACK, receiver.loops, back_uv, undo)
        else:
            _remove_uv_map(obj.data, UV_MAP_BACK, undo)
    else:
        for name in (UV_MAP, UV_MAP_BACK):      # baked before without modifiers
            _remove_uv_map(obj.data, name, undo)
        _write_snapshot(obj, receiver, triangle_uv, back_uv, undo)


def _remove_uv_map(data, name, undo):
    """Remove a UV map of Luxel's; undo brings back its UVs."""
    layers = data.uv_layers if isinstance(data, bpy.types.Mesh) else None
    if layers is None or name not in layers:
        return
    values = np.empty(len(data.loops) * 2, dtype=np.float32)
    layers[name].uv.foreach_get("vector", values)
    layers.remove(layers[name])

    def restore():
        layers.new(name=name, do_init=False)
        _set_uvs(data, name, values)
    undo.append(restore)


def _set_record(obj, image, uv_map):
    obj.luxel.image = image
    obj.luxel.uv_map = uv_map


def clear_object(obj):
    """Remove what a previous bake left on ``obj``: its lightmap UV map or modifier and
    snapshot, its offsets and its image reference."""
    if obj.type == 'MESH' and obj.luxel.uv_map:
        for name in (obj.luxel.uv_map, UV_MAP_BACK):
            layer = obj.data.uv_layers.get(name)
            if layer is not None:
                obj.data.uv_layers.remove(layer)
        if PLACEHOLDER_KEY in obj.data:
            _remove_placeholder(obj.data)
    _remove_snapshot(obj)
    for key in (OBJECT_OFFSET, INSTANCER_OFFSET):
        obj.pop(key, None)
    obj.luxel.uv_map = ""
    obj.luxel.image = None


def remove_written(scene):
    """Take away what write_back wrote into ``scene`` and the file: the lightmap images (and
    their EXR files' links), UV maps, modifiers, snapshots, the node group, offsets and
    records."""
    for obj in scene.objects:
        clear_object(obj)
    for image in _page_images(scene):
        bpy.data.images.remove(image)
    for obj in [obj for obj in bpy.data.objects if obj.name.startswith(SNAPSHOT_PREFIX)
                and obj.users == 0]:
        bpy.data.objects.remove(obj)
    group = bpy.data.node_groups.get(NODE_GROUP)
    if group is not None and group.users == 0:
        bpy.data.node_groups.remove(group)


def is_stale(obj, depsgraph):
    """Whether the object's modifiers no longer make the corners its lightmap was baked for:
    its modifier then shows no lightmap (UVs far outside the page), and the panel says so."""
    snapshot = snapshot_of(obj)
    if snapshot is None:
        return False
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        return mesh is None or len(mesh.loops) != len(snapshot.data.vertices)
    finally:
        evaluated.to_mesh_clear()


def snapshot_of(obj):
    modifier = obj.modifiers.get(MODIFIER)
    if modifier is None or modifier.type != 'NODES':
        return None
    return _input(modifier, "Snapshot")


def _page_images(scene):
    """Luxel's images of ``scene``: its lightmaps and irradiance pages."""
    return [image for image in bpy.data.images if (PAGE_KEY in image or IRRADIANCE_KEY in image)
            and image.name.startswith(image_name(scene, ""))]


def _page_image(scene, index, page, directory, undo, *, irradiance=False):
    """A new image for ``page``, beside any old one of its name (Blender suffixes it), packed
    or read from a staged EXR file; _replace_page() swaps it in."""
    name = image_name(scene, index, irradiance=irradiance)
    height, width = page.shape[:2]
    pixels = np.ascontiguousarray(page, dtype=np.float32).copy()
    # Opaque everywhere: Blender premultiplies packed float images by alpha, which would wipe
    # the dilated gutter that bilinear filtering reads at chart edges.
    pixels[..., 3] = 1.0
    if directory is not None:
        staged = _exr_path(directory, name, staged=True)
        undo.append(lambda: _remove_file(staged))
        try:
            write_exr(staged, pixels)
        except OSError as error:
            raise LuxelError(f"could not write the lightmap '{_exr_path(directory, name)}' "
                             f"({error.strerror or error}): free some disk space or choose "
                             "another folder, or set Output to 'Pack into .blend'") from error
        image = bpy.data.images.load(staged)
        image.name = name
    else:
        image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
        image.pixels.foreach_set(pixels.ravel())
        image.file_format = 'OPEN_EXR'
        image.pack()
    undo.append(lambda: bpy.data.images.remove(image))
    image.colorspace_settings.name = 'Linear Rec.709'
    image[IRRADIANCE_KEY if irradiance else PAGE_KEY] = index
    # No material reads the irradiance: a fake user keeps it when the .blend is saved.
    image.use_fake_user = irradiance
    return image


def _replace_page(scene, image, directory):
    """The new page image takes the old one's users and name, and its file the final name."""
    key = PAGE_KEY if PAGE_KEY in image else IRRADIANCE_KEY
    name = image_name(scene, image[key], irradiance=key == IRRADIANCE_KEY)
    old = bpy.data.images.get(name)
    if old is not None and old != image and key in old:
        old.user_remap(image)
        bpy.data.images.remove(old)
    image.name = name
    if directory is not None:
        path = _exr_path(directory, name)
        os.replace(_exr_path(directory, name, staged=True), path)
        image.filepath = bpy.path.relpath(path) if bpy.data.filepath else path


def _exr_path(directory, name, staged=False):
    """The page's EXR file, or the hidden file it is staged in until the bake is written."""
    file = bpy.path.clean_name(name) + ".exr"
    return os.path.join(directory, "." + file + ".baking" if staged else file)


def _remove_file(path):
    if os.path.exists(path):
        os.unlink(path)


def writable(directory):
    """A folder that exists and takes a file, or whose nearest existing parent does (a file
    is made and removed there: permissions alone pass a root user in /proc)."""
    existing = directory
    while not os.path.exists(existing):
        existing = os.path.dirname(existing)
    if not os.path.isdir(existing):
        return False
    try:
        with tempfile.TemporaryFile(dir=existing):
            return True
    except OSError:
        return False


def _make_directory(directory, undo):
    missing = []
    path = directory
    while not os.path.isdir(path):
        missing.append(path)
        path = os.path.dirname(path)
    try:
        os.makedirs(directory, exist_ok=True)
    except OSError as error:
        raise LuxelError(f"could not make the lightmap folder '{directory}' "
                         f"({error.strerror or error}): choose a folder you may write to, or "
                         "set Output to 'Pack into .blend'") from error
    for path in reversed(missing):      # undone from the deepest
        undo.append(lambda path=path: os.rmdir(path))


def hold_render_uv(mesh):
    """Where ``mesh`` has no UV map, an all-zero one as its active and render map (what its
    materials read where it has none), so that a map added next is not what they read.
    Returns the map made, or None."""
    if len(mesh.uv_layers):
        return None
    layer = mesh.uv_layers.new(name=PLACEHOLDER_UV, do_init=False)
    mesh.attributes[layer.name].data.foreach_set(
        "vector", np.zeros(2 * len(mesh.loops), dtype=np.float32))
    return layer


def _remove_placeholder(mesh):
    """The map hold_render_uv() made on ``mesh``, unless the user has filled it."""
    layer = mesh.uv_layers.get(mesh.get(PLACEHOLDER_KEY, ""))
    if layer is not None:
        values = np.empty(2 * len(mesh.loops), dtype=np.float32)
        mesh.attributes[layer.name].data.foreach_get("vector", values)
        if not values.any():
            mesh.uv_layers.remove(layer)
    mesh.pop(PLACEHOLDER_KEY, None)


def _write_uv_map(mesh, name, loops, triangle_uv, undo):
    layers = mesh.uv_layers
    layer = layers.get(name)
    if layer is None:
        active, active_render = layers.active_index, _active_render_index(layers)
        layer = layers.new(name=name, do_init=False)
        undo.append(lambda: layers.remove(layers[name]))
        # A new layer must not take over the user's active or render UV map.
        if active >= 0:
            layers.active_index = active
        if active_render >= 0:
            layers[active_render].active_render = True
    else:
        before = np.empty(len(mesh.loops) * 2, dtype=np.float32)
        layer.uv.foreach_get("vector", before)
        undo.append(lambda: _set_uvs(mesh, name, before))
    loop_uv = np.zeros((len(mesh.loops), 2), dtype=np.float32)
    loop_uv[loops.ravel()] = triangle_uv.reshape(-1, 2)
    _set_uvs(mesh, name, loop_uv.ravel())


def _set_uvs(mesh, name, values):
    # Through the attribute, not uv_layers[name].uv: before Blender 5.2 that writes into the
    # array the mesh may share with its copies and its evaluated mesh (seen changing both),
    # where the attribute API first makes the mesh's own.
    mesh.attributes[name].data.foreach_set("vector", values)
    mesh.update()


def _active_render_index(layers):
    for index, layer in enumerate(layers):
        if layer.active_render:
            return index
    return -1


# -------------------------------------------------------------- the modifier and its snapshot
def _write_snapshot(obj, receiver, triangle_uv, back_uv, undo):
    """The evaluated corners' lightmap UVs (and their back faces'), as a vertex per corner of
    a mesh of Luxel's, and the modifier at the end of the object's stack that copies them
    onto the corners."""
    name = SNAPSHOT_PREFIX + obj.name
    mesh = bpy.data.meshes.new(name)
    undo.append(lambda: bpy.data.meshes.remove(mesh))
    mesh.vertices.add(receiver.corner_count)
    for attribute_name, uv in ((SNAPSHOT_ATTRIBUTE, triangle_uv),
                               (SNAPSHOT_BACK_ATTRIBUTE, back_uv)):
        if uv is None:
            continue
        corner_uv = np.zeros((receiver.corner_count, 3), dtype=np.float32)
        corner_uv[receiver.loops.ravel(), :2] = uv.reshape(-1, 2)
        attribute = mesh.attributes.new(attribute_name, 'FLOAT_VECTOR', 'POINT')
        attribute.data.foreach_set("vector", corner_uv.ravel())
    snapshot = snapshot_of(obj)
    if snapshot is None:
        snapshot = bpy.data.objects.new(name, mesh)
        undo.append(lambda: bpy.data.objects.remove(snapshot))
        modifier = obj.modifiers.new(MODIFIER, 'NODES')
        undo.append(lambda: obj.modifiers.remove(obj.modifiers[MODIFIER]))
        modifier.node_group = _node_group(undo)
        modifier.show_in_editmode = False
        _set_input(modifier, "Snapshot", snapshot)
    else:
        before = snapshot.data
        snapshot.data = mesh
        undo.append(lambda: setattr(snapshot, "data", before))
    modifier = obj.modifiers[MODIFIER]
    shown_before = bool(_input(modifier, "Back Faces"))
    _set_input(modifier, "Back Faces", back_uv is not None)
    undo.append(lambda: _set_input(modifier, "Back Faces", shown_before))
    # The modifier comes last, after any the user added since.
    if obj.modifiers[-1].name != MODIFIER:
        index = list(obj.modifiers).index(obj.modifiers[MODIFIER])
        obj.modifiers.move(index, len(obj.modifiers) - 1)


def _remove_snapshot(obj):
    snapshot = snapshot_of(obj)
    modifier = obj.modifiers.get(MODIFIER)
    if modifier is not None:
        obj.modifiers.remove(modifier)
    if snapshot is not None:
        mesh = snapshot.data
        bpy.data.objects.remove(snapshot)
        if mesh.users == 0:
            bpy.data.meshes.remove(mesh)


def _input(modifier, name):
    """The value of the geometry-nodes modifier's input ``name`` (None where unset)."""
    key = modifier.node_group.interface.items_tree[name].identifier
    if _has_input_properties(modifier):
        return getattr(modifier.properties.inputs, key).value
    return modifier.get(key)


def _set_input(modifier, name, value):
    key = modifier.node_group.interface.items_tree[name].identifier
    if _has_input_properties(modifier):
        getattr(modifier.properties.inputs, key).value = value
    else:
        modifier[key] = value


def _has_input_properties(modifier):
    """Blender 5.2 keeps a modifier's inputs in modifier.properties.inputs; before, they were
    ID properties of the modifier, keyed by the socket's identifier."""
    return hasattr(getattr(modifier, "properties", None), "inputs")


def _node_group(undo):
    """Luxel's geometry nodes: the snapshot's UV of each corner, by index, stored as the
    lightmap UV map (and the back faces' map, where the modifier's Back Faces is on); far
    outside every page when the corners no longer match."""
    group = bpy.data.node_groups.get(NODE_GROUP)
    if group is not None:
        return group
    group = bpy.data.node_groups.new(NODE_GROUP, 'GeometryNodeTree')
    undo.append(lambda: bpy.data.node_groups.remove(group))
    interface = group.interface
    interface.new_socket("Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
    interface.new_socket("Snapshot", in_out='INPUT', socket_type='NodeSocketObject')
    interface.new_socket("Back Faces", in_out='INPUT', socket_type='NodeSocketBool')
    interface.new_socket("Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    nodes, links = group.nodes, group.links
    inputs, outputs = nodes.new('NodeGroupInput'), nodes.new('NodeGroupOutput')
    info = nodes.new('GeometryNodeObjectInfo')
    links.new(inputs.outputs["Snapshot"], info.inputs["Object"])
    corners = nodes.new('GeometryNodeAttributeDomainSize')
    corners.component = 'MESH'
    links.new(inputs.outputs["Geometry"], corners.inputs[0])
    points = nodes.new('GeometryNodeAttributeDomainSize')
    points.component = 'MESH'
    links.new(info.outputs["Geometry"], points.inputs[0])
    same = nodes.new('FunctionNodeCompare')
    same.data_type, same.operation = 'INT', 'EQUAL'
    # The integer sockets: by name, as Blender 5.2 keeps only the data type's sockets.
    a, b = (next(socket for socket in same.inputs if socket.enabled and socket.name == name)
            for name in ("A", "B"))
    links.new(corners.outputs["Face Corner Count"], a)
    links.new(points.outputs["Point Count"], b)
    index = nodes.new('GeometryNodeInputIndex').outputs[0]
    geometry = inputs.outputs["Geometry"]
    for attribute, uv_map in ((SNAPSHOT_ATTRIBUTE, UV_MAP),
                              (SNAPSHOT_BACK_ATTRIBUTE, UV_MAP_BACK)):
        sample = nodes.new('GeometryNodeSampleIndex')
        sample.data_type, sample.domain = 'FLOAT_VECTOR', 'POINT'
        links.new(info.outputs["Geometry"], sample.inputs["Geometry"])
        stored = nodes.new('GeometryNodeInputNamedAttribute')
        stored.data_type = 'FLOAT_VECTOR'
        stored.inputs["Name"].default_value = attribute
        links.new(stored.outputs["Attribute"], sample.inputs["Value"])
        links.new(index, sample.inputs["Index"])
        switch = nodes.new('GeometryNodeSwitch')
        switch.input_type = 'VECTOR'
        switch.inputs["False"].default_value = (STALE_UV, STALE_UV, 0.0)
        links.new(same.outputs[0], switch.inputs["Switch"])
        links.new(sample.outputs[0], switch.inputs["True"])
        store = nodes.new('GeometryNodeStoreNamedAttribute')
        store.data_type, store.domain = 'FLOAT2', 'CORNER'
        store.inputs["Name"].default_value = uv_map
        links.new(geometry, store.inputs["Geometry"])
        links.new(switch.outputs[0], store.inputs["Value"])
        if uv_map == UV_MAP_BACK:       # only for objects whose back faces were solved
            either = nodes.new('GeometryNodeSwitch')
            either.input_type = 'GEOMETRY'
            links.new(inputs.outputs["Back Faces"], either.inputs["Switch"])
            links.new(geometry, either.inputs["False"])
            links.new(store.outputs[0], either.inputs["True"])
            geometry = either.outputs[0]
        else:
            geometry = store.outputs[0]
    links.new(geometry, outputs.inputs[0])
    return group
