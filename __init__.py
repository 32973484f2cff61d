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


__all__ = ["register", "unregister"]
