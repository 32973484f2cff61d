"""Luxel's Blender-free solver: GPU progressive radiosity into lightmaps (numpy, moderngl,
xatlas, OpenEXR). Never imports bpy."""
from .atlas import Atlas, build_atlas
from .errors import GLUnavailableError, GPUMemoryError, LuxelError, SceneError, SettingsError
from .gpu import create_context
from .output import read_exr, tone_map, write_exr, write_png
from .scene import PointLight, Scene, SpotLight, SunLight
from .set_up import SetUpProgress, lightmap_atlas
from .settings import MAX_SUBDIVISION_LEVEL, PROJECTIONS, SUBDIVISIONS, Settings
from .solver import Ledger, Progress, Solver

__all__ = [
    "Atlas", "build_atlas", "GLUnavailableError", "GPUMemoryError", "LuxelError", "SceneError",
    "SettingsError", "create_context", "read_exr", "tone_map", "write_exr", "write_png",
    "PointLight", "Scene", "SpotLight", "SunLight", "Ledger", "Progress", "SetUpProgress",
    "Settings", "Solver", "lightmap_atlas",
    "PROJECTIONS", "SUBDIVISIONS", "MAX_SUBDIVISION_LEVEL",
]
