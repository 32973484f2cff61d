"""Which evaluation of the scene a bake serves: the render's, the one final images use.

Blender evaluates modifiers twice over: for the viewport (Subdivision Surface's and
Multires's viewport levels, each modifier's Realtime switch) and for renders (their render
levels and Render switch). Python can only evaluate the viewport's, so for the bake's export
and its material evaluation RenderEvaluation sets the viewport's settings to the render's,
and puts them back afterwards, whatever happens. A lightmap then fits what F12, `blender -b
-f` and every render engine draw; where the viewport evaluates a mesh differently, the
viewport shows its lightmap as stale, and differences() names the setting that differs.
Geometry nodes that read Is Viewport cannot be set to render: the bake fits their viewport
geometry."""
import bpy

# Modifiers whose viewport and render levels differ: (type, viewport level, render level).
LEVELS = (('SUBSURF', "levels", "render_levels"), ('MULTIRES', "levels", "render_levels"))


class RenderEvaluation:
    """The scene's modifiers set to their render evaluation while held (apply(), restore())."""

    def __init__(self, scene):
        self.scene = scene
        self._changed = []      # (modifier's object name, modifier name, attribute, value)

    def apply(self):
        for obj, modifier in _modifiers(self.scene):
            for attribute, render in _render_settings(modifier):
                if getattr(modifier, attribute) != render:
                    self._changed.append((obj.name, modifier.name, attribute,
                                          getattr(modifier, attribute)))
                    setattr(modifier, attribute, render)

    def restore(self):
        while self._changed:
            name, modifier_name, attribute, value = self._changed.pop()
            obj = bpy.data.objects.get(name)
            modifier = obj.modifiers.get(modifier_name) if obj is not None else None
            if modifier is not None:
                setattr(modifier, attribute, value)


def differences(obj):
    """What evaluates ``obj`` differently in the viewport and in renders, as phrases naming
    the modifier and its settings (empty where both agree)."""
    found = []
    for modifier in obj.modifiers:
        for attribute, render in _render_settings(modifier):
            viewport = getattr(modifier, attribute)
            if viewport == render:
                continue
            if attribute == "show_viewport":
                found.append(f"modifier '{modifier.name}' is "
                             f"{'on' if render else 'off'} in renders and "
                             f"{'on' if viewport else 'off'} in the viewport")
            else:
                found.append(f"modifier '{modifier.name}' has Levels Viewport {viewport} "
                             f"and Render {render}")
        if modifier.type == 'NODES' and _reads_is_viewport(modifier.node_group):
            found.append(f"geometry nodes '{modifier.name}' read Is Viewport (the bake "
                         "fits the viewport's geometry there)")
    return found


def _modifiers(scene):
    for obj in scene.objects:
        if obj.library is None:
            for modifier in obj.modifiers:
                yield obj, modifier


def _render_settings(modifier):
    """(attribute, its render value) of the modifier's viewport settings."""
    settings = [("show_viewport", modifier.show_render)]
    for kind, viewport, render in LEVELS:
        if modifier.type == kind:
            settings.append((viewport, getattr(modifier, render)))
    return settings


def _reads_is_viewport(tree, seen=None):
    if tree is None:
        return False
    seen = set() if seen is None else seen
    if tree.name in seen:
        return False
    seen.add(tree.name)
    for node in tree.nodes:
        if node.bl_idname == 'GeometryNodeIsViewport':
            return True
        if node.bl_idname == 'GeometryNodeGroup' and _reads_is_viewport(node.node_tree, seen):
            return True
    return False
