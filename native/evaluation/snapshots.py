"""A bake's lightmaps kept at 1, 2, 4, ... shots and at the end, for speed-against-error
curves: only the occupied texels' RGB, with the bake's own time at each (the time spent
keeping them left out)."""
import time

import numpy as np

from ..gpu import using


class Snapshots:
    def __init__(self, started, per_doubling=1):
        """``started``: time.perf_counter() when the bake began (before the solver's
        creation, or before whatever else the caller counts). ``per_doubling``: snapshots
        per doubling of the shots (2: at 1, 2, 3, 4, 6, 8, 11, 16, ...)."""
        self.started = started
        self.masks = None       # per page: (H, W) bool, the occupied texels
        self.shots = []
        self.seconds = []
        self.rgb = []           # per snapshot, per page: (N, 3) float32 of the occupied texels
        self._paused = 0.0
        self._per_doubling = per_doubling
        self._step = 0
        self._next = 1

    def after_step(self, solver):
        """Call after each step: keeps the lightmaps when the shot count reaches the next of
        1, 2, 4, ... (or the finer schedule)."""
        if solver.shots >= self._next and not solver.finished:
            self.take(solver)
            while self._next <= solver.shots:
                self._step += 1
                self._next = round(2.0 ** (self._step / self._per_doubling))

    def take(self, solver):
        # The GPU finishes the shots queued so far on the bake's clock, not the snapshot's.
        with using(solver.ctx):
            solver.ctx.finish()
        began = time.perf_counter()
        pages = solver.result()
        if self.masks is None:
            self.masks = [page[..., 3] > 0.5 for page in pages]
        self.shots.append(solver.shots)
        self.seconds.append(began - self.started - self._paused)
        self.rgb.append([page[mask][:, :3].copy() for page, mask in zip(pages, self.masks)])
        self._paused += time.perf_counter() - began

    def elapsed(self):
        """The bake's seconds so far, the time spent keeping snapshots left out."""
        return time.perf_counter() - self.started - self._paused

    def page(self, snapshot, page):
        """Snapshot ``snapshot`` of page ``page`` as an (H, W, 4) lightmap, alpha 1 where
        occupied (the gutters are 0)."""
        mask = self.masks[page]
        full = np.zeros(mask.shape + (4,), dtype=np.float32)
        full[mask, :3] = self.rgb[snapshot][page]
        full[mask, 3] = 1.0
        return full
