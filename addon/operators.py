"""``luxel.bake``: modal with a progress bar from the UI (Esc cancels, in the set-up too),
synchronous from scripts and in background mode. A bake's failures (all LuxelErrors, see
bake.py) become reports naming the object and the fix, with the GPU freed and the file as it
was."""
import os
import tempfile
import webbrowser

import bpy
from bpy.props import StringProperty

from ..native import LuxelError
from ..native.viewer import GLB_NAME, serve, write_viewer
from .bake import BakeJob, divergence_message, remove_lightmaps, shot_limit_message
from .compare import compare_with_cycles, summary_lines
from .gltf_export import export_gltf, scene_has_lightmaps

TIMER_SECONDS = 0.05
STEP_SECONDS = 0.1       # work per timer tick: long enough to progress, short for the UI


def _can_start(operator, context):
    """Bakes and comparisons need Object Mode and no interactive bake running."""
    if LUXEL_OT_bake._modal_running:
        operator.poll_message_set("A Luxel bake is running (Esc cancels it)")
        return False
    return context.scene is not None and context.mode == 'OBJECT'


class LUXEL_OT_bake(bpy.types.Operator):
    """Bake diffuse global illumination into lightmaps with Luxel's GPU radiosity"""
    bl_idname = "luxel.bake"
    bl_label = "Bake Lightmaps"
    bl_options = {'REGISTER', 'UNDO'}

    _job = None
    _timer = None
    _modal_running = False      # one interactive bake at a time

    @classmethod
    def poll(cls, context):
        return _can_start(cls, context)

    def execute(self, context):
        job = self._start(context)
        if job is None:
            return {'CANCELLED'}
        try:
            while not job.step(seconds=1.0):
                self._report_warnings(job)
        except LuxelError as error:
            return self._fail(job, error)
        return self._finish(job)

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        self._job = self._start(context)
        if self._job is None:
            return {'CANCELLED'}
        wm = context.window_manager
        self._timer = wm.event_timer_add(TIMER_SECONDS, window=context.window)
        wm.progress_begin(0, 1000)
        wm.modal_handler_add(self)
        LUXEL_OT_bake._modal_running = True
        context.workspace.status_text_set(
            f"Luxel: {self._job.status(takes_esc=True)}  (Esc to cancel)")
        return {'RUNNING_MODAL'}

    def modal(self, context, event):
        if event.type == 'ESC':
            self._end_modal(context)
            self._job.release()
            self.report({'WARNING'}, "Luxel bake cancelled; nothing was changed")
            return {'CANCELLED'}
        if event.type != 'TIMER':
            # The export reads the scene between timer events: edits wait until it is done.
            return {'RUNNING_MODAL'} if self._job.reading_the_scene else {'PASS_THROUGH'}
        try:
            done = self._job.step(STEP_SECONDS)
        except LuxelError as error:
            self._end_modal(context)
            return self._fail(self._job, error)
        self._report_warnings(self._job)
        context.window_manager.progress_update(int(1000 * self._job.fraction()))
        context.workspace.status_text_set(
            f"Luxel: {self._job.status(takes_esc=True)}  (Esc to cancel)")
        if not done:
            return {'RUNNING_MODAL'}
        self._end_modal(context)
        return self._finish(self._job)

    def _start(self, context):
        try:
            return BakeJob(context)
        except LuxelError as error:
            self.report({'ERROR'}, str(error))
            return None

    def _report_warnings(self, job):
        for warning in job.new_warnings():
            self.report({'WARNING'}, warning)

    def _finish(self, job):
        try:
            job.finish()
        except LuxelError as error:
            return self._fail(job, error)
        self._report_warnings(job)
        stats = job.scene.luxel.stats
        self.report({'INFO'}, f"Luxel: {stats.texels:,} texels, {stats.shots:,} shots, "
                              f"{stats.unshot:.2f} % unshot, {stats.seconds:.1f} s")
        stopped = shot_limit_message(stats, job.settings.threshold)
        if stopped:
            self.report({'WARNING'}, f"{stopped}: raise Max Shots (Render properties > Luxel "
                                     "Lightmaps) and bake again")
        diverged = divergence_message(stats)
        if diverged:
            self.report({'WARNING'}, diverged)
        return {'FINISHED'}

    def _fail(self, job, error):
        job.release()
        self.report({'ERROR'}, str(error))
        return {'CANCELLED'}

    def _end_modal(self, context):
        LUXEL_OT_bake._modal_running = False
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)


class LUXEL_OT_compare(bpy.types.Operator):
    """Bake with Luxel and with Cycles, and write error maps, views, perceptual differences and
    speed-against-error curves into a report folder"""
    bl_idname = "luxel.compare"
    bl_label = "Compare with Cycles"
    bl_options = {'REGISTER', 'UNDO'}

    directory: StringProperty(name="Folder", subtype='DIR_PATH',
                              description="Report folder; empty: the scene's comparison folder")

    @classmethod
    def poll(cls, context):
        return _can_start(cls, context)

    def execute(self, context):
        options = context.scene.luxel.comparison.options(self.directory)
        wm = context.window_manager
        interactive = context.window is not None and not bpy.app.background

        def progress(fraction, text):
            if interactive:
                wm.progress_update(int(1000 * fraction))
                context.workspace.status_text_set(f"Luxel: comparing with Cycles: {text}")

        if interactive:
            wm.progress_begin(0, 1000)
        try:
            report = compare_with_cycles(context, options, progress)
        except LuxelError as error:
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        finally:
            if interactive:
                wm.progress_end()
                context.workspace.status_text_set(None)
        for line in summary_lines(report):
            self.report({'INFO'}, line)
        return {'FINISHED'}


class LUXEL_OT_remove_lightmaps(bpy.types.Operator):
    """Take away everything Luxel's bakes added: images, UV maps, modifiers, helper data and
    properties; the file is as it was before the first bake"""
    bl_idname = "luxel.remove_lightmaps"
    bl_label = "Remove Lightmaps"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return _can_start(cls, context)

    def execute(self, context):
        remove_lightmaps(context.scene)
        return {'FINISHED'}


class LUXEL_OT_view_in_browser(bpy.types.Operator):
    """Export the baked scene as glTF with its lightmaps and show it in a web page served on
    this computer; the page's folder (luxel_view beside the .blend) can be sent as it is"""
    bl_idname = "luxel.view_in_browser"
    bl_label = "View in Browser"
    bl_options = {'REGISTER'}

    _server = None      # (folder, server) while Blender runs

    @classmethod
    def poll(cls, context):
        if not scene_has_lightmaps(context.scene):
            cls.poll_message_set("Bake first: there are no lightmaps to show")
            return False
        return _can_start(cls, context)

    def execute(self, context):
        folder = (bpy.path.abspath("//luxel_view") if bpy.data.filepath
                  else os.path.join(tempfile.gettempdir(), "luxel_view"))
        glb = os.path.join(folder, GLB_NAME)
        try:
            export_gltf(context, glb)
            write_viewer(glb, folder)
        except LuxelError as error:
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        served = LUXEL_OT_view_in_browser._server
        if served is None or served[0] != folder:
            stop_viewer_server()
            LUXEL_OT_view_in_browser._server = (folder, serve(folder))
        url = LUXEL_OT_view_in_browser._server[1].url
        if not bpy.app.background:
            webbrowser.open(url)
        self.report({'INFO'}, f"Luxel: showing {url} (the page is in {folder})")
        return {'FINISHED'}


def stop_viewer_server():
    if LUXEL_OT_view_in_browser._server is not None:
        server = LUXEL_OT_view_in_browser._server[1]
        server.shutdown()
        server.server_close()
        LUXEL_OT_view_in_browser._server = None


_register, _unregister = bpy.utils.register_classes_factory(
    (LUXEL_OT_bake, LUXEL_OT_compare, LUXEL_OT_remove_lightmaps, LUXEL_OT_view_in_browser))


def register():
    _register()


def unregister():
    stop_viewer_server()
    _unregister()
