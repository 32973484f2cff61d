"""Postprocess: the lightmaps from the maps (rho * (E / pi + ambient) on receiving texels,
moved back to the atlas's layout, the gutter around charts filled), the ambient term that
stands for the light not yet shot, the energy ledger from sums over the maps, and the texels'
sample points."""
from dataclasses import dataclass
import math

import numpy as np

from .state import decode_normals, in_atlas_layout, read_map

# The ambient term's mean albedo stays under this: two albedos of 1 would bounce for ever.
MAX_MEAN_ALBEDO = 0.999


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


def lightmaps(state, ambient):
    """Per page: rho * (E / pi + ambient) on receiving texels, alpha 1, and the gutter
    filled, on the CPU from the maps it reads anyway (no output maps on the GPU).
    ``ambient(irradiance)`` gives the ambient radiance from the pages' irradiance maps, or
    None to leave it out."""
    # Whole RGBA rows are contiguous (fast); the irradiance's alpha is 0 throughout.
    irradiance = [read_map(page.textures["irradiance"]) for page in state.pages]
    radiance = ambient(irradiance) if ambient is not None else np.zeros(3)
    pages = []
    for page, image in zip(state.pages, irradiance):
        occupied = read_map(page.textures["material"])[..., 3] > 0   # a receiving texel
        image *= np.float32(1.0 / math.pi)
        image += np.append(radiance, 0.0).astype(np.float32)
        image[..., :3] *= page.albedo
        image *= occupied[..., None]
        image[..., 3] = occupied
        image = in_atlas_layout(state, page, image)
        fill_gutter(image, state.settings.padding + 1)
        pages.append(image)
    return pages


def ambient_radiance(state, energy, irradiance, received):
    """The unshot light that has bounced at least once as uniform radiance (Solver.
    ambient_radiance), from the pages' ``irradiance`` maps and their unshot maps;
    ``received`` (W) starts the sum of what was received (the thin gaps' correction)."""
    unshot = np.zeros(3)
    for page, page_irradiance in zip(state.pages, irradiance):
        # Whole RGBA rows times the areas: one product each (an estimate needs no
        # double-precision sums; the ledger's are).
        area = page.area.reshape(-1)
        received = received + (page_irradiance.reshape(-1, 4).T @ area)[:3]
        unshot = unshot + math.pi * (read_map(page.textures["unshot"]).reshape(-1, 4).T
                                     @ area)[:3]
        unshot = unshot - page.emission_left[1].sum(axis=0)   # direct light, unshot
    bounced = np.maximum(unshot, 0.0)
    shot = float(np.mean(energy.shot_power)) - energy.sunlight_missed
    lands = min(float(np.mean(received)) / shot, 1.0) if shot > 0 else 1.0
    area = max(energy.surface_area, 1e-30)
    mean_albedo = np.minimum(energy.albedo_area / area, MAX_MEAN_ALBEDO)
    return lands * bounced / (math.pi * area) / (1.0 - lands * mean_albedo)


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
    totals (thin_gaps.ThinGaps): what their receivers' maps show is not what arrived; all
    that arrived was absorbed in the gap."""
    totals = map_totals(state)
    for power in lights_unshot:
        totals["unshot"] += power
    received = totals["received"] - gaps.shown_received + gaps.arrived
    absorbed = totals["absorbed"] - gaps.shown_absorbed + gaps.arrived
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
        totals["received"] += irradiance.reshape(-1, 3).sum(axis=0)
        totals["absorbed"] += ((1.0 - albedo) * irradiance).reshape(-1, 3).sum(axis=0)
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
