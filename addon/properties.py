"""Luxel's settings and results, saved in the .blend: ``scene.luxel`` and ``object.luxel``."""
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty,
                       IntVectorProperty, PointerProperty, StringProperty)

from ..native.settings import EXPOSED_SETTINGS, Settings
from .compare import CompareOptions

OUTPUTS = [
    ("PACK", "Pack into .blend", "Lightmaps are packed into the .blend file as EXR"),
    ("FILES", "EXR files", "Lightmaps are written as EXR files to a folder next to the .blend"),
]


def _show_baked_changed(settings, context):
    from . import display
    display.set_baked_lighting(context.scene, settings.show_baked)


class LuxelBakeStats(bpy.types.PropertyGroup):
    texels: IntProperty(name="Texels", description="Lightmap texels covered by surfaces")
    shots: IntProperty(name="Shots", description="Patches and lights shot")
    seconds: FloatProperty(name="Seconds", description="Wall-clock time of the bake")
    unshot: FloatProperty(name="Unshot", subtype='PERCENTAGE',
                          description="Share of the emitted power still unshot at the end")
    stopped_at_shot_limit: BoolProperty(name="Stopped at the Shot Limit",
                                        description="The bake stopped at Max Shots with more "
                                        "than the threshold still unshot")
    diverged: BoolProperty(name="Diverged",
                           description="The unshot power rose (shots made light): the bake "
                           "stopped and kept the lightmaps of its last checkpoint")
    pages: IntProperty(name="Pages", description="Lightmap images written")
    valid: BoolProperty(name="Baked", description="A bake has finished in this scene")


class LuxelComparison(bpy.types.PropertyGroup):
    """Settings of Compare with Cycles and the headline numbers of its last run."""
    directory: StringProperty(name="Folder", default="//luxel_compare", subtype='DIR_PATH',
                              description="Folder for report.html, report.json and images "
                              "(relative to the .blend)")
    samples: IntProperty(name="Reference Samples", default=256, min=4, soft_max=16384,
                         description="Cycles samples of the reference bake; its curve bakes "
                         "1, 4, 16, ... samples below this")
    view_samples: IntProperty(name="View Samples", default=128, min=1, soft_max=4096,
                              description="Cycles samples of each path-traced view")
    views: IntProperty(name="Views", default=5, min=1, max=32,
                       description="Views rendered: the scene's cameras, then automatic ones")
    resolution: IntVectorProperty(name="Resolution", size=2, default=(320, 240), min=16,
                                  max=8192, description="Width and height of the views")
    valid: BoolProperty(name="Compared", description="A comparison has finished")
    rel_rms: FloatProperty(name="Relative RMS", description="Lightmap RMS error divided by the "
                           "reference's RMS radiance")
    rms: FloatProperty(name="RMS", description="Lightmap RMS error (the paper's eq. 1)")
    max_error: FloatProperty(name="Max Error", description="Largest texel error")
    flip_mean: FloatProperty(name="FLIP", description="Mean FLIP error over the views")
    yee_fraction: FloatProperty(name="Yee", description="Share of views that Yee's metric "
                                "judges different")
    report: StringProperty(name="Report", subtype='FILE_PATH',
                           description="report.html of the last comparison")

    def options(self, directory=""):
        """The comparison these settings ask for, into ``directory`` (default: the folder)."""
        return CompareOptions(directory=directory or self.directory, samples=self.samples,
                              view_samples=self.view_samples,
                              resolution=tuple(self.resolution), views=self.views)


def _solver_property(setting):
    """The Blender property of one of the solver's settings, made from its declaration."""
    common = dict(name=setting.exposed.label, description=setting.help, default=setting.default)
    if setting.kind is bool:
        return BoolProperty(**common)
    if setting.kind is str:
        return EnumProperty(items=[(choice.identifier, choice.label, choice.help)
                                   for choice in setting.choices], **common)
    limits = {key: value for key, value in (("min", setting.lowest), ("max", setting.maximum),
                                            ("soft_max", setting.soft_maximum))
              if value is not None}
    if setting.kind is int:
        return IntProperty(subtype=setting.exposed.subtype, **limits, **common)
    digits = {} if setting.exposed.digits is None else {"precision": setting.exposed.digits}
    return FloatProperty(subtype=setting.exposed.subtype, **digits, **limits, **common)


class LuxelSceneSettings(bpy.types.PropertyGroup):
    """The bake's settings: the solver's (native/settings.py, added below) and Blender's own."""
    output: EnumProperty(name="Output", items=OUTPUTS, default="PACK",
                         description="Where the lightmap images are stored")
    directory: StringProperty(name="Folder", default="//lightmaps", subtype='DIR_PATH',
                              description="Folder for EXR lightmaps (relative to the .blend)")
    show_baked: BoolProperty(name="Show Baked Lighting", default=False,
                             update=_show_baked_changed,
                             description="Display the baked lightmaps in EEVEE, Cycles and "
                             "Workbench; turning it off restores the materials exactly")
    gltf_lightmaps: BoolProperty(name="Luxel Lightmaps in glTF", default=True,
                                 description="glTF export: each baked object's lightmap UVs "
                                 "as TEXCOORD_1 and its lightmap in its material "
                                 "(MOZ_lightmap), as three.js reads it")
    stats: PointerProperty(type=LuxelBakeStats)
    comparison: PointerProperty(type=LuxelComparison)

    def solver_settings(self):
        return Settings(**{setting.name: getattr(self, setting.name)
                           for setting in EXPOSED_SETTINGS})


# Blender reads a PropertyGroup's properties from its annotations when it is registered.
LuxelSceneSettings.__annotations__ = {
    **{setting.name: _solver_property(setting) for setting in EXPOSED_SETTINGS},
    **LuxelSceneSettings.__annotations__}


class LuxelObjectSettings(bpy.types.PropertyGroup):
    receive: BoolProperty(name="Receive Lightmap", default=True,
                          description="Bake a lightmap for this object (it occludes and emits "
                                      "either way)")
    back_faces: EnumProperty(
        name="Back Faces", default='AUTO', items=[
            ('AUTO', "Auto", "Emitting sheets (lights modelled as planes, open meshes) receive "
             "on their backs too: light bounces between a lamp's back and the ceiling"),
            ('ON', "On", "The back faces receive and reflect light on texels of their own, "
             "as Blender's two-sided surfaces do (they are not shown in the viewport)"),
            ('OFF', "Off", "Only the front faces receive light")],
        description="Whether light reaching this object's back faces is reflected")
    uv_source: EnumProperty(
        name="UV Source", default='LUXEL', items=[
            ('LUXEL', "Luxel's Charts", "Luxel unwraps the evaluated surface into charts of "
             "its own at the texel density"),
            ('MAP', "UV Map", "A lightmap UV map of this mesh's, packed as it is: its faces "
             "must not overlap and must lie inside [0, 1]")],
        description="Where the lightmap's UVs come from")
    source_uv_map: StringProperty(name="UV Map",
                                  description="The mesh's own lightmap UV map, with UV "
                                  "Source set to UV Map")
    resolution_scale: FloatProperty(name="Resolution Scale", default=1.0, min=0.01,
                                    soft_max=16.0,
                                    description="Multiplies the scene's texel density here")
    image: PointerProperty(type=bpy.types.Image, name="Lightmap",
                           description="Lightmap image of the last bake")
    uv_map: StringProperty(name="Lightmap UV Map",
                           description="UV map that the last bake added to this mesh")


_classes = (LuxelBakeStats, LuxelComparison, LuxelSceneSettings, LuxelObjectSettings)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(_classes)


def register():
    _register_classes()
    bpy.types.Scene.luxel = PointerProperty(type=LuxelSceneSettings)
    bpy.types.Object.luxel = PointerProperty(type=LuxelObjectSettings)


def unregister():
    del bpy.types.Object.luxel
    del bpy.types.Scene.luxel
    _unregister_classes()
