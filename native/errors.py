"""Typed errors of the solver. Each message says what is wrong, where, and how to fix it."""


class LuxelError(Exception):
    """Base class of every error Luxel raises on purpose."""


class SceneError(LuxelError, ValueError):
    """The scene cannot be baked as given. ``object_name`` names the culprit when there is one."""

    def __init__(self, message, object_name=None):
        super().__init__(message)
        self.object_name = object_name


class SettingsError(LuxelError, ValueError):
    """A bake setting is out of its valid range."""


class GLUnavailableError(LuxelError, RuntimeError):
    """No OpenGL 4.1 context could be created."""


class GPUMemoryError(LuxelError, MemoryError):
    """The lightmaps would not fit the GPU; the message gives a texel density that would."""

    def __init__(self, message, needed_bytes, available_bytes, suggested_density):
        super().__init__(message)
        self.needed_bytes = needed_bytes
        self.available_bytes = available_bytes
        self.suggested_density = suggested_density
