"""OpenGL plumbing: a headless 4.1 core context, GLSL files loaded from the package's shaders/
folder, and one registry that releases every GL object the solver made."""
from contextlib import contextmanager
import ctypes
import ctypes.util
import functools
from pathlib import Path
import re
import sys

import moderngl

from .errors import GLUnavailableError

SHADER_DIR = Path(__file__).resolve().parent.parent / "shaders"
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.MULTILINE)
_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.DOTALL)
# "uniform [qualifiers] type name[, name ...];": the names, arrays' sizes left on them.
_UNIFORM = re.compile(r"\buniform\s+(?:layout\s*\([^)]*\)\s*)?(?:(?:lowp|mediump|highp)\s+)?"
                      r"\w+\s+([^;{]+);")

GL_CLIP_DISTANCE0 = 0x3000
INSTALL_HINT = ("Luxel needs OpenGL 4.1. Install or update the GPU driver; on a machine without "
                "a GPU install Mesa (Debian/Ubuntu: apt install libegl1 libgl1-mesa-dri; "
                "Fedora: dnf install mesa-libEGL mesa-dri-drivers).")


def create_context():
    """A headless OpenGL 4.1+ core context (EGL on Linux, the native API elsewhere). The
    caller's current context (Blender's) stays current."""
    attempts = [{"backend": "egl"}, {}]
    errors = []
    saved = _save_current()
    try:
        for kwargs in attempts:
            try:
                return moderngl.create_standalone_context(require=410, **kwargs)
            except Exception as error:  # moderngl raises plain Exceptions for missing drivers
                errors.append(f"{kwargs.get('backend', 'default')}: {error}")
    finally:
        _restore(saved)
    raise GLUnavailableError(f"{INSTALL_HINT} ({'; '.join(errors)})")


class _CurrentEGL:
    """The calling thread's current EGL context, to hand back after Luxel's work."""

    def __init__(self):
        egl = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
        for name in ("eglGetCurrentContext", "eglGetCurrentDisplay", "eglGetCurrentSurface"):
            getattr(egl, name).restype = ctypes.c_void_p
        egl.eglGetCurrentSurface.argtypes = [ctypes.c_int]
        egl.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
        self._egl = egl

    def save(self):
        egl = self._egl
        context = egl.eglGetCurrentContext()
        if not context:
            return None
        return (egl.eglGetCurrentDisplay(), egl.eglGetCurrentSurface(0x3059),
                egl.eglGetCurrentSurface(0x305A), context)

    def restore(self, saved):
        if saved is not None:
            self._egl.eglMakeCurrent(*saved)
        elif self._egl.eglGetCurrentContext():
            # Nothing was current: leave nothing current, or a context Luxel destroys later
            # would stay current on this thread for the next user of EGL (Blender).
            self._egl.eglMakeCurrent(self._egl.eglGetCurrentDisplay(), None, None, None)


class _CurrentGLX:
    """The calling thread's current GLX context (Blender's own, on X11)."""

    def __init__(self):
        glx = ctypes.CDLL(ctypes.util.find_library("GL") or "libGL.so.1")
        for name in ("glXGetCurrentContext", "glXGetCurrentDisplay"):
            getattr(glx, name).restype = ctypes.c_void_p
        for name in ("glXGetCurrentDrawable", "glXGetCurrentReadDrawable"):
            getattr(glx, name).restype = ctypes.c_ulong
        glx.glXMakeContextCurrent.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_ulong,
                                              ctypes.c_void_p]
        self._glx = glx

    def save(self):
        glx = self._glx
        context = glx.glXGetCurrentContext()
        if not context:
            return None
        return (glx.glXGetCurrentDisplay(), glx.glXGetCurrentDrawable(),
                glx.glXGetCurrentReadDrawable(), context)

    def restore(self, saved):
        if saved is not None:
            self._glx.glXMakeContextCurrent(*saved)
        elif self._glx.glXGetCurrentContext():
            self._glx.glXMakeContextCurrent(self._glx.glXGetCurrentDisplay(), 0, 0, None)


def _context_trackers():
    trackers = []
    if sys.platform.startswith("linux"):
        for kind in (_CurrentEGL, _CurrentGLX):
            try:
                trackers.append(kind())
            except (OSError, AttributeError):
                pass
    return trackers


_TRACKERS = None


def _save_current():
    global _TRACKERS
    if _TRACKERS is None:
        _TRACKERS = _context_trackers()
    return [(tracker, tracker.save()) for tracker in _TRACKERS]


def _restore(saved):
    for tracker, state in saved:
        tracker.restore(state)


@contextmanager
def using(ctx):
    """Make Luxel's context current for a block and give the caller's context back after it.

    moderngl's own ``with ctx:`` leaves no context current on exit (EGL), which would pull the
    rug from under Blender's drawing; on Linux the previous EGL or GLX context is restored."""
    saved = _save_current()
    try:
        with ctx:
            # Rebind the framebuffer that was bound on entry: moderngl rebinds its last-used
            # framebuffer when it creates another, which fails once that one is released.
            bound = ctx.detect_framebuffer()
            try:
                yield ctx
            finally:
                bound.use()
    finally:   # an error in the block gives the caller's context back too
        _restore(saved)


def load_shader(name, defines=None):
    """Source of shaders/<name>, with #include "file" lines replaced by that file, and a
    #define after the #version line for each (name, value) of ``defines``."""
    source = _expanded(name)
    if not defines:
        return source
    version, rest = source.split("\n", 1)
    return "\n".join([version] + [f"#define {key} {value}" for key, value in defines.items()]
                      + [rest])


# Every bake makes its programs anew: the files are read and searched once per process.
@functools.lru_cache(maxsize=None)
def _expanded(name):
    def expand(path, seen):
        if path in seen:
            raise RuntimeError(f"recursive #include of {path}")
        text = (SHADER_DIR / path).read_text()
        return _INCLUDE.sub(lambda m: expand(m.group(1), seen | {path}), text)
    return expand(name, frozenset())


def declared_uniforms(*sources):
    """The names of the uniforms that GLSL ``sources`` (#include expanded) declare: the
    compiler drops those a program does not use, and moderngl then does not list them."""
    return set().union(*(_declared(source) for source in sources))


@functools.lru_cache(maxsize=None)
def _declared(source):
    return frozenset(name.split("[")[0].strip()
                     for declaration in _UNIFORM.findall(_COMMENT.sub(" ", source))
                     for name in declaration.split(","))


class UndeclaredUniformError(LookupError):
    """A uniform set on a program whose shaders do not declare it (a misspelt or stale
    name): a bug, never a driver's choice."""


def set_uniform(program, name, value):
    """Set a uniform of a program made by GLObjects.program. A uniform its shaders declare
    but the compiler removed as unused (drivers differ) is skipped; one they never declare
    raises UndeclaredUniformError."""
    uniform = program.get(name, None)
    if uniform is not None:
        uniform.value = value
    elif name not in program.extra["uniforms"]:
        raise UndeclaredUniformError(
            f"uniform {name} is not declared in program {program.extra['name']}")


@contextmanager
def render_state(ctx, *, blend=None, framebuffer=None, color_mask=None, clip_distance=False,
                 depth_test=False):
    """Blend, colour-mask, clip and depth state for a block, restored after it, also on an
    exception.
    ``blend``: an equation (moderngl.FUNC_ADD, MIN, MAX, FUNC_REVERSE_SUBTRACT) that adds the
    incoming values to the stored ones with weights one and one; ``color_mask`` the mask of
    ``framebuffer``'s attachments (moderngl applies it when the framebuffer is bound);
    ``clip_distance``: gl_ClipDistance[0] clips; ``depth_test``: the nearer fragment wins."""
    saved_mask = None
    if clip_distance:
        ctx.enable_direct(GL_CLIP_DISTANCE0)
    if depth_test:
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
    if color_mask is not None:
        saved_mask = framebuffer.color_mask
        framebuffer.color_mask = color_mask
    if blend is not None:
        ctx.enable(moderngl.BLEND)
        ctx.blend_equation = blend
        ctx.blend_func = moderngl.ONE, moderngl.ONE
    try:
        yield
    finally:
        if blend is not None:
            ctx.blend_equation = moderngl.FUNC_ADD
            ctx.disable(moderngl.BLEND)
        if saved_mask is not None:
            framebuffer.color_mask = saved_mask
        if clip_distance:
            ctx.disable_direct(GL_CLIP_DISTANCE0)
        if depth_test:
            ctx.disable(moderngl.DEPTH_TEST)


class GLObjects:
    """Every GL object the solver creates goes through here and is released in one place,
    in reverse order, also when construction failed halfway."""

    def __init__(self, ctx):
        self.ctx = ctx
        self._objects = []

    def keep(self, obj):
        self._objects.append(obj)
        return obj

    def texture(self, size, components, dtype="f4", data=None):
        texture = self.keep(self.ctx.texture(size, components, data=data, dtype=dtype))
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return texture

    def texture_array(self, size, components, dtype="f4"):
        texture = self.keep(self.ctx.texture_array(size, components, dtype=dtype))
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return texture

    def framebuffer(self, color_attachments, depth_attachment=None):
        return self.keep(self.ctx.framebuffer(color_attachments, depth_attachment))

    @contextmanager
    def temporary_framebuffer(self, color_attachments, *, then, color_mask=None):
        """A framebuffer bound for the block, writing under ``color_mask`` (moderngl applies a
        mask when it binds), and released after it, with ``then`` bound in its place (moderngl
        binds the last used framebuffer again when it makes one: it must not be a released
        one)."""
        framebuffer = self.framebuffer(color_attachments)
        if color_mask is not None:
            framebuffer.color_mask = color_mask
        framebuffer.use()
        try:
            yield framebuffer
        finally:
            then.use()
            self.release_now(framebuffer)

    def depth_texture(self, size):
        return self.keep(self.ctx.depth_texture(size))

    def buffer(self, data=None, reserve=0):
        return self.keep(self.ctx.buffer(data, reserve=reserve))

    def program(self, vertex, fragment, geometry=None, *, defines=None):
        """A program from shader files, each given ``defines`` (load_shader); its ``extra``
        names them and the uniforms they declare (set_uniform)."""
        sources = [load_shader(vertex, defines), load_shader(fragment, defines)]
        if geometry:
            sources.append(load_shader(geometry, defines))
        program = self.keep(self.ctx.program(
            vertex_shader=sources[0], fragment_shader=sources[1],
            geometry_shader=sources[2] if geometry else None))
        program.extra = {"name": " + ".join(name for name in (vertex, geometry, fragment) if name),
                         "uniforms": declared_uniforms(*sources)}
        return program

    def vertex_array(self, program, content):
        return self.keep(self.ctx.vertex_array(program, content))

    def release_now(self, *objects):
        """Release these objects before the rest (temporaries of one phase), in the order given."""
        for obj in objects:
            self._objects.remove(obj)
            obj.release()

    def release(self):
        while self._objects:
            self._objects.pop().release()

    def __len__(self):
        return len(self._objects)


def buffer_content(program, vbo, layout):
    """Vertex-array content for an interleaved buffer of float attributes ((name, count) in
    ``layout``), skipping those the program's compiler removed as unused."""
    formats, names = [], []
    for name, count in layout:
        if program.get(name, None) is not None:
            formats.append(f"{count}f")
            names.append(name)
        else:
            formats.append(f"{4 * count}x")
    return (vbo, " ".join(formats), *names)


QUERY_POOL_SIZE = 512


def query_pool(ctx):
    """Occlusion queries for ``ctx``. moderngl cannot delete query objects, so each context
    keeps one pool, reused by every solver on it and freed with the context."""
    if ctx.extra is None:
        ctx.extra = {}
    pool = ctx.extra.setdefault("luxel_queries", [])
    while len(pool) < QUERY_POOL_SIZE:
        pool.append(ctx.query(samples=True))
    return pool
