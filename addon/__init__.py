"""Everything of Luxel that imports bpy: settings, the bake operator, panels, the command line
entry, scene export and write-back, glTF export. Each module registers its own classes."""
from . import cli, gltf_export, operators, panels, properties

_MODULES = (properties, operators, panels, cli, gltf_export)


def register():
    for module in _MODULES:
        module.register()


def unregister():
    for module in reversed(_MODULES):
        module.unregister()
