"""Luxel's lightmaps in Blender's glTF export (File > Export > glTF 2.0, and ``--command luxel
export --gltf``), through the exporter's user-extension hooks.

While the exporter gathers nodes, each baked object's node (and each collection instancer's)
is tagged with where its lightmap lies; once the file is written, native.gltf gives the
tagged nodes their lightmap UVs (TEXCOORD_1) and MOZ_lightmap materials, and the tags go.
Blender 4.2's exporter has no hook after writing: there the command line edits the file
itself and File > Export does on the next tick of the interface."""
import os

import bpy

from ..native import LuxelError
from ..native.gltf import DefaultMaterial, Placement, add_lightmaps, read_gltf, write_gltf
from ..native.lightmap_encoding import lightmap_png
from .display import FILL_MATERIAL, set_baked_lighting
from .evaluation import RenderEvaluation
from .export import DEFAULT_ALBEDO
from .writeback import (INSTANCER_OFFSET, OBJECT_OFFSET, UV_MAP, UV_MAP_BACK,
                        image_pixels, irradiance_images)

TAG = "luxel_lightmap"      # in a node's extras while the file is being written
PANEL = "Luxel Lightmaps"


def scene_has_lightmaps(scene):
    return bool(irradiance_images(scene)) and any(OBJECT_OFFSET in obj for obj in scene.objects)


class LightmapExtension:
    """The exporter's ``glTF2ExportUserExtension`` (the root package hands it over)."""

    def __init__(self):
        self.scene = bpy.context.scene
        self.active = self.scene.luxel.gltf_lightmaps and scene_has_lightmaps(self.scene)
        self.finish_scheduled = False

    def gather_node_hook(self, gltf2_node, blender_object, export_settings):
        if not self.active or blender_object is None:
            return
        tag = _tag(blender_object, export_settings)
        if tag is None:
            return
        if not isinstance(gltf2_node.extras, dict):
            gltf2_node.extras = {}
        gltf2_node.extras[TAG] = tag
        # Blender 4.2 calls no hook after writing; finishing twice does nothing more.
        if not (self.finish_scheduled or _finishing_in_caller or bpy.app.background):
            path, scene = export_settings["gltf_filepath"], self.scene
            bpy.app.timers.register(lambda: finish_export(path, scene) and None,
                                    first_interval=0.0)
            self.finish_scheduled = True

    def post_export_hook(self, export_settings):
        if self.active and not _finishing_in_caller:
            finish_export(export_settings["gltf_filepath"], self.scene)


_finishing_in_caller = False    # export_gltf() edits the file itself
_held = []      # while an export gathers: (scene, its RenderEvaluation, whether it was shown)


def pre_export_callback(export_settings):
    """The exporter must see what the bake saw: the user's own materials (Show Baked Lighting
    puts the lightmap in them as emission) and the modifiers' render evaluation (the lightmap
    UVs fit its corners)."""
    scene = bpy.context.scene
    shown = scene.luxel.show_baked
    if shown:
        set_baked_lighting(scene, False)
    evaluation = RenderEvaluation(scene)
    evaluation.apply()
    _held.append((scene, evaluation, shown))


def post_export_callback(export_settings):
    while _held:
        scene, evaluation, shown = _held.pop()
        evaluation.restore()
        if shown:
            set_baked_lighting(scene, True)


def _tag(obj, export_settings):
    """What the written file needs to know of ``obj``'s lightmap, or None."""
    tag = {}
    if OBJECT_OFFSET in obj and obj.luxel.image is not None:
        names = _exported_uv_maps(obj, export_settings)
        if UV_MAP in names:
            tag["uv_set"] = names.index(UV_MAP)
            tag["back_uv_set"] = names.index(UV_MAP_BACK) if UV_MAP_BACK in names else None
            tag["offset"] = list(obj[OBJECT_OFFSET][:2])
        else:
            tag["missing"] = True
    if INSTANCER_OFFSET in obj:
        block = obj[INSTANCER_OFFSET]
        tag["block"] = list(block[:2])
        tag["page"] = int(round(block[2])) - 1
        tag["instancer"] = obj.instance_type == 'COLLECTION' and obj.instance_collection is not None
    if not tag:
        return None
    tag["object"] = obj.name
    return tag


def _exported_uv_maps(obj, export_settings):
    """The UV maps, in order, of the mesh the exporter writes for ``obj``: evaluated with
    Apply Modifiers (and for curves and text), else the object's own."""
    if obj.type == 'MESH' and not export_settings.get("gltf_apply"):
        return [layer.name for layer in obj.data.uv_layers]
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        return [] if mesh is None else [layer.name for layer in mesh.uv_layers]
    finally:
        evaluated.to_mesh_clear()


def finish_export(path, scene):
    """Add the lightmaps to the glTF file at ``path`` that the tagged export wrote; a file
    without tags (already done, or nothing baked) is left as it is. Returns the objects
    given a lightmap."""
    path = os.path.abspath(bpy.path.abspath(path))
    if not os.path.exists(path):
        return []
    gltf = read_gltf(path)
    nodes = gltf.document.get("nodes", [])
    tags = {index: node["extras"].pop(TAG) for index, node in enumerate(nodes)
            if isinstance(node.get("extras"), dict) and TAG in node["extras"]}
    if not tags:
        return []
    for node in nodes:
        if node.get("extras") == {}:
            del node["extras"]
    placements, missing = _placements(nodes, tags)
    if missing:
        raise LuxelError(f"the export has no lightmap UVs for {_names(missing)}: their "
                         "modifiers add them; turn on Apply Modifiers in the exporter "
                         "(Data > Mesh), or use --command luxel export")
    pages = irradiance_images(scene)
    lightmaps = [lightmap_png(image_pixels(pages[number])) for number in sorted(pages)]
    if any(placement.page >= len(lightmaps) for placement in placements):
        raise LuxelError("the lightmaps' images are missing some pages: bake again")
    add_lightmaps(gltf, placements, lightmaps,
                  DefaultMaterial(base_color=DEFAULT_ALBEDO, name=FILL_MATERIAL))
    write_gltf(gltf)
    return sorted({tags[placement.node]["object"] for placement in placements})


def _placements(nodes, tags):
    """A Placement for each tagged node with lightmap UVs: its object's offset plus the block
    of its outermost collection instancer, else its own (an object shown by itself)."""
    parent = {child: index for index, node in enumerate(nodes)
              for child in node.get("children", [])}
    placements, missing = [], []
    for index, tag in tags.items():
        if tag.get("missing"):
            missing.append(tag["object"])
        if "uv_set" not in tag:
            continue
        shown_by = tag if "block" in tag else None
        ancestor = parent.get(index)
        while ancestor is not None:
            if tags.get(ancestor, {}).get("instancer"):
                shown_by = tags[ancestor]
            ancestor = parent.get(ancestor)
        if shown_by is None:
            continue
        offset = (tag["offset"][0] + shown_by["block"][0], tag["offset"][1] + shown_by["block"][1])
        placements.append(Placement(node=index, uv_set=tag["uv_set"],
                                    back_uv_set=tag["back_uv_set"], offset=offset,
                                    page=shown_by["page"]))
    return placements, missing


def _names(objects):
    shown = ", ".join(f"'{name}'" for name in objects[:5])
    return shown + (f" and {len(objects) - 5} more" if len(objects) > 5 else "")


def export_gltf(context, path, *, selected_only=False):
    """Blender's glTF export of ``context.scene`` with its lightmaps: the objects shown and
    rendered (not those of excluded collections, which only instances show), the modifiers
    applied (as the bake saw them) and the camera; returns the objects given a lightmap."""
    global _finishing_in_caller
    scene = context.scene
    if not scene_has_lightmaps(scene):
        baked = any(OBJECT_OFFSET in obj for obj in scene.objects)
        raise LuxelError("the scene's lightmaps were baked before Luxel kept the irradiance "
                         "that glTF files hold: bake again" if baked else
                         "the scene has no Luxel lightmaps to export: bake first "
                         "(--command luxel bake)")
    path = os.path.abspath(path)
    if not path.lower().endswith((".glb", ".gltf")):
        raise LuxelError(f"'{path}': name a .glb or .gltf file")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    _finishing_in_caller = True
    try:
        bpy.ops.export_scene.gltf(
            filepath=path, export_format='GLB' if path.lower().endswith(".glb")
            else 'GLTF_SEPARATE', export_apply=True, export_cameras=True,
            export_texcoords=True, use_selection=selected_only, use_visible=True,
            use_renderable=True)
    finally:
        _finishing_in_caller = False
    return finish_export(path, scene)


def draw_export_panel(context, layout):
    """The switch in the exporter's panel (shown where the exporter draws user extensions)."""
    scene = context.scene
    header, body = layout.panel("LUXEL_gltf_export", default_closed=True)
    header.use_property_split = False
    header.prop(scene.luxel, "gltf_lightmaps", text=PANEL)
    if body is not None:
        body.active = scene.luxel.gltf_lightmaps
        if scene_has_lightmaps(scene):
            body.label(text="Lightmap UVs as TEXCOORD_1, MOZ_lightmap materials")
        else:
            body.label(text="No Luxel lightmaps in this scene: bake first", icon='INFO')


def register():
    try:
        import io_scene_gltf2
    except ImportError:
        return
    io_scene_gltf2.exporter_extension_layout_draw[PANEL] = draw_export_panel


def unregister():
    try:
        import io_scene_gltf2
    except ImportError:
        return
    io_scene_gltf2.exporter_extension_layout_draw.pop(PANEL, None)
