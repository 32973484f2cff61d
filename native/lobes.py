"""Glossy lobes: where a shooter's glossy layers send its light. A texel reflects its
reflectance's share of what it receives (the material map); of that, what lies beyond the
diffuse albedo (a Principled BSDF's specular, coat and metal layers, Scene.reflectance) leaves
about the mirror direction of the light that came in, not evenly: light from a lamp above
that grazes a wall leaves it down towards the floor. The receivers keep, per texel, the
directions their unshot light came from, weighted by the irradiance each brought
(receiver_common.glsl out_incoming). A shooter reads their mean as light from one direction d
mixed with light from all round (an even radiance: its directions' mean, so weighted, is two
thirds of the normal, inwards): the share beta from d that gives that mean. The glossy share of the light from all round leaves as
if diffuse (a rough mirror sends on an even radiance evenly), that of d in a lobe shaped as
the microfacet reflection Cycles' glossy layers have,

    L(w) = scale * D(h) G1(w) F(h . l) / (w . n)      (in units of the radiance it shoots)

for light from l (d reversed), h the half vector of l and w: GGX's distribution D of alpha =
roughness^2, Smith's masking G1 and Fresnel's term F of a dielectric reflecting the layers'
albedo at normal incidence; scaled so that it sends the power a diffuse shooter of that
radiance sends (how much that is: rise()). Light that comes in at a slant leaves it mostly
nearer the horizon than its mirror direction (the Fresnel term and GGX's long tail): a Phong
lobe about the mirror direction sent a quarter to a half of what GGX sends below 20
degrees. A rough surface (roughness 1) sends its glossy share as if diffuse.
"""
from dataclasses import dataclass
import functools
import math

import numpy as np

# Samples of the upper hemisphere (uniform in solid angle) for a lobe's normalization.
HEMISPHERE_SAMPLES = 32768
# The sharpest lobe: receive_patch.frag samples a shooter's quad at four points, and sharper
# lobes from them light four spots where the quad's mirror image lights an area
# (tests/test_glossy_lobes.py).
SMOOTHEST = 0.36
# rise(): (1 - cos)^2.5 times this has a cosine-weighted mean of 1 over the hemisphere; it
# gives Cycles' default layer 1.33, 2.56 and 4.04 times its normal-incidence albedo at cos 0.65,
# 0.35 and 0.15 (measured 1.36, 2.54, 3.64).
RISE_SHAPE = 7.875
# white_sky_albedo(): how fast roughness damps the rise (fitted at roughness 0.2, 0.5, 1).
RISE_DAMPING = 2.2


def needed(scene):
    """Whether any surface of ``scene`` has glossy layers that are not rough through
    (roughness under 1). Scenes without keep no incoming directions
    (memory.bytes_per_texel)."""
    return has_glossy(scene, scene.roughness < 1.0)


def has_glossy(scene, triangles=None):
    """Whether any of ``triangles`` (a mask; all by default) reflects more than its albedo,
    per triangle or in the textures: glossy layers."""
    smooth = np.ones(len(scene.triangles), bool) if triangles is None else triangles
    if not smooth.any():
        return False
    if (scene.reflected()[smooth] > scene.albedo[smooth]).any():
        return True
    for index in np.unique(scene.reflectance_texture_index[smooth]):
        if index < 0:
            continue
        reflectance = np.asarray(scene.reflectance_textures[index])[..., :3]
        albedo_index = scene.albedo_texture_index[smooth][
            scene.reflectance_texture_index[smooth] == index]
        albedo = (np.asarray(scene.albedo_textures[albedo_index[0]])[..., :3]
                  if albedo_index[0] >= 0 else 1.0)
        if (reflectance > albedo).any():
            return True
    return False


def _upper_hemisphere(count):
    index = np.arange(count) + 0.5
    z = index / count                       # uniform in solid angle over z in (0, 1)
    ring = np.sqrt(1.0 - z * z)
    azimuth = math.pi * (3.0 - math.sqrt(5.0)) * index
    return np.stack([ring * np.cos(azimuth), ring * np.sin(azimuth), z], axis=1)


_UPPER = _upper_hemisphere(HEMISPHERE_SAMPLES)


@dataclass
class Lobe:
    """A shooter's glossy lobe, as receive_patch.frag reads it."""
    axis: np.ndarray        # (3,) the mirror direction, world space
    alpha: float            # GGX's width: the roughness squared
    fresnel_f0: float       # the layers' albedo at normal incidence, for the Fresnel term
    #                         in its shape (1: without the Fresnel rise)
    share: np.ndarray       # (3,) the glossy share of the radiance it shoots
    scale: float            # the lobe's shape times this is its radiance over the radiance shot


def diffuse():
    """The lobe of a shooter without glossy light: everything leaves as if diffuse."""
    return Lobe(axis=np.array([0.0, 0.0, 1.0]), alpha=1.0, fresnel_f0=1.0, share=np.zeros(3),
                scale=1.0)


def lobe_alpha(roughness):
    """GGX's alpha for a layer of ``roughness``, no sharper than SMOOTHEST's."""
    return max(roughness, SMOOTHEST) ** 2


def shape(out, axis, normal, alpha, fresnel_f0):
    """(N,) a lobe's radiance towards the directions ``out`` (N, 3), before its scale:
    D(h) G1(out) F(h . l) / (out . n) for light from l, the mirror of ``axis`` about
    ``normal`` (receive_patch.frag lobe_shape() is the same)."""
    cos_out = out @ normal
    toward_light = 2.0 * float(axis @ normal) * normal - axis
    half = out + toward_light
    half /= np.linalg.norm(half, axis=-1, keepdims=True)
    alpha2 = alpha * alpha
    cos_half = np.clip(half @ normal, 0.0, 1.0)
    distribution = alpha2 / (math.pi * (cos_half * cos_half * (alpha2 - 1.0) + 1.0) ** 2)
    safe = np.maximum(cos_out, 1e-6)
    masking = 2.0 / (1.0 + np.sqrt(1.0 + alpha2 * (1.0 - safe * safe) / (safe * safe)))
    fresnel = dielectric_fresnel(np.clip(half @ toward_light, 0.0, 1.0), fresnel_f0)
    return np.where(cos_out > 0.0, distribution * masking * fresnel / safe, 0.0)


def from_one_direction(mean, normal):
    """The share beta of light from one direction d, mixed with light from all round, whose
    directions' mean is ``mean``: beta d - (1 - beta) 2/3 normal = mean. Returns (beta, d)."""
    along, squared = float(mean @ normal), float(mean @ mean)
    # With c = (1 - beta) 2/3: |mean + c normal| = 1 - 3c/2, the smaller root in [0, 2/3].
    b = 3.0 + 2.0 * along
    c = (b - math.sqrt(max(b * b - 5.0 * (1.0 - squared), 0.0))) / 2.5
    beta = 1.0 - 1.5 * min(max(c, 0.0), 2.0 / 3.0)
    if beta <= 0.0:
        return 0.0, -normal
    return beta, (mean + c * normal) / max(float(np.linalg.norm(mean + c * normal)), 1e-30)


@dataclass
class Reflection:
    """What a shooter's texels send: their radiance times their area, summed (RGB; more or
    less than they took where their glossy layers' albedo rises towards grazing light), and
    the lobe of its glossy share."""
    power: np.ndarray
    lobe: Lobe


def reflect(normal, incoming, taken, reflectance, glossy, roughness, *, fresnel):
    """The Reflection of a shooter of ``normal`` from its texels' rows: ``incoming`` (N, 4)
    the directions their unshot light came from, times their area (xyz, w: the weights'
    sum; None in a scene that keeps none: light from all round); ``taken`` (N, 3) their
    unshot radiance times their area; ``reflectance`` (N, 3) what they reflect,
    ``glossy`` (N, 3) its glossy layers' part at normal incidence (0 where the
    unshot light is emission); ``roughness`` (N,). With ``fresnel`` (Scene.glossy_fresnel)
    the glossy layers reflect more of light that comes in at a slant (rise()), and the
    diffuse part what they leave of the directions it goes to (Cycles' layering)."""
    share = np.divide(glossy, reflectance, out=np.zeros_like(glossy),
                      where=reflectance > 0.0).clip(0.0, 1.0)
    glossy_part = taken * share
    diffuse_part = taken - glossy_part
    summed = np.zeros(4) if incoming is None else incoming.sum(axis=0)
    beta, travel = ((0.0, -normal) if summed[3] <= 0.0
                    else from_one_direction(summed[:3] / summed[3], normal))
    if fresnel:
        albedo = glossy.mean(axis=1)
        white_sky = white_sky_albedo(albedo, roughness)
        ratio = np.divide(white_sky, albedo, out=np.ones_like(albedo), where=albedo > 0.0)
        from_one = beta * rise(min(max(-float(travel @ normal), 0.0), 1.0), ratio)
        diffuse_part = diffuse_part * ((1.0 - white_sky) / (1.0 - albedo))[:, None]
        lobed = glossy_part * from_one[:, None]
        evenly = glossy_part * ((1.0 - beta) * ratio)[:, None]
    else:
        lobed, evenly = glossy_part * beta, glossy_part * (1.0 - beta)
    power = (diffuse_part + lobed + evenly).sum(axis=0)
    lobe_share = np.divide(lobed.sum(axis=0), power, out=np.zeros(3), where=power > 0.0)
    down = float(travel @ normal)
    if lobe_share.max() <= 0.0 or down >= 0.0:
        return Reflection(power=power, lobe=diffuse())
    # The texels' roughness and albedo weighted by the power each sends into the lobe.
    weights = lobed.sum(axis=1)
    mean_roughness = float(np.average(roughness, weights=weights))
    if mean_roughness >= 1.0:
        return Reflection(power=power, lobe=diffuse())
    alpha = lobe_alpha(mean_roughness)
    fresnel_f0 = (min(max(float(np.average(glossy.mean(axis=1), weights=weights)), 1e-3), 1.0)
                  if fresnel else 1.0)
    axis = travel - 2.0 * down * normal
    return Reflection(power=power, lobe=Lobe(
        axis=axis, alpha=alpha, fresnel_f0=fresnel_f0, share=lobe_share,
        scale=math.pi / lobe_integral(float(axis @ normal), alpha, fresnel_f0)))


def cell_lobes(lobe, normal, incoming):
    """(cells, 4) per cell of a shooter of ``normal`` its lobe's axis (xyz) and scale (w):
    about the mirror direction of the light its texels took, ``incoming`` (cells, 4) their
    directions summed as reflect() reads them (zero where the scene keeps none), with the
    shooter's ``lobe``'s width and Fresnel term. A block's one axis, the mirror of its
    texels' mean, sent a lamp's light off a floor block the same way from its near and its
    far side, where each side mirrors the lamp its own way: a wall standing on the floor got
    0.82 of it. The shooter's axis where a cell took no light from one direction."""
    cells = np.tile([*lobe.axis, lobe.scale], (len(incoming), 1))
    if lobe.share.max() <= 0.0:
        return cells
    for cell, summed in zip(cells, incoming):
        if summed[3] <= 0.0:
            continue
        beta, travel = from_one_direction(summed[:3] / summed[3], normal)
        down = float(travel @ normal)
        if beta > 0.0 and down < 0.0:
            axis = travel - 2.0 * down * normal
            cell[:] = [*axis, math.pi / lobe_integral(float(axis @ normal), lobe.alpha,
                                                      lobe.fresnel_f0)]
    return cells


def white_sky_albedo(albedo, roughness):
    """(N,) what Principled glossy layers of normal-incidence albedo ``albedo`` (N,) and
    ``roughness`` (N,) reflect of light from all round: Schlick's Fresnel term's white-sky
    mean, F0 + (1 - F0) / 21, with the albedo for F0 and the rise damped by the roughness as
    Cycles' white furnace measures it (BENCHMARKS.md, "Glossy layers in a white furnace").
    0 where there is no glossy layer."""
    damping = np.minimum(np.exp(-RISE_DAMPING * (roughness - 0.2)), 1.0)
    return np.where(albedo > 0.0, albedo + (1.0 - albedo) * damping / 21.0, 0.0)


def rise(cosine, ratio):
    """(N,) the glossy layers' albedo for light coming in at ``cosine`` over theirs at normal
    incidence, for layers whose white-sky albedo is ``ratio`` (N,) times that: a rise towards
    grazing of shape (1 - cos)^2.5 whose cosine-weighted mean is ratio."""
    return 1.0 + (ratio - 1.0) * RISE_SHAPE * (1.0 - cosine) ** 2.5


def dielectric_fresnel(cosine, normal_reflectance):
    """(N,) Fresnel's reflectance of unpolarized light at ``cosine`` off a dielectric whose
    reflectance at normal incidence is ``normal_reflectance`` (its index of refraction from
    that): Schlick's approximation gives the default layer's 0.04 a fifth too little at 60
    degrees. 1 for a layer that reflects everything."""
    if normal_reflectance >= 1.0:
        return np.ones_like(cosine)
    root = math.sqrt(normal_reflectance)
    eta = (1.0 + root) / (1.0 - root)
    g = np.sqrt(eta * eta - 1.0 + cosine * cosine)
    return 0.5 * ((g - cosine) / (g + cosine)) ** 2 * (
        1.0 + ((cosine * (g + cosine) - 1.0) / (cosine * (g - cosine) + 1.0)) ** 2)


def lobe_integral(height, alpha, fresnel_f0):
    """The integral over the hemisphere above a surface of a lobe's shape() times the cosine
    to its normal, for an axis at ``height`` (axis . n) above it."""
    return _lobe_integral(round(height, 3), round(alpha, 3), round(fresnel_f0, 3))


@functools.lru_cache(maxsize=4096)
def _lobe_integral(height, alpha, fresnel_f0):
    normal = np.array([0.0, 0.0, 1.0])
    axis = np.array([math.sqrt(max(1.0 - height * height, 0.0)), 0.0, height])
    values = shape(_UPPER, axis, normal, alpha, fresnel_f0) * _UPPER[:, 2]
    return float(values.mean()) * 2.0 * math.pi
