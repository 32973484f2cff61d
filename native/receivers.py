"""Receiver update and lights: every receiving texel gathers a shot's light against the
visibility map (receive_patch.frag for a patch, receive_light.frag for a point, spot or sun
light) by additive blending into its page's irradiance and unshot maps; a patch first takes
what it shoots from its texels. The lights' views, uniforms and power, and the sky as suns."""
import math

import moderngl
import numpy as np

from .geometry import frame_around
from .gpu import render_state, set_uniform
from .scene import SpotLight, SunLight
from .state import NO_SURFACE, View, blend_points

# u_light_kind of receive_light.frag.
POINT_LIGHT, SPOT_LIGHT, SUN_LIGHT = 0, 1, 2


def take_unshot(state, shooter):
    """Subtract what the shot took from its texels' unshot energy (exactly the values it
    read, so energy they received since stays)."""
    blend_points(state, shooter.page.unshot_only, shooter.texels, shooter.unshot,
                 moderngl.FUNC_REVERSE_SUBTRACT)
    emitting, power = shooter.page.emission_left
    if len(emitting):
        flat = shooter.texels[:, 1].astype(np.int64) * state.packed.width + shooter.texels[:, 0]
        where = np.searchsorted(emitting, flat).clip(0, len(emitting) - 1)
        power[where[emitting[where] == flat]] = 0.0


def set_patch_uniforms(state, shooter):
    program = state.programs["patch"]
    set_uniform(program, "u_quad", [tuple(corner) for corner in shooter.quad])
    set_uniform(program, "u_centre", tuple(shooter.centre))
    set_uniform(program, "u_radiance", tuple(shooter.radiance))
    # An empty rectangle: no texel is across a thin gap from this shooter.
    set_uniform(program, "u_surface_extent",
                NO_SURFACE if shooter.extent is None else shooter.extent)


def light_view(light, bounds):
    """The View a light's visibility is drawn from: a point or spot light's position, or
    the sun's orthographic window over the scene's bounding square, from its far side."""
    if isinstance(light, SunLight):
        n = np.asarray(light.direction, dtype=np.float64)
        n /= np.linalg.norm(n)
        return View(eye=bounds.centre - n * bounds.radius, frame=frame_around(n),
                    orthographic=True)
    return View(eye=np.asarray(light.position, dtype=np.float64), frame=np.eye(3),
                orthographic=False)


def set_light_uniforms(state, light):
    program = state.programs["light"]
    if isinstance(light, SunLight):
        set_uniform(program, "u_light_kind", SUN_LIGHT)
        set_uniform(program, "u_light_value", tuple(light.irradiance()))
        return
    set_uniform(program, "u_light_kind", POINT_LIGHT)
    set_uniform(program, "u_light_value", tuple(light.intensity()))
    if isinstance(light, SpotLight):
        axis = np.asarray(light.direction, dtype=np.float64)
        set_uniform(program, "u_light_kind", SPOT_LIGHT)
        set_uniform(program, "u_spot_axis", tuple(axis / np.linalg.norm(axis)))
        set_uniform(program, "u_spot_cos_half", light.cos_half_angle())
        set_uniform(program, "u_spot_smooth", light.smooth_width())


def light_power(light, radius):
    """A light's emitted power (W, RGB); a sun's over the scene's bounding square."""
    if isinstance(light, SunLight):
        return light.irradiance() * (2.0 * radius) ** 2
    return light.emitted_power()


def update(state, visibility, view, kind):
    """Every page's receivers gather the shot (program ``kind``: "patch" or "light")."""
    program = state.programs[kind]
    view.set_uniforms(program, state)
    with render_state(state.ctx, blend=moderngl.FUNC_ADD):
        visibility.texture.use(location=0)
        for page in state.pages:
            page.receivers.use()
            page.use_maps("position", "normal", "material", "level")
            state.fullscreen[kind].render(moderngl.TRIANGLES, vertices=3)


def sky_suns(radiance, count):
    """A uniform sky of ``radiance`` as ``count`` suns on a Fibonacci sphere, each carrying the
    irradiance of its 4 pi / count share of directions: radiance * 4 pi / count."""
    radiance = np.asarray(radiance, dtype=np.float64)
    if radiance.max() <= 0.0:
        return []
    index = np.arange(count) + 0.5
    z = 1.0 - 2.0 * index / count
    azimuth = math.pi * (3.0 - math.sqrt(5.0)) * index
    ring = np.sqrt(1.0 - z * z)
    directions = np.stack([ring * np.cos(azimuth), ring * np.sin(azimuth), z], axis=1)
    strength = float(radiance.max()) * 4.0 * math.pi / count
    color = tuple(radiance / radiance.max())
    return [SunLight(tuple(d), strength, color, name="World") for d in directions]
