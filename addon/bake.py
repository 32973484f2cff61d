"""One bake, as the operator and the command line run it: export, solve step by step, write
back. The .blend changes only in finish(); cancel() and failures leave it untouched."""
import math
import time

from ..native import SceneError, Solver
from . import display
from .export import export_scene
from .writeback import write_back


class BakeJob:
    def __init__(self, context):
        self.scene = context.scene
        self.started = time.perf_counter()
        self.export = export_scene(context)
        if not self.export.receivers:
            raise SceneError("no object gets a lightmap: enable 'Receive Lightmap' on a "
                             "visible mesh (Object properties > Luxel)")
        self.solver = Solver(self.export.scene, self.scene.luxel.solver_settings())

    @property
    def warnings(self):
        return self.export.warnings

    def step(self, seconds=0.1):
        """Shoot for about ``seconds``; True when the bake has converged or hit max shots."""
        deadline = time.perf_counter() + seconds
        while not self.solver.progress.finished and time.perf_counter() < deadline:
            self.solver.step()
        return self.solver.progress.finished

    def fraction(self):
        """0..1 for a progress bar: unshot energy falls geometrically, so on a log scale."""
        progress = self.solver.progress
        settings = self.solver.settings
        if progress.finished:
            return 1.0
        by_shots = progress.shots / max(settings.max_shots, 1)
        by_energy = 0.0
        if progress.unshot_fraction < 1.0 and settings.threshold > 0.0:
            by_energy = math.log(max(progress.unshot_fraction, 1e-12)) / math.log(
                settings.threshold)
        return min(max(by_shots, by_energy, 0.0), 0.999)

    def status(self):
        progress = self.solver.progress
        return (f"Luxel: {progress.shots} shots, {100.0 * progress.unshot_fraction:.2f} % "
                f"unshot, {self.solver.texel_count:,} texels")

    def finish(self):
        """Write the lightmaps, UV maps and stats into the .blend and free the GPU."""
        try:
            pages = self.solver.result()
            progress = self.solver.progress
            images = write_back(self.scene, self.export, self.solver.atlas, pages)
            settings = self.scene.luxel
            settings["material_emission"] = {name: list(value) for name, value in
                                             self.export.emission_of_material.items()}
            stats = settings.stats
            stats.texels = self.solver.texel_count
            stats.shots = progress.shots
            stats.unshot = 100.0 * progress.unshot_fraction
            stats.pages = len(images)
            stats.seconds = time.perf_counter() - self.started
            stats.valid = True
            display.refresh(self.scene)
            return images
        finally:
            self.release()

    def release(self):
        self.solver.release()
