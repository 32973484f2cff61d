"""Bake results into the .blend: one float image per atlas page (packed, or EXR files next to
the .blend), a lightmap UV map on each receiving mesh, and each object's ``luxel`` record.
Everything is checked before the first change, so a failure leaves the file as it was."""
import os

import bpy
import numpy as np

from ..native import SettingsError, write_exr

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
    return bpy.path.abspath(settings.directory)


def write_back(scene, export, atlas, pages):
    """Store ``pages`` ((H, W, 4) arrays, row 0 at v = 0) and the atlas UVs in the .blend."""
    settings = scene.luxel
    directory = lightmap_directory(scene) if settings.output == 'FILES' else None
    for receiver in export.receivers:
        if bpy.data.objects.get(receiver.object_name) is None:
            raise SettingsError(f"object '{receiver.object_name}' vanished during the bake; "
                                "bake again")
    if directory is not None:
        os.makedirs(directory, exist_ok=True)

    previous = {image.name for image in bpy.data.images if PAGE_KEY in image
                and image.name.startswith(image_name(scene, ""))}
    images = [_page_image(scene, index, page, directory) for index, page in enumerate(pages)]

    row_of_triangle = np.full(len(export.scene.triangles), -1)
    row_of_triangle[atlas.triangles] = np.arange(len(atlas.triangles))
    uv = atlas.uv()
    baked = set()
    for receiver in export.receivers:
        obj = bpy.data.objects[receiver.object_name]
        rows = row_of_triangle[receiver.first_triangle:receiver.first_triangle
                               + len(receiver.loops)]
        _write_uv_map(obj.data, receiver.loops, uv[rows])
        page = np.bincount(atlas.page[rows]).argmax()
        obj.luxel.image = images[page]
        obj.luxel.uv_map = UV_MAP
        baked.add(obj.name)

    for obj in scene.objects:
        if obj.name not in baked and obj.luxel.uv_map:
            clear_object(obj)
    for name in previous - {image.name for image in images}:
        bpy.data.images.remove(bpy.data.images[name])
    return images


def clear_object(obj):
    """Remove the lightmap UV map and image reference a previous bake left on ``obj``."""
    if obj.type == 'MESH':
        layer = obj.data.uv_layers.get(obj.luxel.uv_map)
        if layer is not None:
            obj.data.uv_layers.remove(layer)
    obj.luxel.uv_map = ""
    obj.luxel.image = None


def _page_image(scene, index, page, directory):
    name = image_name(scene, index)
    height, width = page.shape[:2]
    pixels = np.ascontiguousarray(page, dtype=np.float32).copy()
    # Opaque everywhere: Blender premultiplies packed float images by alpha, which would wipe
    # the dilated gutter that bilinear filtering reads at chart edges.
    pixels[..., 3] = 1.0
    image = bpy.data.images.get(name)
    if image is not None and (tuple(image.size) != (width, height) or not image.is_float):
        bpy.data.images.remove(image)
        image = None
    if directory is not None:
        path = os.path.join(directory, bpy.path.clean_name(name) + ".exr")
        write_exr(path, pixels)
        if image is None:
            image = bpy.data.images.load(path)
            image.name = name
        else:
            if image.packed_file is not None:
                image.unpack(method='REMOVE')
            image.source = 'FILE'
            image.filepath = path
            image.reload()
        if bpy.data.filepath:
            image.filepath = bpy.path.relpath(path)
    else:
        if image is None:
            image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
        image.pixels.foreach_set(pixels.ravel())
        image.file_format = 'OPEN_EXR'
        image.pack()
    image.colorspace_settings.name = 'Linear Rec.709'
    image[PAGE_KEY] = index
    return image


def _write_uv_map(mesh, loops, triangle_uv):
    layers = mesh.uv_layers
    layer = layers.get(UV_MAP)
    if layer is None:
        active, active_render = layers.active_index, _active_render_index(layers)
        layer = layers.new(name=UV_MAP, do_init=False)
        # A new layer must not take over the user's active or render UV map.
        if active >= 0:
            layers.active_index = active
        if active_render >= 0:
            layers[active_render].active_render = True
    loop_uv = np.zeros((len(mesh.loops), 2), dtype=np.float32)
    loop_uv[loops.ravel()] = triangle_uv.reshape(-1, 2)
    layer.uv.foreach_set("vector", loop_uv.ravel())
    mesh.update()


def _active_render_index(layers):
    for index, layer in enumerate(layers):
        if layer.active_render:
            return index
    return -1
