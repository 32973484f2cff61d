import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))


@pytest.fixture(scope="session")
def ctx():
    """One headless context (EGL, Mesa llvmpipe in CI) shared by the GPU tests."""
    from native import create_context
    context = create_context()
    yield context
    context.release()


@pytest.fixture
def gl_clean(ctx):
    """Fails the test if it left a GL error behind (moderngl's own test style)."""
    with ctx:
        ctx.error  # reading clears a stale error
        yield ctx
        assert ctx.error == "GL_NO_ERROR"
