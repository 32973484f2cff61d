"""Every uniform the solver sets is declared in its program's shaders: set_uniform raises for
one that is not (a misspelt or stale name), and skips only those the compiler removed as
unused. Bakes that go through every program (each projection, subdivision NONE, ADAPTIVE and
REGULAR, point, spot and sun lights, a thin gap, texels whose surface bends within them) set
each uniform at least once."""
import math

import numpy as np
import pytest

import scenes

from native import PROJECTIONS, PointLight, Scene, Settings, Solver, SpotLight, SunLight
from native import gpu
from native.samples import SceneBuilder
from native.state import NO_SURFACE

# The modules that set uniforms, each through its own name for gpu.set_uniform.
SETTERS = ("state", "preprocess", "visibility", "subdivision", "receivers", "thin_gaps")


def test_declared_uniforms_are_read_from_the_sources():
    source = """
    uniform vec3 u_quad[4];        // corners
    uniform float u_a, u_b;
    /* uniform int u_commented; */
    // uniform int u_also_commented;
    uniform sampler2DArray u_visibility;
    layout(std140) uniform highp float u_qualified;
    """
    assert gpu.declared_uniforms(source) == {"u_quad", "u_a", "u_b", "u_visibility",
                                             "u_qualified"}


def test_an_undeclared_uniform_fails_and_an_unused_one_is_skipped(ctx, gl_clean):
    objects = gpu.GLObjects(ctx)
    try:
        program = objects.program("fullscreen.vert", "argmax.frag")
        program.extra["uniforms"].add("u_declared_but_unused")
        gpu.set_uniform(program, "u_source", 0)
        gpu.set_uniform(program, "u_declared_but_unused", 1.0)
        with pytest.raises(gpu.UndeclaredUniformError, match="u_never_declared.*argmax.frag"):
            gpu.set_uniform(program, "u_never_declared", 1.0)
    finally:
        objects.release()


def lit_room():
    """A floor under a shelf, an emitter 1 mm over the floor (a thin gap), and a point, a spot
    and a sun light."""
    builder = SceneBuilder()
    builder.quad("floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], (0.5,) * 3)
    builder.quad("shelf", [(.2, .2, .5), (.7, .2, .5), (.7, .7, .5), (.2, .7, .5)], (0.5,) * 3)
    builder.quad("lamp", [(-.25, -.25, .001), (-.25, .25, .001), (.25, .25, .001),
                          (.25, -.25, .001)], (0.0,) * 3, (4.0,) * 3, two_sided=False)
    return builder.build([PointLight(position=(0.0, 0.0, 1.5), power=50.0),
                          SpotLight(position=(0.5, 0.0, 1.0), direction=(0.0, 0.0, -1.0),
                                    power=50.0),
                          SunLight(direction=(0.3, 0.2, -1.0), strength=2.0)])


def thin_cable():
    """A smooth 1 cm tube at 10 texels per metre: its texels bend within them."""
    vertices, triangles, normals = scenes.smooth_tube(0.005, 1.0, sides=16, rings=4)
    return Scene(vertices=vertices, triangles=triangles, normals=normals,
                 albedo=np.full((len(triangles), 3), 0.5),
                 lights=[SunLight(direction=(0.0, -math.sqrt(0.5), -math.sqrt(0.5)),
                                  strength=3.0)])


def test_bakes_through_every_program_set_declared_uniforms_only(ctx, gl_clean, monkeypatch):
    import importlib
    made, set_on = set(), {}

    def recording(program, name, value, original=gpu.set_uniform):
        set_on.setdefault(program.extra["name"], {}).setdefault(name, []).append(value)
        original(program, name, value)   # raises for an undeclared uniform

    def program(self, *files, original=gpu.GLObjects.program, **options):
        made_program = original(self, *files, **options)
        made.add(made_program.extra["name"])
        return made_program

    for module in SETTERS:
        monkeypatch.setattr(importlib.import_module(f"native.{module}"), "set_uniform",
                            recording)
    monkeypatch.setattr(gpu.GLObjects, "program", program)
    for projection in PROJECTIONS:
        for subdivision in ("NONE", "ADAPTIVE", "REGULAR"):
            for scene, density in ((lit_room(), 10), (thin_cable(), 10)):
                solver = Solver(scene, Settings(texel_density=density, max_shots=40,
                                                threshold=0.0, projection=projection,
                                                subdivision=subdivision), ctx=ctx)
                try:
                    solver.run()
                    solver.result()
                finally:
                    solver.release()
    assert made == set(set_on)   # every program had uniforms set
    patch = set_on["receiver_boxes.vert + receive_patch.frag"]
    assert any(tuple(extent) != NO_SURFACE for extents in patch["u_surface_extents"]
               for extent in extents)
    light = set_on["receiver_boxes.vert + receive_light.frag"]
    assert set(light["u_light_kind"]) == {0, 1, 2}
    count = set_on["raster.vert + raster.geom + shadow_count.frag"]
    assert set(count["u_count_hidden"]) == {0, 1}
    level = set_on["raster.vert + raster.geom + set_level.frag"]
    assert set(level["u_boundary_only"]) == {0, 1}
