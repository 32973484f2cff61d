"""Postprocess: the lightmaps from the maps (rho * (E / pi + ambient) on receiving texels,
moved back to the atlas's layout, the gutter around charts filled), the ambient term that
stands for the light not yet shot, the energy ledger from sums over the maps, and the texels'
sample points; and the checkpoints a bake goes back to where its unshot power rises."""
import copy
from dataclasses import dataclass
import math

import numpy as np

from .state import decode_normals, in_atlas_layout, read_map

# The ambient term's mean albedo stays under this: two albedos of 1 would bounce for ever.
MAX_MEAN_ALBEDO = 0.999
# A texel the bounced light reached with less than this share of the mean irradiance it
# brought gets the ambient term in proportion: the little that leaks past a wall's edge into
# a sealed room does not carry the lit room's ambient light with it.
FULLY_REACHED_SHARE = 0.01
# The unshot power only falls: a shot takes its shooter's and returns at most the
# reflectance's share of it. Past this share above its least, far beyond the GPU's rounding,
# shots are making light, and the bake stops (Solver, Progress.diverged).
UNSHOT_RISE = 0.05
# A new checkpoint each time the unshot fraction falls to this share of the last one's: a
# few dozen copies of the maps in a bake, not one per selection.
CHECKPOINT_FALL = 0.8
# The maps a checkpoint keeps: what result() and ledger() read that shots change.
CHECKPOINT_MAPS = ("irradiance", "unshot", "incoming")


@dataclass
class Ledger:
    """RGB power in watts. emitted = absorbed + escaped + unshot at every step; escaped is what
    was shot and reached no receiving surface (open scenes, back faces)."""
    emitted: np.ndarray
    absorbed: np.ndarray
    escaped: np.ndarray
    unshot: np.ndarray

    def imbalance(self):
        residual = self.emitted - (self.absorbed + self.escaped + self.unshot)
        return float(np.max(np.abs(residual) / np.maximum(self.emitted, 1e-30)))


@dataclass
class Ambient:
    """The ambient term: a uniform radiance (RGB) on the texels the bounced light has
    reached, per page an (H, W) float32 weight in [0, 1] (how far it reached each texel)."""
    radiance: np.ndarray
    reached: list


@dataclass
class ReflectedStart:
    """The totals at a point after the direct light was shot (Solver's ambient term measures
    the reflected shots since against them): what had been received (W, RGB, with the thin
    gaps' correction) and shot (W, RGB), per page each texel's irradiance (mean of RGB), and
    the unshot fraction then."""
    received: np.ndarray
    shot: np.ndarray
    irradiance: list
    unshot_fraction: float


def lightmaps(state, ambient, *, reflected=True):
    """Per page: rho * (E / pi + ambient), the reflected radiance, or with ``reflected``
    False the irradiance E + pi * ambient, on receiving texels, alpha 1, and the gutter
    filled, on the CPU from the maps it reads anyway (no output maps on the GPU).
    ``ambient(irradiance)`` gives the Ambient from the pages' irradiance maps, or None to
    leave it out."""
    # Whole RGBA rows are contiguous (fast); the irradiance's alpha is 0 throughout.
    irradiance = [read_map(page.textures["irradiance"]) for page in state.pages]
    term = ambient(irradiance) if ambient is not None else None
    pages = []
    for index, (page, image) in enumerate(zip(state.pages, irradiance)):
        occupied = read_map(page.textures["material"])[..., 3] > 0   # a receiving texel
        image *= np.float32(1.0 / math.pi)
        if term is not None:
            image[..., :3] += term.reached[index][..., None] * term.radiance.astype(np.float32)
        image[..., :3] *= page.albedo if reflected else np.float32(math.pi)
        image *= occupied[..., None]
        image[..., 3] = occupied
        image = in_atlas_layout(state, page, image)
        fill_gutter(image, state.settings.padding + 1)
        pages.append(image)
    return pages


def received_power(state, irradiance):
    """What the pages' ``irradiance`` maps show was received (W, RGB): one product per page
    (an estimate needs no double-precision sums; the ledger's are)."""
    received = np.zeros(3)
    for page, page_irradiance in zip(state.pages, irradiance):
        received = received + (page_irradiance.reshape(-1, 4).T
                               @ page.own_area().reshape(-1))[:3]
    return received


def reflected_start(state, energy, irradiance, correction, unshot_fraction):
    """The ReflectedStart from the pages' ``irradiance`` maps now; ``correction`` (W) is the
    thin gaps' (what arrived less what their maps show)."""
    return ReflectedStart(received=received_power(state, irradiance) + correction,
                          shot=np.array(energy.shot_power, dtype=np.float64),
                          irradiance=[np.mean(image[..., :3], axis=-1)
                                      for image in irradiance],
                          unshot_fraction=unshot_fraction)


def ambient_term(state, energy, irradiance, correction, start):
    """The unshot light that has bounced at least once as uniform radiance (Solver.
    ambient_radiance), from the pages' ``irradiance`` maps and their unshot maps;
    ``correction`` (W) is the thin gaps' (what arrived less what their maps show), ``start``
    the ReflectedStart or None while direct light is still being shot."""
    received = received_power(state, irradiance) + correction
    unshot = np.zeros(3)
    for page in state.pages:
        unshot = unshot + math.pi * (read_map(page.textures["unshot"]).reshape(-1, 4).T
                                     @ page.area.reshape(-1))[:3]
        unshot = unshot - page.emission_left[1].sum(axis=0)   # direct light, unshot
    bounced = np.maximum(unshot, 0.0)
    shot = np.array(energy.shot_power, dtype=np.float64)
    if start is not None and float(np.mean(shot - start.shot)) > 0:
        # Reflected light lands elsewhere than direct light (an open floor's escapes),
        # and only where reflected shots reach (not in a room sealed from them).
        landed = float(np.mean(received - start.received))
        shot = float(np.mean(shot - start.shot))
        brought = [np.mean(image[..., :3], axis=-1) - before
                   for image, before in zip(irradiance, start.irradiance)]
    else:
        landed, shot = float(np.mean(received)), float(np.mean(shot)) - energy.sunlight_missed
        brought = [np.mean(image[..., :3], axis=-1) for image in irradiance]
    lands = min(max(landed, 0.0) / shot, 1.0) if shot > 0 else 1.0
    materials = [read_map(page.textures["material"]) for page in state.pages]
    receiving = [material[..., 3] > 0 for material in materials]
    brought_sum = sum(float((page.own_area() * np.maximum(page_brought, 0)
                             * page_receiving).sum())
                      for page, page_brought, page_receiving in zip(state.pages, brought,
                                                                    receiving))
    receiving_area = sum(float((page.own_area() * page_receiving).sum())
                         for page, page_receiving in zip(state.pages, receiving))
    full = FULLY_REACHED_SHARE * brought_sum / max(receiving_area, 1e-30)
    reached = [np.clip(page_brought / full, 0.0, 1.0).astype(np.float32) * page_receiving
               if full > 0 else np.zeros_like(page_brought)
               for page_brought, page_receiving in zip(brought, receiving)]
    area, albedo_area = 0.0, np.zeros(3)
    for page, material, page_reached in zip(state.pages, materials, reached):
        # The material map's reflectance is already scaled by each texel's share.
        area += float((page.own_area() * page_reached).sum(dtype=np.float64))
        albedo_area = albedo_area + (material[..., :3].reshape(-1, 3).T
                                     @ (page.area * page_reached).reshape(-1)).astype(np.float64)
    if area <= 0:
        return Ambient(radiance=np.zeros(3), reached=reached)
    mean_albedo = np.minimum(albedo_area / area, MAX_MEAN_ALBEDO)
    return Ambient(radiance=lands * bounced / (math.pi * area) / (1.0 - lands * mean_albedo),
                   reached=reached)


def texel_samples(state):
    """Solver.texel_samples: per page the texels' sample points, normals, areas, coverage
    and whether they receive, in the atlas's layout."""
    samples = []
    for page in state.pages:
        position = read_map(page.textures["position"])
        texel_size = read_map(page.textures["unshot"])[..., 3]
        area = position[..., 3]
        coverage = np.zeros_like(area)
        np.divide(area, texel_size ** 2, out=coverage, where=texel_size > 0)
        samples.append({name: in_atlas_layout(state, page, value) for name, value in {
            "position": position[..., :3],
            "normal": decode_normals(read_map(page.textures["normal"])),
            "area": area, "coverage": coverage,
            "occupied": (area > 0) & (read_map(page.textures["material"])[..., 3] > 0)
        }.items()})
    return samples


def ledger(state, energy, gaps, lights_unshot):
    """The Ledger from the maps, the power (W) of each light not yet shot, and the thin gaps'
    totals (thin_gaps.ThinGaps): what their receivers' maps show is not what arrived; what
    arrived was absorbed in the gap, but what left it as unshot light."""
    totals = map_totals(state)
    for power in lights_unshot:
        totals["unshot"] += power
    received = totals["received"] - gaps.shown_received + gaps.arrived
    absorbed = (totals["absorbed"] - gaps.shown_absorbed + gaps.arrived - gaps.escaped
                - energy.reflected_surplus)
    return Ledger(energy.emitted.copy(), absorbed, energy.shot_power - received,
                  totals["unshot"])


def map_totals(state):
    """Sums over every texel of the maps, in double precision: the irradiance received and
    absorbed (W) and the unshot power the texels hold (W)."""
    totals = {key: np.zeros(3) for key in ("absorbed", "received", "unshot")}
    for page in state.pages:
        maps = {name: read_map(page.textures[name])
                for name in ("material", "irradiance", "unshot")}
        area = page.area[..., None].astype(np.float64)
        albedo = maps["material"][..., :3] * (maps["material"][..., 3:4] > 0)
        irradiance = maps["irradiance"][..., :3] * area
        received = irradiance if page.share is None else irradiance * page.share[..., None]
        totals["received"] += received.reshape(-1, 3).sum(axis=0)
        # What the texel reflects into the room is the material map's (its share's).
        totals["absorbed"] += (received - albedo * irradiance).reshape(-1, 3).sum(axis=0)
        totals["unshot"] += math.pi * (maps["unshot"][..., :3] * area).reshape(-1, 3).sum(axis=0)
    return totals


def fill_gutter(image, passes):
    """Gutter fill, ``passes`` rings deep: an empty texel next to filled ones takes their
    mean, so bilinear sampling across chart borders shows no seams; alpha stays 0 there."""
    height, width = image.shape[:2]
    filled = image[..., 3] > 0
    offsets = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    for _ in range(passes):
        padded = np.pad(filled, 1)
        touched = np.zeros_like(filled)
        for dy, dx in offsets:
            touched |= padded[1 + dy:1 + dy + height, 1 + dx:1 + dx + width]
        ys, xs = np.nonzero(touched & ~filled)
        if not len(ys):
            return
        total, count = np.zeros((len(ys), 3)), np.zeros(len(ys))
        for dy, dx in offsets:
            ny, nx = ys + dy, xs + dx
            inside = (ny >= 0) & (ny < height) & (nx >= 0) & (nx < width)
            ny, nx = np.clip(ny, 0, height - 1), np.clip(nx, 0, width - 1)
            use = inside & filled[ny, nx]
            total += image[ny, nx, :3] * use[:, None]
            count += use
        image[ys, xs, :3] = total / count[:, None]
        filled[ys, xs] = True


@dataclass
class Checkpoint:
    """A bake as it stood at a selection (nothing queued), to go back to: per page its maps
    (CHECKPOINT_MAPS) and emission not yet shot, the lights still pending, the energy
    totals, the thin gaps' ledger and the ambient term's starts."""
    unshot_fraction: float
    shots: int
    maps: list
    emission_left: list
    pending: list
    energy: object
    gap_totals: dict
    reflected_starts: list


GAP_TOTALS = ("shown_received", "shown_absorbed", "arrived", "escaped")


def checkpoint(state, energy, gaps, pending, reflected_starts, shots, unshot_fraction):
    """A Checkpoint of the bake now: the maps read back to the CPU, the totals copied."""
    return Checkpoint(
        unshot_fraction=unshot_fraction, shots=shots,
        maps=[{name: page.textures[name].read() for name in CHECKPOINT_MAPS
               if name in page.textures} for page in state.pages],
        emission_left=[(page.emission_left[0], page.emission_left[1].copy())
                       for page in state.pages],
        pending=list(pending), energy=copy.deepcopy(energy),
        gap_totals={name: getattr(gaps, name).copy() for name in GAP_TOTALS},
        reflected_starts=list(reflected_starts))


def restore(state, kept, gaps):
    """Put the maps and the thin gaps' ledger back as ``kept`` holds them; the caller takes
    its energy totals, pending lights and starts."""
    for page, maps in zip(state.pages, kept.maps):
        for name, data in maps.items():
            page.textures[name].write(data)
    for page, left in zip(state.pages, kept.emission_left):
        page.emission_left = (left[0], left[1].copy())
    for name, value in kept.gap_totals.items():
        setattr(gaps, name, value.copy())
