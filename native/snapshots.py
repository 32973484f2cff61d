"""A bake's lightmaps kept at 1, 2, 4, ... shots and at the end, for speed-against-error
curves: only the occupied texels' RGB, with the bake's own time at each (the time spent
keeping them left out)."""
import time

import numpy as np


class Snapshots:
    def __init__(self, started):
        """``started``: time.perf_counter() when the bake began (before the solver's
        creation, or before whatever else the caller counts)."""
        self.started = started
        self.masks = None       # per page: (H, W) bool, the occupied texels
        self.shots = []
        self.seconds = []
        self.rgb = []           # per snapshot, per page: (N, 3) float32 of the occupied texels
        self._paused = 0.0
        self._next = 1

    def after_step(self, solver):
        """Call after each shot: keeps the lightmaps when the shot count reaches 1, 2, 4, ..."""
        if solver.shots >= self._next and not solver.finished:
            self.take(solver)
            self._next *= 2

    def take(self, solver):
        began = time.perf_counter()
        pages = solver.result()
        if self.masks is None:
            self.masks = [page[..., 3] > 0.5 for page in pages]
        self.shots.append(solver.shots)
        self.seconds.append(began - self.started - self._paused)
        self.rgb.append([page[mask][:, :3].copy() for page, mask in zip(pages, self.masks)])
        self._paused += time.perf_counter() - began

    def page(self, snapshot, page):
        """Snapshot ``snapshot`` of page ``page`` as an (H, W, 4) lightmap, alpha 1 where
        occupied (the gutters are 0)."""
        mask = self.masks[page]
        full = np.zeros(mask.shape + (4,), dtype=np.float32)
        full[mask, :3] = self.rgb[snapshot][page]
        full[mask, 3] = 1.0
        return full
