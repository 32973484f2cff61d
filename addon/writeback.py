"""Bake results into the .blend: one float image per atlas page (packed, or EXR files next to
the .blend), a lightmap UV map on each receiving mesh, and each object's ``luxel`` record.
The new images and files are made beside the old ones and replace them only once everything
is written; a failure on the way (a full disk) undoes what was made, so the .blend and the
lightmap folder are left as they were."""
import os

import bpy
import numpy as np

from ..native import LuxelError, SettingsError, write_exr

UV_MAP = "LuxelLightmap"
PAGE_KEY = "luxel_page"          # ID property marking Luxel's images, with their page number


def image_name(scene, page):
    return f"Luxel {scene.name} {page}"


def lightmap_directory(scene):
    """Absolute folder for EXR output; an error before anything is written if it can't be."""
    settings = scene.luxel
    if settings.directory.startswith("//") and not bpy.data.filepath:
        raise SettingsError("the .blend is not saved, so the lightmap folder "
                            f"'{settings.directory}' has no place: save the file first, or set "
                            "Output to 'Pack into .blend'")
    directory = os.path.abspath(bpy.path.abspath(settings.directory))
    if not _writable(directory):
        raise SettingsError(f"the lightmap folder '{directory}' cannot be written: choose a "
                            "folder you may write to (Render properties > Luxel Lightmaps > "
                            "Folder, or --output), or set Output to 'Pack into .blend'")
    return directory


def write_back(scene, export, atlas, pages):
    """Store ``pages`` ((H, W, 4) arrays, row 0 at v = 0) and the atlas UVs in the .blend."""
    settings = scene.luxel
    directory = lightmap_directory(scene) if settings.output == 'FILES' else None
    for receiver in export.receivers:
        if bpy.data.objects.get(receiver.object_name) is None:
            raise SettingsError(f"object '{receiver.object_name}' vanished during the bake; "
                                "bake again")
    previous = {image.name for image in bpy.data.images if PAGE_KEY in image
                and image.name.startswith(image_name(scene, ""))}
    undo = []           # what to do, last first, to take back each change made so far
    try:
        if directory is not None:
            _make_directory(directory, undo)
        images = [_page_image(scene, index, page, directory, undo)
                  for index, page in enumerate(pages)]
        baked = _write_receivers(export, atlas, images, undo)
    except BaseException:
        for action in reversed(undo):
            action()
        raise

    # Everything is written: the new results take the old ones' place.
    for image in images:
        _replace_page(scene, image, directory)
    for obj in scene.objects:
        if obj.name not in baked and obj.luxel.uv_map:
            clear_object(obj)
    for name in previous - {image.name for image in images}:
        bpy.data.images.remove(bpy.data.images[name])
    return images


def _write_receivers(export, atlas, images, undo):
    """The lightmap UV map and ``luxel`` record of each receiver; returns their names."""
    row_of_triangle = np.full(len(export.scene.triangles), -1)
    # Back faces solved on texels of their own come after the scene's triangles: no UV map
    # shows them.
    front = atlas.triangles < len(row_of_triangle)
    row_of_triangle[atlas.triangles[front]] = np.nonzero(front)[0]
    uv = atlas.uv()
    baked = set()
    for receiver in export.receivers:
        obj = bpy.data.objects[receiver.object_name]
        rows = row_of_triangle[receiver.first_triangle:receiver.first_triangle
                               + len(receiver.loops)]
        _write_uv_map(obj.data, receiver.loops, uv[rows], undo)
        page = np.bincount(atlas.page[rows]).argmax()
        undo.append(lambda obj=obj, record=(obj.luxel.image, obj.luxel.uv_map):
                    _set_record(obj, *record))
        _set_record(obj, images[page], UV_MAP)
        baked.add(obj.name)
    return baked


def _set_record(obj, image, uv_map):
    obj.luxel.image = image
    obj.luxel.uv_map = uv_map


def clear_object(obj):
    """Remove the lightmap UV map and image reference a previous bake left on ``obj``."""
    if obj.type == 'MESH':
        layer = obj.data.uv_layers.get(obj.luxel.uv_map)
        if layer is not None:
            obj.data.uv_layers.remove(layer)
    obj.luxel.uv_map = ""
    obj.luxel.image = None


def _page_image(scene, index, page, directory, undo):
    """A new image for ``page``, beside any old one of its name (Blender suffixes it), packed
    or read from a staged EXR file; _replace_page() swaps it in."""
    name = image_name(scene, index)
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
    image[PAGE_KEY] = index
    return image


def _replace_page(scene, image, directory):
    """The new page image takes the old one's users and name, and its file the final name."""
    name = image_name(scene, image[PAGE_KEY])
    old = bpy.data.images.get(name)
    if old is not None and old != image and PAGE_KEY in old:
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


def _writable(directory):
    """A folder that exists and may be written, or that can be made."""
    existing = directory
    while not os.path.exists(existing):
        existing = os.path.dirname(existing)
    return os.path.isdir(existing) and os.access(existing, os.W_OK | os.X_OK)


def _make_directory(directory, undo):
    missing = []
    path = directory
    while not os.path.isdir(path):
        missing.append(path)
        path = os.path.dirname(path)
    os.makedirs(directory, exist_ok=True)
    for path in reversed(missing):      # undone from the deepest
        undo.append(lambda path=path: os.rmdir(path))


def _write_uv_map(mesh, loops, triangle_uv, undo):
    layers = mesh.uv_layers
    layer = layers.get(UV_MAP)
    if layer is None:
        active, active_render = layers.active_index, _active_render_index(layers)
        layer = layers.new(name=UV_MAP, do_init=False)
        undo.append(lambda: layers.remove(layers[UV_MAP]))
        # A new layer must not take over the user's active or render UV map.
        if active >= 0:
            layers.active_index = active
        if active_render >= 0:
            layers[active_render].active_render = True
    else:
        before = np.empty(len(mesh.loops) * 2, dtype=np.float32)
        layer.uv.foreach_get("vector", before)
        undo.append(lambda: _set_uvs(mesh, before))
    loop_uv = np.zeros((len(mesh.loops), 2), dtype=np.float32)
    loop_uv[loops.ravel()] = triangle_uv.reshape(-1, 2)
    _set_uvs(mesh, loop_uv.ravel())


def _set_uvs(mesh, values):
    mesh.uv_layers[UV_MAP].uv.foreach_set("vector", values)
    mesh.update()


def _active_render_index(layers):
    for index, layer in enumerate(layers):
        if layer.active_render:
            return index
    return -1
