"""Lightmaps into glTF files that Blender's exporter wrote: each baked node's primitives get
the lightmap UVs as TEXCOORD_1 and their materials the MOZ_lightmap extension (the convention
of Mozilla Hubs and three.js's loader plugins) naming an RGBD page (lightmap_encoding).

The file is edited as JSON and one binary buffer, whatever the exporter's version: a node
that shows the lightmap where the mesh's other users show another region gets a mesh (and
materials) of its own; meshes and materials no node uses any more are dropped."""
import base64
import copy
from dataclasses import dataclass
import json
import os
from pathlib import Path
import struct

import numpy as np

from .errors import LuxelError
from .lightmap_encoding import ENCODING
from .output import write_bytes

EXTENSION = "MOZ_lightmap"
LIGHTMAP_SET = 1            # TEXCOORD_1, the lightmap UVs' set
FLOAT = 5126
LINEAR = 9729
CLAMP_TO_EDGE = 33071
GLB_MAGIC, JSON_CHUNK, BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942
# Compressed or quantized attributes cannot be rewritten here.
UNEDITABLE = ("KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_mesh_quantization")


@dataclass(frozen=True)
class Placement:
    """Where node ``node``'s lightmap lies: the TEXCOORD set the exporter wrote its lightmap
    UVs into (``back_uv_set``: that of the back faces' map, dropped, or None), the offset to
    add to them (Blender's UVs: v up) and the page."""
    node: int
    uv_set: int
    back_uv_set: int | None
    offset: tuple[float, float]
    page: int


@dataclass(frozen=True)
class DefaultMaterial:
    """What a primitive without a material is lit as (Blender's default grey, not glTF's
    metallic white)."""
    base_color: tuple[float, float, float]
    name: str


@dataclass
class GltfFile:
    """A glTF document and its one binary buffer; ``path`` and ``binary_path`` where they
    are read from and written to (the same file for a GLB)."""
    document: dict
    binary: bytearray
    path: Path
    binary_path: Path | None = None

    @property
    def is_glb(self):
        return self.path.suffix.lower() == ".glb"


def read_gltf(path):
    """A .glb or .gltf file (its buffer embedded or a file beside it) as a GltfFile."""
    path = Path(path)
    data = path.read_bytes()
    if path.suffix.lower() == ".glb":
        magic, _, _ = struct.unpack_from("<III", data, 0)
        if magic != GLB_MAGIC:
            raise LuxelError(f"'{path}' is not a GLB file")
        offset, document, binary = 12, None, bytearray()
        while offset < len(data):
            length, kind = struct.unpack_from("<II", data, offset)
            chunk = data[offset + 8:offset + 8 + length]
            if kind == JSON_CHUNK:
                document = json.loads(chunk)
            elif kind == BIN_CHUNK:
                binary = bytearray(chunk)
            offset += 8 + length
        return GltfFile(document, binary, path)
    document = json.loads(data)
    buffers = document.get("buffers", [])
    if len(buffers) > 1:
        raise LuxelError(f"'{path}' has {len(buffers)} buffers; export it again as one GLB")
    if not buffers:
        return GltfFile(document, bytearray(), path, path.with_suffix(".bin"))
    uri = buffers[0].get("uri", "")
    if uri.startswith("data:"):
        return GltfFile(document, bytearray(base64.b64decode(uri.split(",", 1)[1])), path)
    binary_path = path.parent / uri
    return GltfFile(document, bytearray(binary_path.read_bytes()), path, binary_path)


def write_gltf(gltf):
    """Write ``gltf`` back where it was read from, each file whole or not at all."""
    document = gltf.document
    if gltf.binary:
        buffer = {"byteLength": len(gltf.binary)}
        if not gltf.is_glb:
            if gltf.binary_path is None:
                buffer["uri"] = ("data:application/octet-stream;base64,"
                                 + base64.b64encode(bytes(gltf.binary)).decode("ascii"))
            else:
                buffer["uri"] = os.path.relpath(gltf.binary_path, gltf.path.parent)
                write_bytes(gltf.binary_path, bytes(gltf.binary))
        document["buffers"] = [buffer]
    text = json.dumps(document, separators=(",", ":")).encode()
    if not gltf.is_glb:
        write_bytes(gltf.path, text)
        return
    text += b" " * (-len(text) % 4)
    binary = bytes(gltf.binary) + b"\0" * (-len(gltf.binary) % 4)
    chunks = struct.pack("<II", len(text), JSON_CHUNK) + text
    if binary:
        chunks += struct.pack("<II", len(binary), BIN_CHUNK) + binary
    write_bytes(gltf.path, struct.pack("<III", GLB_MAGIC, 2, 12 + len(chunks)) + chunks)


def add_lightmaps(gltf, placements, lightmaps, default_material):
    """Give each placed node its lightmap: ``lightmaps`` are the pages' EncodedLightmaps."""
    document = gltf.document
    used = set(document.get("extensionsUsed", []))
    blocked = used.intersection(UNEDITABLE)
    if blocked:
        raise LuxelError(f"the glTF file uses {', '.join(sorted(blocked))}, whose attributes "
                         "Luxel cannot add lightmap UVs to: export without compression, and "
                         "compress the file after")
    editor = _Editor(gltf, default_material)
    textures = [editor.texture(page, lightmap) for page, lightmap in enumerate(lightmaps)]
    for placement in placements:
        node = document["nodes"][placement.node]
        if "mesh" in node:
            node["mesh"] = editor.placed_mesh(node["mesh"], placement,
                                              textures[placement.page],
                                              lightmaps[placement.page].intensity)
    _drop_unused(document)
    document["extensionsUsed"] = sorted(used | {EXTENSION})


class _Editor:
    """Appends to the document and its buffer; one placed mesh per mesh and placement, one
    material per material, page and order of texture sets."""

    def __init__(self, gltf, default_material):
        self.gltf, self.document = gltf, gltf.document
        self.default_material = default_material
        self.meshes, self.materials = {}, {}

    def _append(self, kind, item):
        items = self.document.setdefault(kind, [])
        items.append(item)
        return len(items) - 1

    def _buffer_view(self, data, target=None):
        binary = self.gltf.binary
        binary.extend(b"\0" * (-len(binary) % 4))
        view = {"buffer": 0, "byteOffset": len(binary), "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        binary.extend(data)
        return self._append("bufferViews", view)

    def texture(self, page, lightmap):
        image = self._append("images", {"bufferView": self._buffer_view(lightmap.png),
                                        "mimeType": "image/png",
                                        "name": f"Luxel lightmap {page}"})
        sampler = self._append("samplers", {"magFilter": LINEAR, "minFilter": LINEAR,
                                            "wrapS": CLAMP_TO_EDGE, "wrapT": CLAMP_TO_EDGE})
        return self._append("textures", {"sampler": sampler, "source": image})

    def _read_uvs(self, accessor_index):
        accessor = self.document["accessors"][accessor_index]
        if accessor.get("componentType") != FLOAT or accessor.get("type") != "VEC2" \
                or "sparse" in accessor:
            raise LuxelError("the lightmap UVs were written as quantized or sparse values: "
                             "export without quantization")
        view = self.document["bufferViews"][accessor["bufferView"]]
        stride = view.get("byteStride", 8)
        start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
        count = accessor["count"]
        raw = np.frombuffer(bytes(self.gltf.binary[start:start + stride * count]),
                            dtype=np.uint8).reshape(count, stride)[:, :8]
        return np.ascontiguousarray(raw).view(np.float32).reshape(count, 2)

    def _uv_accessor(self, uv):
        uv = np.ascontiguousarray(uv, dtype=np.float32)
        view = self._buffer_view(uv.tobytes(), target=34962)
        return self._append("accessors", {
            "bufferView": view, "componentType": FLOAT, "count": len(uv), "type": "VEC2",
            "min": uv.min(axis=0).tolist() if len(uv) else [0.0, 0.0],
            "max": uv.max(axis=0).tolist() if len(uv) else [0.0, 0.0]})

    def placed_mesh(self, mesh_index, placement, texture, intensity):
        key = (mesh_index, placement.uv_set, placement.back_uv_set, placement.offset,
               placement.page)
        if key in self.meshes:
            return self.meshes[key]
        mesh = copy.deepcopy(self.document["meshes"][mesh_index])
        for primitive in mesh["primitives"]:
            self._place_primitive(primitive, placement, texture, intensity)
        self.meshes[key] = self._append("meshes", mesh)
        return self.meshes[key]

    def _place_primitive(self, primitive, placement, texture, intensity):
        attributes = primitive["attributes"]
        lightmap_name = f"TEXCOORD_{placement.uv_set}"
        if lightmap_name not in attributes:
            raise LuxelError(f"the exporter wrote no {lightmap_name} for the lightmap UVs: "
                             "turn on the exporter's UVs (Data > Mesh)")
        # glTF's v runs down the image: v_gltf = 1 - v_blender.
        uv = self._read_uvs(attributes[lightmap_name]) + np.array(
            [placement.offset[0], -placement.offset[1]], dtype=np.float32)
        sets = sorted(int(name[9:]) for name in attributes if name.startswith("TEXCOORD_"))
        own = [index for index in sets if index not in (placement.uv_set,
                                                        placement.back_uv_set)]
        # The user's first set stays TEXCOORD_0, the lightmap takes TEXCOORD_1, the others
        # follow; materials' texCoord follow their sets.
        renumbered = {old: (new if new == 0 else new + 1) for new, old in enumerate(own)}
        moved = {name: attributes.pop(name) for name in list(attributes)
                 if name.startswith("TEXCOORD_")}
        for old, new in renumbered.items():
            attributes[f"TEXCOORD_{new}"] = moved[f"TEXCOORD_{old}"]
        lightmap = self._uv_accessor(uv)
        attributes[f"TEXCOORD_{LIGHTMAP_SET}"] = lightmap
        if not own:     # sets must start at 0: what Blender renders without a UV map
            attributes["TEXCOORD_0"] = self._uv_accessor(np.zeros_like(uv))
        primitive["material"] = self._material(primitive.get("material"), renumbered,
                                               texture, intensity)

    def _material(self, index, renumbered, texture, intensity):
        moved = tuple(sorted((old, new) for old, new in renumbered.items() if old != new))
        key = (index, moved, texture)
        if key not in self.materials:
            if index is None:
                material = {"name": self.default_material.name, "pbrMetallicRoughness": {
                    "baseColorFactor": [*self.default_material.base_color, 1.0],
                    "metallicFactor": 0.0, "roughnessFactor": 0.5}}
            else:
                material = copy.deepcopy(self.document["materials"][index])
                _renumber_tex_coords(material, dict(moved))
            material.setdefault("extensions", {})[EXTENSION] = {
                "index": texture, "texCoord": LIGHTMAP_SET, "intensity": intensity,
                "extras": {"encoding": ENCODING}}
            self.materials[key] = self._append("materials", material)
        return self.materials[key]


def _renumber_tex_coords(value, renumbered):
    if isinstance(value, dict):
        if isinstance(value.get("texCoord"), int):
            value["texCoord"] = renumbered.get(value["texCoord"], value["texCoord"])
        for item in value.values():
            _renumber_tex_coords(item, renumbered)
    elif isinstance(value, list):
        for item in value:
            _renumber_tex_coords(item, renumbered)


def _drop_unused(document):
    """Drop the meshes no node uses and the materials no mesh uses (unless variants name
    them), renumbering what refers to them."""
    nodes = document.get("nodes", [])
    kept_meshes = sorted({node["mesh"] for node in nodes if "mesh" in node})
    mesh_number = {old: new for new, old in enumerate(kept_meshes)}
    document["meshes"] = [document["meshes"][old] for old in kept_meshes]
    for node in nodes:
        if "mesh" in node:
            node["mesh"] = mesh_number[node["mesh"]]
    if "KHR_materials_variants" in document.get("extensionsUsed", []):
        return
    primitives = [primitive for mesh in document["meshes"] for primitive in mesh["primitives"]]
    kept_materials = sorted({p["material"] for p in primitives if "material" in p})
    material_number = {old: new for new, old in enumerate(kept_materials)}
    if "materials" in document:
        document["materials"] = [document["materials"][old] for old in kept_materials]
    for primitive in primitives:
        if "material" in primitive:
            primitive["material"] = material_number[primitive["material"]]
