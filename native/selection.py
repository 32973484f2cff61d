"""Next-shooter selection: a masked arg-max of the blocks' unshot power on the GPU, read back
as a grid of regions, and the regions of texels the strongest blocks shoot from (finer for a
strong block, coarser for a weak one with the adaptive shooting level)."""
from dataclasses import dataclass, field
import math
from typing import NamedTuple

import moderngl
import numpy as np

from .settings import MAX_SHOOT_LEVEL
from .state import Region

# One selection (an arg-max read-back, which waits for the GPU) picks up to
# Settings.shooters_per_selection patches: the strongest block of each region of the atlas
# whose power is at least this share of the strongest one's. Each shot then takes exactly the
# energy it read; what its texels receive meanwhile stays unshot for a later shot.
BATCH_MIN_SHARE = 0.25
# A patch's side with Settings.patch_size 0 (automatic): that of a square of the scene's
# surface area over this many. Patches large against the gaps between surfaces send their
# light across them short (docs/benchmarks-log.md, "Patches half as wide"); the Cornell box's
# at 60 texels per metre are the shoot level's 4 texels wide.
AUTOMATIC_PATCHES = 1024
# The adaptive shooting level coarsens a shot by one level (4x the texels) for every 4x less
# power than the strongest patch shot had, by at most this many levels.
MAX_COARSER_LEVELS = 2
# A strong block shoots as parts at most this many levels finer than the patch level, per
# projection: a quarter or a sixteenth of a patch (whose side follows the scene's size, not
# its texels). Each part is a shot: a light's sixteenths took four times the shots of its
# quarters to the first lightmap, and cut its penumbrae into twice the steps. The cube, the
# default, takes quarters for the first lightmap's sake; the non-linear projection, chosen
# for accuracy at more time than the cube's, keeps the sixteenths (with quarters it came
# farther from Cycles on a scene strewn with penumbrae); and the per-vertex hemisphere needs
# them, its straight-drawn edges misplaced by up to a texel, which the sixteenths' many eyes
# average out (docs/benchmarks-log.md, "A light's quarters").
FINEST_PARTS = {"HEMICUBE": 1, "NONLINEAR": 2, "HEMISPHERE": 2}
# A selection reads back up to this many candidates per shooter it may queue (blocks inside
# others are dropped later).
CANDIDATES_PER_SHOOTER = 2
# Emission shoots from parts as small as this many shots over all emitting texels allow
# (block_region): direct light is the sharpest, and from one centre per facet a lamp
# shade's inside, seen through its opening from part of its height, lit what faces the
# opening as if seen from all of it.
EMISSION_SHOTS = 128


class Candidate(NamedTuple):
    """The strongest block of a region of the selection grid."""
    power: float
    page: int
    block: tuple    # (x, y) at the shooting level


@dataclass
class ShotQueue:
    """The shots selected and not yet shot, the lights still to shoot, and the strongest
    powers so far (adaptive levels, adaptive subdivision)."""
    shots: list = field(default_factory=list)      # state.Shooter or lights, in order
    pending: list = field(default_factory=list)    # lights not yet queued
    strongest_patch: float = 0.0
    strongest_shot: float = 0.0


def patch_level(settings, surface_area):
    """The mip level whose blocks shoot: the one whose side (2^level texels of 1 / density
    metres) is nearest the patch size in a log scale, never finer than shoot_level. A
    patch's world size, not its texels, sets the shots: doubling the density adds a level."""
    size = settings.patch_size or math.sqrt(surface_area / AUTOMATIC_PATCHES)
    texels = size * settings.texel_density
    if texels <= 1.0:
        return settings.shoot_level
    level = int(math.floor(math.log2(texels) + 0.5))
    return min(max(level, settings.shoot_level), max(settings.shoot_level, MAX_SHOOT_LEVEL))


def measure(state):
    """Masked arg-max over the shooting level on the GPU, down to a grid of regions that is
    read back. Returns the Candidates, the strongest blocks of their regions, strongest
    first: those with at least BATCH_MIN_SHARE of the strongest power, at most
    CANDIDATES_PER_SHOOTER times the batch; and the total unshot power."""
    grids = []
    for index, page in enumerate(state.pages):
        texture, fbo = page.pyramid[0]
        fbo.use()
        page.textures["position"].use(location=0)
        page.textures["unshot"].use(location=1)
        state.fullscreen["block"].render(moderngl.TRIANGLES, vertices=3)
        for (source, _), (_, target) in zip(page.pyramid, page.pyramid[1:]):
            target.use()
            source.use(location=0)
            state.fullscreen["argmax"].render(moderngl.TRIANGLES, vertices=3)
        grid = np.frombuffer(page.pyramid[-1][0].read(), dtype="f4").reshape(-1, 4)
        grids.append(np.concatenate([grid, np.full((len(grid), 1), index, "f4")], axis=1))
    grid = np.concatenate(grids).astype(np.float64)
    total = float(grid[:, 3].sum())
    strongest = grid[:, 0].max(initial=0.0)
    if strongest <= 0.0:
        return [], total
    chosen = np.nonzero(grid[:, 0] >= BATCH_MIN_SHARE * strongest)[0]
    chosen = chosen[np.argsort(-grid[chosen, 0], kind="stable")]
    batch = CANDIDATES_PER_SHOOTER * state.settings.shooters_per_selection
    return [Candidate(grid[i, 0], int(grid[i, 4]), (int(grid[i, 1]), int(grid[i, 2])))
            for i in chosen[:batch]], total


def regions_to_shoot(state, energy, queue, candidates, count):
    """[(Region, finer levels)] of up to ``count`` candidates, strongest first, skipping a
    block inside one already taken (adaptive levels)."""
    least_finer = emission_finer(state)
    # Where emission shoots at the patch level anyway (a furnace's walls), which blocks
    # hold it does not matter.
    emitting = _emitting_blocks(state) if least_finer else set()
    chosen = []
    for candidate in candidates:
        holds_emission = (candidate.page, *candidate.block) in emitting
        region, finer = block_region(state, energy, queue, candidate,
                                     least_finer=least_finer if holds_emission else 0)
        if not any(region.overlaps(other) for other, _ in chosen):
            chosen.append((region, finer))
        if len(chosen) == count:
            break
    return chosen


def block_region(state, energy, queue, candidate, least_finer=0):
    """The Region of texels a block shoots from, and how many levels finer its parts shoot.
    A block carrying 4^k times a mean block's share of the emitted power or more shoots as
    sub-blocks k levels finer, down to single texels: a strong shooter's visibility from one
    centre would cut its penumbrae into steps (the Cornell box's light, 57 times a mean
    block; not a furnace's walls, nor an emitter that is half the scene's blocks); and at
    least ``least_finer`` levels finer, however weak (emission_finer()). With the adaptive
    shooting level a weak block shoots as a coarser block around it. Blocks are patches
    (patch_level): the refinement follows their power, not their texels."""
    level = state.patch_level
    power = candidate.power
    ratio = power * energy.shooting_blocks / max(energy.emitted_scalar, 1e-30)
    finer = min(max(min(level, int(math.log(ratio, 4.0))) if ratio >= 4.0 else 0, least_finer),
                FINEST_PARTS[state.settings.projection])
    coarser = 0 if finer else _coarser_levels(state.settings, queue, power)
    size = 1 << (level + coarser)
    x, y = candidate.block
    return Region(candidate.page, (x >> coarser) * size, (y >> coarser) * size, size), finer


def emission_finer(state):
    """How many levels below the patch level a block holding emission shoots: down to single
    texels where EMISSION_SHOTS cover all the scene's emitting texels, each level up a
    quarter as many shots (a furnace's emitting walls stay at the patch level)."""
    # emission_left keeps its texels as they shoot (their power zeroed): all that emitted.
    emitting_texels = sum(len(page.emission_left[0]) for page in state.pages)
    level = state.patch_level
    finer = level
    while finer > 0 and emitting_texels > EMISSION_SHOTS * 4 ** (level - finer):
        finer -= 1
    return finer


def _emitting_blocks(state):
    """{(page, block x, block y)} of the patches whose texels hold emission not yet shot."""
    blocks = set()
    width, level = state.packed.width, state.patch_level
    for index, page in enumerate(state.pages):
        emitting, power = page.emission_left
        left = emitting[power.max(axis=1, initial=0.0) > 0.0]
        blocks.update((index, int(x), int(y)) for x, y in
                      np.unique(np.stack([(left % width) >> level, (left // width) >> level],
                                         axis=1), axis=0))
    return blocks


def _coarser_levels(settings, queue, power):
    """Adaptive shooting level: how many levels coarser than the patch level this shot is, from
    its block's power against the strongest patch shot so far."""
    if not settings.adaptive_shoot_level:
        return 0
    queue.strongest_patch = max(queue.strongest_patch, power)
    ratio = queue.strongest_patch / max(power, 1e-30)
    return int(min(MAX_COARSER_LEVELS, max(0.0, math.log(ratio, 4.0))))

