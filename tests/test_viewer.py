"""The browser viewer (viewer/, written out by native.viewer) against a GLB built here by hand:
three quads lit only by one RGBD lightmap page, seen from a glTF camera. Each pixel's linear
radiance must be the page's irradiance at that pixel's lightmap UV times baseColor / pi, the
truth worked out here by casting the pixel's ray at the quads, and each pixel must name the
glTF node it shows. Needs /usr/bin/chromium (make chromium) and three.js (make viewer)."""
import json
import math
from pathlib import Path
import re
import struct
import urllib.request

import numpy as np
import pytest

from browser import render_viewer
from native import viewer
from native.lightmap_encoding import ENCODING, lightmap_png

WIDTH, HEIGHT = 192, 128
TAN_HALF_FOV = 0.5
CAMERA_POSITION = np.array([0.1, -0.05, 0.5])
CAMERA_TURN = math.radians(4.0)             # about +y, to the left
PAGE = 64                                   # texels a side; four 32-texel regions
REGION = 0.5
MARGIN = 2.0 / PAGE                         # each quad's UVs stay two texels inside its region
SPAN = REGION - 2.0 * MARGIN
FLOAT, UNSIGNED_SHORT = 5126, 5123
LINEAR, CLAMP_TO_EDGE = 9729, 33071


def gradient_wall(a, b):
    return (1.0 + 6.0 * a + 3.0 * b)[..., None] * np.array([1.0, 0.9, 0.8])


def gradient_panel(a, b):
    return (2.0 + 4.0 * a)[..., None] * np.array([1.0, 0.6, 0.3])


def dark(a, b):
    """A hundredth of the page's brightest texel (10): the RGBD divisor's decade."""
    return np.broadcast_to(np.array([0.1, 0.08, 0.06]), np.shape(a) + (3,))


def coloured(a, b):
    return np.broadcast_to(np.array([5.0, 3.0, 1.5]), np.shape(a) + (3,))


# Quads: corner, edge along a, edge along b (a x b faces the camera). Each primitive covers
# b from b0 to b1 of its quad and maps (a, its own b rescaled to [0, 1]) into one region of the
# page, region (i, j) starting at u = i / 2, v = j / 2 (Blender's v, up the image).
QUADS = {
    "Wall.001": dict(corner=(-1.35, -0.75, -2.0), a=(0.8, 0.0, 0.0), b=(0.0, 1.5, 0.0),
                     primitives=[dict(b0=0.0, b1=1.0, region=(0, 0), light=gradient_wall,
                                      base_color=(0.8, 0.8, 0.8))]),
    # Turned away from the camera, so the gradient's pixels test perspective-correct UVs.
    "Panel": dict(corner=(-0.4, -0.7, -2.0), a=(0.8, 0.0, -0.5), b=(0.0, 1.4, 0.0),
                  primitives=[dict(b0=0.0, b1=1.0, region=(1, 0), light=gradient_panel,
                                   base_color=(0.2, 0.6, 0.9))]),
    # Two primitives under one node: GLTFLoader makes a Group of two Meshes.
    "Shelf [2]:x": dict(corner=(0.55, -0.75, -2.0), a=(0.8, 0.0, 0.0), b=(0.0, 1.5, 0.0),
                        primitives=[dict(b0=0.0, b1=0.5, region=(0, 1), light=dark,
                                         base_color=(0.5, 0.5, 0.5)),
                                    dict(b0=0.5, b1=1.0, region=(1, 1), light=coloured,
                                         base_color=(0.9, 0.3, 0.3))]),
}
PRIMITIVES = [(name, primitive) for name, quad in QUADS.items() for primitive in quad["primitives"]]


def lightmap_page():
    """The page, row 0 at v = 0: each region's light at its texel centres, the quads' local
    coordinates extended into the margins so that bilinear filtering inside a quad reads the
    same linear function."""
    centres = (np.arange(PAGE) + 0.5) / PAGE
    u, v = np.meshgrid(centres, centres)
    page = np.zeros((PAGE, PAGE, 3))
    for _, primitive in PRIMITIVES:
        i, j = primitive["region"]
        inside = (u // REGION == i) & (v // REGION == j)
        a = (u[inside] - i * REGION - MARGIN) / SPAN
        b = (v[inside] - j * REGION - MARGIN) / SPAN
        page[inside] = primitive["light"](a, b)
    return page


def camera_rotation():
    c, s = math.cos(CAMERA_TURN), math.sin(CAMERA_TURN)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


class GlbWriter:
    """A glTF document and its binary chunk, built up accessor by accessor."""

    def __init__(self):
        self.binary = bytearray()
        self.document = {"asset": {"version": "2.0"}, "buffers": [{}], "bufferViews": [],
                         "accessors": []}

    def view(self, data, target=None):
        self.binary += b"\0" * (-len(self.binary) % 4)
        view = {"buffer": 0, "byteOffset": len(self.binary), "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self.binary += data
        self.document["bufferViews"].append(view)
        return len(self.document["bufferViews"]) - 1

    def accessor(self, array, kind, bounds=False):
        indices = kind == "SCALAR"
        array = np.ascontiguousarray(array, dtype=np.uint16 if indices else np.float32)
        accessor = {"bufferView": self.view(array.tobytes(), 34963 if indices else 34962),
                    "componentType": UNSIGNED_SHORT if indices else FLOAT,
                    "count": len(array), "type": kind}
        if bounds:
            accessor["min"] = array.min(axis=0).tolist()
            accessor["max"] = array.max(axis=0).tolist()
        self.document["accessors"].append(accessor)
        return len(self.document["accessors"]) - 1

    def glb(self):
        self.binary += b"\0" * (-len(self.binary) % 4)
        self.document["buffers"][0]["byteLength"] = len(self.binary)
        text = json.dumps(self.document).encode()
        text += b" " * (-len(text) % 4)
        chunks = (struct.pack("<I4s", len(text), b"JSON") + text
                  + struct.pack("<I4s", len(self.binary), b"BIN\0") + bytes(self.binary))
        return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


def scene_glb():
    writer = GlbWriter()
    encoded = lightmap_png(lightmap_page())
    document = writer.document
    document.update(
        extensionsUsed=["MOZ_lightmap"],
        images=[{"bufferView": writer.view(encoded.png), "mimeType": "image/png"}],
        samplers=[{"magFilter": LINEAR, "minFilter": LINEAR,
                   "wrapS": CLAMP_TO_EDGE, "wrapT": CLAMP_TO_EDGE}],
        textures=[{"sampler": 0, "source": 0}],
        materials=[], meshes=[],
        cameras=[{"type": "perspective", "perspective": {
            "yfov": 2.0 * math.atan(TAN_HALF_FOV), "aspectRatio": WIDTH / HEIGHT,
            "znear": 0.1, "zfar": 100.0}}])
    turn = CAMERA_TURN / 2.0
    nodes = [{"name": "Camera", "camera": 0, "translation": CAMERA_POSITION.tolist(),
              "rotation": [0.0, math.sin(turn), 0.0, math.cos(turn)]}]
    for name, quad in QUADS.items():
        a, b = np.array(quad["a"]), np.array(quad["b"])
        primitives = []
        for primitive in quad["primitives"]:
            corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
            quad_b = primitive["b0"] + corners[:, 1] * (primitive["b1"] - primitive["b0"])
            positions = corners[:, :1] * a + quad_b[:, None] * b
            i, j = primitive["region"]
            u = i * REGION + MARGIN + corners[:, 0] * SPAN
            v = j * REGION + MARGIN + corners[:, 1] * SPAN
            document["materials"].append({
                "pbrMetallicRoughness": {"baseColorFactor": [*primitive["base_color"], 1.0],
                                         "metallicFactor": 0.0, "roughnessFactor": 0.5},
                "extensions": {"MOZ_lightmap": {"index": 0, "texCoord": 1,
                                                "intensity": encoded.intensity,
                                                "extras": {"encoding": ENCODING}}}})
            normal = np.cross(a, b) / np.linalg.norm(np.cross(a, b))
            primitives.append({
                "attributes": {
                    "POSITION": writer.accessor(positions, "VEC3", bounds=True),
                    "NORMAL": writer.accessor(np.tile(normal, (4, 1)), "VEC3"),
                    # glTF's v runs down the image: 1 - Blender's v.
                    "TEXCOORD_1": writer.accessor(np.stack([u, 1.0 - v], axis=1), "VEC2")},
                "indices": writer.accessor(np.array([0, 1, 2, 0, 2, 3]), "SCALAR"),
                "material": len(document["materials"]) - 1})
        document["meshes"].append({"primitives": primitives})
        nodes.append({"name": name, "mesh": len(document["meshes"]) - 1,
                      "translation": list(quad["corner"])})
    document.update(nodes=nodes, scenes=[{"nodes": list(range(len(nodes)))}], scene=0)
    return writer.glb()


def expected_view():
    """Per pixel, by casting its ray: the quad it shows (-1: none), the primitive (index in
    PRIMITIVES, -1: none), the radiance there, and whether it is well inside its primitive
    (clear of the edges a pixel could straddle)."""
    rows, columns = np.mgrid[0:HEIGHT, 0:WIDTH] + 0.5
    x = (2.0 * columns / WIDTH - 1.0) * TAN_HALF_FOV * WIDTH / HEIGHT
    y = (1.0 - 2.0 * rows / HEIGHT) * TAN_HALF_FOV
    directions = np.stack([x, y, -np.ones_like(x)], axis=-1) @ camera_rotation().T
    quad_ids = np.full((HEIGHT, WIDTH), -1)
    nearest = np.full((HEIGHT, WIDTH), np.inf)
    quad_coordinates = {}
    for quad_id, (name, quad) in enumerate(QUADS.items()):
        # origin + t d = corner + a A + b B, solved for (t, a, b) at every pixel.
        matrix = np.stack([directions, np.broadcast_to(np.negative(quad["a"]), directions.shape),
                           np.broadcast_to(np.negative(quad["b"]), directions.shape)], axis=-1)
        offset = np.broadcast_to(np.array(quad["corner"]) - CAMERA_POSITION, directions.shape)
        t, a, b = np.moveaxis(np.linalg.solve(matrix, offset[..., None])[..., 0], -1, 0)
        hit = (t > 0) & (a >= 0) & (a <= 1) & (b >= 0) & (b <= 1) & (t < nearest)
        nearest[hit] = t[hit]
        quad_ids[hit] = quad_id
        quad_coordinates[name] = a, b

    primitive_ids = np.full((HEIGHT, WIDTH), -1)
    radiance = np.zeros((HEIGHT, WIDTH, 3))
    clear = np.zeros((HEIGHT, WIDTH), dtype=bool)
    for index, (name, primitive) in enumerate(PRIMITIVES):
        a, b = quad_coordinates[name]
        b0, b1 = primitive["b0"], primitive["b1"]
        on = (quad_ids == list(QUADS).index(name)) & (b >= b0) & (b <= b1)
        local_b = (b[on] - b0) / (b1 - b0)
        primitive_ids[on] = index
        radiance[on] = primitive["light"](a[on], local_b) * primitive["base_color"] / np.pi
        clear[on] = (a[on] > 0.02) & (a[on] < 0.98) & (local_b > 0.02) & (local_b < 0.98)
    return quad_ids, primitive_ids, radiance, clear


@pytest.fixture(scope="module")
def served_viewer(tmp_path_factory):
    folder = tmp_path_factory.mktemp("viewer")
    glb = folder / "baked.glb"
    glb.write_bytes(scene_glb())
    viewer.write_viewer(glb, folder / "site")
    return folder / "site"


def assert_shows_lightmap(measured):
    """A browser.Measurement of scene_glb's camera view against expected_view: each pixel on
    the node it shows, each primitive's radiance on the whole and pixel by pixel."""
    quad_ids, primitive_ids, radiance, clear = expected_view()
    assert measured.rgb.shape == (HEIGHT, WIDTH, 3)
    assert sorted(measured.names) == sorted(QUADS)

    names = list(QUADS)
    shown = np.array([names.index(name) for name in measured.names] + [-1])[measured.ids]
    assert np.mean(shown == quad_ids) > 0.99, "pixels on the wrong object"
    assert np.all(shown[clear] == quad_ids[clear])
    background = quad_ids == -1
    for axis in (0, 1):
        for shift in (-1, 1):
            background &= np.roll(quad_ids, shift, axis=axis) == -1
    assert np.all(measured.ids[background] == -1), "background pixels on an object"

    for index, (name, primitive) in enumerate(PRIMITIVES):
        pixels = clear & (primitive_ids == index)
        measured_pixels, truth = measured.rgb[pixels], radiance[pixels]
        assert len(truth) > 200, name
        mean_error = np.abs(measured_pixels.mean(axis=0) / truth.mean(axis=0) - 1.0)
        assert np.all(mean_error < 0.01), (name, primitive["light"].__name__, mean_error)
        # The plugins decode the four texels around a point before weighting them: filtering
        # the bytes was 3.7 % off at worst on the gradient, across divisor changes.
        within = np.all(np.abs(measured_pixels / truth - 1.0) < 0.015, axis=-1)
        assert within.mean() >= 0.99, (name, primitive["light"].__name__, within.mean())


def test_viewer_shows_irradiance_times_albedo_over_pi(served_viewer):
    assert_shows_lightmap(render_viewer(served_viewer, WIDTH, HEIGHT))


def test_written_viewer_is_self_contained(served_viewer):
    """Nothing is fetched from the internet, and every file the page imports is there."""
    for name in viewer.PAGE_FILES:
        text = (served_viewer / name).read_text()
        assert not re.search(r"https?://", text), name
    import_map = json.loads(re.search(r'<script type="importmap">(.*?)</script>',
                                      (served_viewer / "index.html").read_text(), re.S).group(1))
    specifiers = list(import_map["imports"].values())
    assert all(target.startswith("./") for target in specifiers)

    # Every module reachable from viewer.js, by its relative imports and the import map.
    pending, seen = ["viewer.js"], set()
    while pending:
        path = pending.pop()
        if path in seen:
            continue
        seen.add(path)
        source = (served_viewer / path).read_text()
        for specifier in re.findall(r"""^\s*(?:import|export)\b[^'"]*?from\s*['"]([^'"]+)['"]""",
                                    source, re.M):
            if specifier == "three":
                target = import_map["imports"]["three"]
            elif specifier.startswith("three/addons/"):
                target = import_map["imports"]["three/addons/"] + specifier[len("three/addons/"):]
            else:
                assert specifier.startswith("."), (path, specifier)
                target = str(Path(path).parent / specifier)
            resolved = (served_viewer / target).resolve().relative_to(served_viewer.resolve())
            pending.append(str(resolved))
    assert {"viewer.js", "moz_lightmap.js", "three/build/three.core.js",
            "three/examples/jsm/loaders/GLTFLoader.js"} <= seen

    server = viewer.serve(served_viewer)
    try:
        for path in sorted(seen | {"index.html", "scene.glb"}):
            with urllib.request.urlopen(server.url + path, timeout=10) as response:
                assert response.read() == (served_viewer / path).read_bytes(), path
                if path.endswith(".js"):
                    assert response.headers["Content-Type"] == "text/javascript", path
    finally:
        server.shutdown()
        server.server_close()


def test_write_viewer_without_three_names_the_fix(tmp_path, monkeypatch):
    monkeypatch.setattr(viewer, "THREE", tmp_path / "node_modules" / "three")
    with pytest.raises(viewer.ViewerNotInstalledError, match="make viewer"):
        viewer.write_viewer(tmp_path / "scene.glb", tmp_path / "site")
