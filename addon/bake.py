"""One bake, as the operator and the command line run it: export, solve step by step, write
back. The .blend changes only in finish(); cancel() and failures leave it untouched. Whatever
fails is raised as a LuxelError naming what failed, so callers catch that alone."""
from contextlib import contextmanager
import math
import time

from ..native import LuxelError, SceneError, Solver
from . import display
from .export import export_scene
from .materials import evaluate_materials
from .writeback import lightmap_directory, write_back

GPU_FIX = "update the GPU driver or lower the texel density (Render properties > Luxel Lightmaps)"
BUG_FIX = "report it as a bug"


class BakeError(LuxelError):
    """A failure that is not the input's: a GL error from moderngl, a bug."""


class BakeJob:
    def __init__(self, context):
        self.scene = context.scene
        self.started = time.perf_counter()
        with _failures_named("exporting the scene", BUG_FIX):
            self.export = export_scene(context)
        if not self.export.receivers:
            raise SceneError("no object gets a lightmap: enable 'Receive Lightmap' on a "
                             "visible mesh (Object properties > Luxel)")
        if self.scene.luxel.output == 'FILES':
            lightmap_directory(self.scene)      # refused now rather than after the bake
        settings = self.scene.luxel.solver_settings()
        with _failures_named("evaluating the materials with Cycles", BUG_FIX):
            evaluate_materials(context, self.export, settings)
        with _failures_named("starting the GPU solver", GPU_FIX):
            self.solver = Solver(self.export.scene, settings)
        for name in sorted({self.export.scene.object_name(triangle)
                            for triangle in self.solver.atlas.unpacked}):
            self.export.warnings.append(f"'{name}': some triangles are too small to chart at "
                                        "this texel density: they cast shadows but get no "
                                        "lightmap; scale them up or raise the density")
        for index in self.solver.atlas.shrunk:
            self.export.warnings.append(
                f"'{self.export.scene.object_names[index]}' is too large for one lightmap "
                "image at this texel density and was baked coarser: raise Max Image Size "
                "or lower its Resolution Scale (Object properties > Luxel)")

    @property
    def warnings(self):
        return self.export.warnings

    def step(self, seconds=0.1):
        """Shoot for about ``seconds``; True when the bake has converged or hit max shots."""
        deadline = time.perf_counter() + seconds
        with _failures_named("the GPU solver", GPU_FIX):
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
            with _failures_named("reading the lightmaps from the GPU", GPU_FIX):
                pages = self.solver.result()
            progress = self.solver.progress
            with _failures_named("writing the lightmaps", BUG_FIX):
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


@contextmanager
def _failures_named(what, fix):
    """Luxel's own errors already name the object and the fix; any other becomes a BakeError
    naming what failed."""
    try:
        yield
    except LuxelError:
        raise
    except Exception as error:
        raise BakeError(f"{what} failed ({type(error).__name__}: {error}); the file was left "
                        f"as it was. Bake again; if it fails again, {fix}") from error

