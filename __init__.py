"""Luxel, the Blender extension: registration lives in addon/, the solver in native/.

addon/ is imported only when Blender registers the extension: importing this package (as
pytest's importlib mode does, as the parent of tests/) must not load bpy into a process that
then uses Mesa's GL (the two in one process have aborted)."""


def register():
    from .addon import register as register_addon
    register_addon()


def unregister():
    from .addon import unregister as unregister_addon
    unregister_addon()


# Blender's glTF exporter looks these up on each enabled add-on's module.
_GLTF_EXPORT_HOOKS = {"glTF2ExportUserExtension": "LightmapExtension",
                      "glTF2_pre_export_callback": "pre_export_callback",
                      "glTF2_post_export_callback": "post_export_callback"}


def __getattr__(name):
    if name not in _GLTF_EXPORT_HOOKS:
        raise AttributeError(name)
    from .addon import gltf_export
    return getattr(gltf_export, _GLTF_EXPORT_HOOKS[name])


__all__ = ["register", "unregister"]
