"""glTF export with the lightmaps (addon/gltf_export.py, native/gltf.py), read back as an
engine reads it: every baked object's primitives carry TEXCOORD_1 and a MOZ_lightmap material;
each shown copy's TEXCOORD_1 holds the same page places that Blender's materials read for it
(the UV map plus its object's and instancer's offsets); and the decoded RGBD lightmap, times
the glTF base colour over pi (three.js's lightMap), gives back the lightmap Blender shows
within 2 % on texels above 1 % of the page's maximum."""
import importlib
import json
import os

import numpy as np
import pytest

import blender_session
from test_blender_every_object import evaluated_lightmap, modelled_room, page_pixels

bpy = blender_session.blender()
addon = blender_session.addon().addon
writeback = importlib.import_module(blender_session.MODULE + ".addon.writeback")
native = importlib.import_module(blender_session.MODULE + ".native")
gltf = importlib.import_module(blender_session.MODULE + ".native.gltf")
encoding = importlib.import_module(blender_session.MODULE + ".native.lightmap_encoding")

COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
DTYPES = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8}


def accessor(document, binary, index):
    """An accessor's values, read as the glTF specification lays them out."""
    acc = document["accessors"][index]
    view = document["bufferViews"][acc["bufferView"]]
    dtype = np.dtype(DTYPES[acc["componentType"]])
    width = COMPONENTS[acc["type"]]
    stride = view.get("byteStride", dtype.itemsize * width)
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    rows = np.frombuffer(bytes(binary[start:start + stride * acc["count"]]), dtype=np.uint8)
    rows = rows.reshape(acc["count"], stride)[:, :dtype.itemsize * width]
    return np.ascontiguousarray(rows).view(dtype).reshape(acc["count"], width)


def decoded_page(document, binary, texture, intensity, folder):
    """The page a texture names, decoded from its PNG (Blender reads the PNG; row 0 at the
    top, where glTF's v is 0)."""
    image = document["images"][document["textures"][texture]["source"]]
    view = document["bufferViews"][image["bufferView"]]
    data = bytes(binary[view.get("byteOffset", 0):view.get("byteOffset", 0)
                        + view["byteLength"]])
    path = folder / f"page-{texture}.png"
    path.write_bytes(data)
    loaded = bpy.data.images.load(str(path))
    try:
        loaded.colorspace_settings.name = 'Non-Color'
        pixels = writeback.image_pixels(loaded)
    finally:
        bpy.data.images.remove(loaded)
    # Blender's rows run up from v = 0: flip to the PNG's (glTF's) order, back to bytes.
    rgbd = np.round(np.flipud(pixels) * 255.0).astype(np.uint8)
    return encoding.decode_rgbd(rgbd, intensity)


def bilinear(image, u, v):
    """``image`` (rows from v = 0) at (u, v), texel centres at (i + 0.5) / size."""
    height, width = image.shape[:2]
    x = np.clip(u * width - 0.5, 0.0, width - 1.0)
    y = np.clip(v * height - 0.5, 0.0, height - 1.0)
    x0, y0 = np.minimum(x.astype(int), width - 2), np.minimum(y.astype(int), height - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    return ((image[y0, x0] * (1 - fx) + image[y0, x0 + 1] * fx) * (1 - fy)
            + (image[y0 + 1, x0] * (1 - fx) + image[y0 + 1, x0 + 1] * fx) * fy)


@pytest.fixture(scope="module")
def exported_room(tmp_path_factory):
    scene = modelled_room()
    scene.luxel.threshold = 0.05
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    scene.luxel.show_baked = True       # the export must see the user's materials
    path = tmp_path_factory.mktemp("gltf") / "room.glb"
    assert addon.cli.execute(["export", "--gltf", str(path)]) == 0
    return scene, gltf.read_gltf(path)


def nearest(points, others):
    """Each point's distance to the nearest of ``others``."""
    return np.array([np.abs(others - point).max(axis=1).min() for point in points])


def shown_copies(document):
    """{node index: (object name, the instancer showing it)} from the node tree."""
    nodes = document["nodes"]
    parent = {child: index for index, node in enumerate(nodes)
              for child in node.get("children", [])}
    roots = set(document["scenes"][document.get("scene", 0)]["nodes"])
    copies = {}
    for index, node in enumerate(nodes):
        if "mesh" not in node:
            continue
        top = index
        while top in parent:
            top = parent[top]
        if top in roots:
            copies[index] = (node["name"], nodes[top]["name"])
    return copies


def test_each_shown_copy_carries_its_own_lightmap_place(exported_room):
    scene, file = exported_room
    document, binary = file.document, file.binary
    assert "MOZ_lightmap" in document["extensionsUsed"]
    copies = shown_copies(document)
    shown = {}
    for index, (name, instancer) in copies.items():
        obj = bpy.data.objects[name]
        for primitive in document["meshes"][document["nodes"][index]["mesh"]]["primitives"]:
            assert "TEXCOORD_1" in primitive["attributes"], name
            lightmap = document["materials"][primitive["material"]]["extensions"]["MOZ_lightmap"]
            assert lightmap["texCoord"] == 1 and lightmap["intensity"] > 0.0, name
            uv = accessor(document, binary, primitive["attributes"]["TEXCOORD_1"])
            # The places Blender's materials read for this copy (v up there, down in glTF).
            expected = (evaluated_lightmap(obj) + np.array(obj[writeback.OBJECT_OFFSET][:2])
                        + np.array((bpy.data.objects[instancer].get(writeback.INSTANCER_OFFSET)
                                    or obj[writeback.INSTANCER_OFFSET])[:2]))
            expected[:, 1] = 1.0 - expected[:, 1]
            assert nearest(uv, expected).max() < 1e-5, (name, instancer)
            assert nearest(expected, uv).max() < 1e-5, (name, instancer)
            shown[(name, instancer)] = uv
    assert {"Room", "Sofa", "Shelf", "Vase", "Chair", "ChairTwin", "Cable", "Sign"} <= \
        {name for name, _ in shown}
    stools = [uv for (name, _), uv in shown.items() if name == "Stool"]
    assert len(stools) == 3     # two instances and the nested one, each in its own place
    assert len({tuple(np.round(uv.mean(axis=0), 5)) for uv in stools}) == 3


def test_the_decoded_lightmap_times_base_colour_is_what_blender_shows(exported_room,
                                                                       tmp_path):
    """At four random points of every triangle of every shown copy. Luxel's lightmap is its
    per-texel albedo (Cycles' bake of the material) times the irradiance, the glTF's the
    irradiance times the base colour: on texels that a surface covers in part Cycles' bake of
    the grey 0.6 can read lower (0.5 by the page's edge here; the text's letters, a few texels
    each, have many), so the bounds are on each copy's median (0.5 %) and 90 % of its points
    (2 %)."""
    scene, file = exported_room
    document, binary = file.document, file.binary
    rng = np.random.default_rng(5)
    checked = 0
    for index in shown_copies(document):
        mesh = document["meshes"][document["nodes"][index]["mesh"]]
        for primitive in mesh["primitives"]:
            material = document["materials"][primitive["material"]]
            lightmap = material["extensions"]["MOZ_lightmap"]
            base = np.array(material["pbrMetallicRoughness"]["baseColorFactor"][:3])
            irradiance = decoded_page(document, binary, lightmap["index"], lightmap["intensity"],
                                      tmp_path)
            image = document["textures"][lightmap["index"]]["source"]
            page = int(document["images"][image]["name"].rsplit(" ", 1)[1])
            shown = page_pixels(scene, page)[..., :3]
            uv = accessor(document, binary, primitive["attributes"]["TEXCOORD_1"])
            triangles = np.repeat(accessor(document, binary, primitive["indices"])
                                  .reshape(-1, 3), 4, axis=0)
            weights = rng.dirichlet((2.0, 2.0, 2.0), size=len(triangles))
            points = np.einsum("tk,tkc->tc", weights, uv[triangles])
            glb = bilinear(np.flipud(irradiance), points[:, 0], 1.0 - points[:, 1]) * base / np.pi
            blender = bilinear(shown, points[:, 0], 1.0 - points[:, 1])
            lit = blender.max(axis=1) > 0.01 * shown.max()
            assert lit.any()
            error = np.abs(glb[lit] - blender[lit]).max(axis=1) / blender[lit].max(axis=1)
            assert np.median(error) < 0.005, document["nodes"][index]["name"]
            assert np.percentile(error, 90) < 0.02, document["nodes"][index]["name"]
            checked += len(error)
    assert checked > 1000


def test_the_export_leaves_no_tags_and_the_scene_as_it_was(exported_room):
    scene, file = exported_room
    assert "luxel_lightmap" not in json.dumps(file.document)
    # Rewritten as a plain open() would have written it (not private to its writer).
    umask = os.umask(0)
    os.umask(umask)
    assert file.path.stat().st_mode & 0o777 == 0o666 & ~umask
    assert scene.luxel.show_baked      # shown again after the export
    assert all(material.name != "Luxel Lightmap" for material in bpy.data.materials
               if not material.users)


def test_blenders_own_export_carries_the_lightmaps_unless_switched_off(exported_room,
                                                                       tmp_path):
    """File > Export > glTF 2.0 (the operator, with Apply Modifiers as the panel says): the
    hooks add the lightmaps; the exporter panel's switch, off, leaves Blender's own file."""
    import io_scene_gltf2
    scene, _ = exported_room
    assert "Luxel Lightmaps" in io_scene_gltf2.exporter_extension_layout_draw
    for switch in (True, False):
        scene.luxel.gltf_lightmaps = switch
        path = tmp_path / f"{switch}.glb"
        bpy.ops.export_scene.gltf(filepath=str(path), export_format='GLB', export_apply=True)
        document = gltf.read_gltf(path).document
        text = json.dumps(document)
        assert ("MOZ_lightmap" in text) == switch and "luxel_lightmap" not in text
        if switch:
            assert all("TEXCOORD_1" in primitive["attributes"]
                       for mesh in document["meshes"] for primitive in mesh["primitives"])
    scene.luxel.gltf_lightmaps = True


def test_an_export_without_lightmaps_says_what_to_do(tmp_path, capsys):
    """No bake: "bake first"; a bake from before the irradiance was kept: "bake again"; no
    file is written either way."""
    import blender_scenes
    blender_session.empty_file()
    path = tmp_path / "scene.glb"
    assert addon.cli.execute(["export", "--gltf", str(path)]) == 1
    assert "bake first" in capsys.readouterr().err and not path.exists()
    scene = blender_scenes.point_scene()
    scene.luxel.texel_density, scene.luxel.threshold = 4.0, 0.05
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    for image in writeback.irradiance_images(scene).values():
        bpy.data.images.remove(image)
    capsys.readouterr()
    assert addon.cli.execute(["export", "--gltf", str(path)]) == 1
    assert "bake again" in capsys.readouterr().err and not path.exists()
