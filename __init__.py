"""Luxel, the Blender extension: registration lives in addon/, the solver in native/."""
from .addon import register, unregister

__all__ = ["register", "unregister"]
