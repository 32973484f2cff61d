"""Everything of Luxel that imports bpy: settings, the bake operator, panels, the command line
entry, scene export and write-back. Each module registers its own classes."""
from . import cli, operators, panels, properties

_MODULES = (properties, operators, panels, cli)


def register():
    for module in _MODULES:
        module.register()


def unregister():
    for module in reversed(_MODULES):
        module.unregister()
