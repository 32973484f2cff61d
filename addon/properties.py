"""Luxel's settings and results, saved in the .blend: ``scene.luxel`` and ``object.luxel``."""
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty,
                       IntVectorProperty, PointerProperty, StringProperty)

from ..native import MAX_SUBDIVISION_LEVEL, Settings
from .compare import CompareOptions

_DEFAULTS = Settings()

PROJECTIONS = [
    ("HEMICUBE", "Hemicube", "Five rasterised faces around each shooter (the paper's baseline)"),
    ("HEMISPHERE", "Hemisphere", "Stereographic projection per vertex: one render, straight "
     "edges stay straight"),
    ("NONLINEAR", "Non-Linear", "Non-linear hemisphere projection (Gascuel et al. 2008): exact "
     "spherical triangles in one render"),
]

SUBDIVISIONS = [
    ("NONE", "None", "Each texel gathers light at its centre"),
    ("ADAPTIVE", "Adaptive", "Refine triangles partly in shadow, and the triangles casting the "
     "shadow: sharper shadow edges for less work than Regular"),
    ("REGULAR", "Regular", "Refine every triangle: each texel gathers light at 4^level points"),
]

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


class LuxelSceneSettings(bpy.types.PropertyGroup):
    projection: EnumProperty(name="Projection", items=PROJECTIONS, default=_DEFAULTS.projection,
                             description="How visibility is sampled around each shooter")
    texel_density: FloatProperty(name="Texel Density", default=_DEFAULTS.texel_density,
                                 min=0.01, soft_max=1000.0,
                                 description="Lightmap texels per metre of surface")
    max_shots: IntProperty(name="Max Shots", default=_DEFAULTS.max_shots, min=1,
                           description="Stop after this many shots")
    threshold: FloatProperty(name="Threshold", default=_DEFAULTS.threshold, min=0.0, max=0.99,
                             precision=4, description="Stop when this fraction of the emitted "
                             "power is left unshot (sunlight that misses the scene does not "
                             "count)")
    hemicube_resolution: IntProperty(name="Hemicube Resolution",
                                     default=_DEFAULTS.hemicube_resolution, min=8, max=4096,
                                     description="Texels on a side of each hemicube face; the "
                                     "hemisphere projections' maps are twice as wide")
    shoot_level: IntProperty(name="Shoot Level", default=_DEFAULTS.shoot_level, min=0, max=6,
                             description="Mip level shot from: a shooter spans 2^level texels")
    max_atlas_size: IntProperty(name="Max Image Size", default=_DEFAULTS.max_atlas_size,
                                min=64, max=16384,
                                description="Largest lightmap side; more images when exceeded")
    output: EnumProperty(name="Output", items=OUTPUTS, default="PACK",
                         description="Where the lightmap images are stored")
    directory: StringProperty(name="Folder", default="//lightmaps", subtype='DIR_PATH',
                              description="Folder for EXR lightmaps (relative to the .blend)")
    show_baked: BoolProperty(name="Show Baked Lighting", default=False,
                             update=_show_baked_changed,
                             description="Display the baked lightmaps in EEVEE, Cycles and "
                             "Workbench; turning it off restores the materials exactly")
    adaptive_shoot_level: BoolProperty(name="Adaptive Shoot Level",
                                       default=_DEFAULTS.adaptive_shoot_level,
                                       description="Shooters with little unshot energy shoot "
                                       "from coarser blocks of texels: fewer, larger shots")
    ambient: BoolProperty(name="Ambient Term", default=_DEFAULTS.ambient,
                          description="Add the light still unshot after its first bounce as "
                          "even ambient light (an estimate, like the unshot share it stands "
                          "for): rooms look converged far sooner")
    neighbour_visibility: BoolProperty(name="Neighbour Visibility",
                                       default=_DEFAULTS.neighbour_visibility,
                                       description="A receiver is visible when any of the 3x3 "
                                       "visibility texels around it sees it, against dark "
                                       "speckles where the visibility map undersamples")
    subdivision: EnumProperty(name="Subdivision", items=SUBDIVISIONS,
                              default=_DEFAULTS.subdivision,
                              description="Where texels gather light at several points")
    subdivision_level: IntProperty(name="Subdivision Level", default=_DEFAULTS.subdivision_level,
                                   min=1, max=MAX_SUBDIVISION_LEVEL,
                                   description="A texel at level k gathers light at 4^k points")
    subdivision_shadow_min: FloatProperty(name="Shadow Min",
                                          default=_DEFAULTS.subdivision_shadow_min,
                                          min=0.0, max=1.0, subtype='FACTOR',
                                          description="Adaptive refines a triangle when at "
                                          "least this share of its texels is in shadow")
    subdivision_shadow_max: FloatProperty(name="Shadow Max",
                                          default=_DEFAULTS.subdivision_shadow_max,
                                          min=0.0, max=1.0, subtype='FACTOR',
                                          description="Adaptive refines a triangle when at "
                                          "most this share of its texels is in shadow")
    stats: PointerProperty(type=LuxelBakeStats)
    comparison: PointerProperty(type=LuxelComparison)

    def solver_settings(self):
        return Settings(texel_density=self.texel_density, max_atlas_size=self.max_atlas_size,
                        hemicube_resolution=self.hemicube_resolution,
                        shoot_level=self.shoot_level, threshold=self.threshold,
                        max_shots=self.max_shots, projection=self.projection,
                        neighbour_visibility=self.neighbour_visibility,
                        subdivision=self.subdivision, subdivision_level=self.subdivision_level,
                        subdivision_shadow_min=self.subdivision_shadow_min,
                        subdivision_shadow_max=self.subdivision_shadow_max,
                        adaptive_shoot_level=self.adaptive_shoot_level, ambient=self.ambient)


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
