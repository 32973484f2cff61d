"""Luxel in the Properties editor: Render properties for the bake, Object properties for each
object's lightmap."""
import bpy

from .evaluation import differences
from .writeback import is_stale


class LUXEL_PT_render(bpy.types.Panel):
    bl_label = "Luxel Lightmaps"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        settings = context.scene.luxel
        row = layout.row()
        row.operator("luxel.bake", icon='RENDER_STILL')
        row.operator("luxel.remove_lightmaps", icon='TRASH')
        column = layout.column()
        column.prop(settings, "texel_density")
        column.prop(settings, "threshold")
        column.prop(settings, "max_shots")
        column.prop(settings, "ambient")
        column.prop(settings, "shoot_level")
        column.prop(settings, "adaptive_shoot_level", text="Adaptive")
        column.prop(settings, "patch_size")
        column.prop(settings, "max_atlas_size")
        column.prop(settings, "output")
        if settings.output == 'FILES':
            column.prop(settings, "directory")
        layout.prop(settings, "show_baked")
        layout.operator("luxel.view_in_browser", icon='URL')


class _RenderSubPanel:
    """Where the render panel's sub-panels live."""
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "render"
    bl_parent_id = "LUXEL_PT_render"


class LUXEL_PT_render_visibility(_RenderSubPanel, bpy.types.Panel):
    bl_label = "Visibility"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        settings = context.scene.luxel
        column = layout.column()
        column.prop(settings, "projection")
        column.prop(settings, "hemicube_resolution", text="Resolution")
        column.prop(settings, "neighbour_visibility")


class LUXEL_PT_render_subdivision(_RenderSubPanel, bpy.types.Panel):
    bl_label = "Subdivision"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        settings = context.scene.luxel
        layout.prop(settings, "subdivision")
        if settings.subdivision == 'NONE':
            return
        layout.prop(settings, "subdivision_level", text="Level")
        if settings.subdivision == 'ADAPTIVE':
            column = layout.column(align=True)
            column.prop(settings, "subdivision_shadow_min")
            column.prop(settings, "subdivision_shadow_max", text="Max")


class LUXEL_PT_render_stats(_RenderSubPanel, bpy.types.Panel):
    bl_label = "Last Bake"

    def draw(self, context):
        stats = context.scene.luxel.stats
        if not stats.valid:
            self.layout.label(text="Not baked yet")
            return
        column = self.layout.column(align=True)
        column.label(text=f"Texels: {stats.texels:,}")
        column.label(text=f"Shots: {stats.shots:,}")
        column.label(text=f"Time: {stats.seconds:.1f} s")
        column.label(text=f"Unshot: {stats.unshot:.2f} %")
        column.label(text=f"Images: {stats.pages}")
        if stats.stopped_at_shot_limit:
            column = self.layout.column(align=True)
            column.label(text=f"Stopped at the shot limit: {stats.unshot:.2f} % unshot",
                         icon='ERROR')
            column.label(text="Raise Max Shots and bake again")
        if stats.diverged:
            column = self.layout.column(align=True)
            column.label(text="Stopped: the unshot power rose", icon='ERROR')
            column.label(text=f"Kept the lightmaps from {stats.unshot:.2f} % unshot")


class LUXEL_PT_render_compare(_RenderSubPanel, bpy.types.Panel):
    bl_label = "Compare with Cycles"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        settings = context.scene.luxel.comparison
        column = layout.column()
        column.prop(settings, "samples")
        column.prop(settings, "view_samples")
        column.prop(settings, "views")
        column.prop(settings, "resolution")
        column.prop(settings, "directory")
        layout.operator("luxel.compare", icon='IMAGE_REFERENCE')
        if not settings.valid:
            return
        column = layout.column(align=True)
        column.label(text=f"Relative RMS: {100.0 * settings.rel_rms:.2f} %")
        column.label(text=f"RMS: {settings.rms:.4g}   Max: {settings.max_error:.4g}")
        column.label(text=f"FLIP: {settings.flip_mean:.4f}")
        column.label(text=f"Yee: {100.0 * settings.yee_fraction:.0f} % of views differ")
        column.label(text=f"Report: {settings.report}")


class LUXEL_PT_object(bpy.types.Panel):
    bl_label = "Luxel Lightmap"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type in {
            'MESH', 'CURVE', 'SURFACE', 'FONT', 'META'}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        settings = context.object.luxel
        layout.prop(settings, "receive")
        column = layout.column()
        column.active = settings.receive
        column.prop(settings, "uv_source")
        if settings.uv_source == 'MAP':
            if context.object.type == 'MESH':
                column.prop_search(settings, "source_uv_map", context.object.data, "uv_layers")
            else:
                column.prop(settings, "source_uv_map")
        column.prop(settings, "resolution_scale")
        column.prop(settings, "back_faces")
        if settings.image is not None:
            column = layout.column(align=True)
            column.label(text=f"Image: {settings.image.name}", icon='IMAGE_DATA')
            column.label(text=f"UV map: {settings.uv_map}", icon='UV')
            if is_stale(context.object, context.evaluated_depsgraph_get()):
                if differences(context.object):
                    column.label(text="Baked as it renders: the viewport evaluates it "
                                 "otherwise (its modifiers' viewport settings)", icon='INFO')
                else:
                    column.label(text="Stale: the modifiers changed since the bake; bake "
                                 "again", icon='ERROR')
        for difference in differences(context.object):
            layout.label(text=f"Viewport and render differ: {difference}", icon='INFO')


_register, _unregister = bpy.utils.register_classes_factory(
    (LUXEL_PT_render, LUXEL_PT_render_visibility, LUXEL_PT_render_subdivision,
     LUXEL_PT_render_stats, LUXEL_PT_render_compare, LUXEL_PT_object))


def register():
    _register()


def unregister():
    _unregister()
