"""One bake, as the operator and the command line run it: a set-up in stages (export, then the
solver's charting and preprocessing), the shots, then write-back. step() does a little of it
at a time, so that the modal operator shows each stage and takes Esc between the pieces. The
.blend changes only in finish(); release() (Esc) and failures leave it untouched. Whatever
fails is raised as a LuxelError naming what failed, so callers catch that alone.
remove_lightmaps() takes away what bakes added."""
from contextlib import contextmanager
from dataclasses import dataclass
import inspect
import math
import time
from typing import Callable

from ..native import LuxelError, SceneError, SetUpProgress, Solver
from . import display
from .evaluation import RenderEvaluation, differences
from .export import EXPORT_STAGE, export_steps
from .materials import evaluate_materials
from .writeback import lightmap_directory, remove_written, write_back

GPU_FIX = "update the GPU driver or lower the texel density (Render properties > Luxel Lightmaps)"
BUG_FIX = "report it as a bug"
# The progress bar's share for the set-up, the shots fill the rest: which of the two takes
# longer differs from scene to scene, and the bar only has to move forward.
SET_UP_SHARE = 0.2
# What the status bar adds to a stage that Esc cannot cut short.
UNINTERRUPTIBLE = {
    "evaluating the materials with Cycles":
        "Cycles' bakes cannot be interrupted: Esc is taken once they are done",
    "charting": "xatlas cannot be interrupted: Esc is taken once it is done"}


class BakeError(LuxelError):
    """A failure that is not the input's: a GL error from moderngl, a bug."""


@dataclass(frozen=True)
class Stage:
    """One stage of a bake's set-up. ``run`` does it in one call, or is a generator function
    that does it in pieces and yields a SetUpProgress (what comes next, the share of the
    stage done) after each piece but the last."""
    name: str           # what it does, in the status bar and in a failure's message
    fix: str            # the fix a failure names where the input is not to blame
    run: Callable


class BakeJob:
    def __init__(self, context):
        """A bake of the context's scene, its set-up not begun: step() does it. Only the scene,
        its settings and the evaluated depsgraph are taken from ``context``, now."""
        self.scene = context.scene
        self.started = time.perf_counter()
        self.settings = self.scene.luxel.solver_settings()
        self.warnings = []
        self.export = None
        self.solver = None
        self._warned = 0
        # The export and the materials read the render's evaluation (evaluation.py).
        self._render_evaluation = RenderEvaluation(self.scene)
        self._differences = {obj.name: differences(obj) for obj in self.scene.objects}
        self._render_evaluation.apply()
        try:
            self.depsgraph = context.evaluated_depsgraph_get()
            self._exporting = export_steps(context, self.depsgraph)
        except BaseException:
            self._render_evaluation.restore()
            raise
        # The set-up, in order: a stage more is a line more.
        self.stages = (
            Stage(EXPORT_STAGE, BUG_FIX, self._export),
            Stage("evaluating the materials with Cycles", BUG_FIX, self._evaluate_materials),
            Stage("opening OpenGL", GPU_FIX, self._start_solver),
        )
        self.set_up_progress = SetUpProgress(stage=self.stages[0].name, fraction=0.0)
        self._set_up_pieces = self._set_up()

    @property
    def is_set_up(self):
        return self._set_up_pieces is None

    @property
    def reading_the_scene(self):
        """Whether the export still reads the scene (an edit now would change it midway)."""
        return self.export is None and not self.is_set_up

    def step(self, seconds=0.1):
        """Work for about ``seconds``, a piece or a shot at least: the set-up's next pieces,
        then shots. True when the bake has converged or hit max shots. A piece cannot be cut
        short (the charting is one call to xatlas), and a step ends where a stage ends (the last
        one too), so that the status names each stage before it runs."""
        deadline = time.perf_counter() + seconds
        stage = self.set_up_progress.stage
        while not self.is_set_up:
            self._set_up_step()
            if (self.is_set_up or self.set_up_progress.stage != stage
                    or time.perf_counter() >= deadline):
                return False
        with _failures_named("the GPU solver", GPU_FIX):
            while self.solver.step() and time.perf_counter() < deadline:
                pass
        return self.solver.progress.finished

    def set_up(self):
        """The whole set-up in one call (scripts, and what runs the shots itself)."""
        while not self.is_set_up:
            self._set_up_step()

    def new_warnings(self):
        """The warnings found since the last call, to report as they come."""
        fresh = self.warnings[self._warned:]
        self._warned = len(self.warnings)
        return fresh

    def fraction(self):
        """0..1 for a progress bar: the set-up, then the shots. Unshot energy falls
        geometrically, so the shots' part is on a log scale."""
        if not self.is_set_up:
            return SET_UP_SHARE * self.set_up_progress.fraction
        progress = self.solver.progress
        settings = self.solver.settings
        if progress.finished:
            return 1.0
        by_shots = progress.shots / max(progress.shot_limit, 1)
        by_energy = 0.0
        if progress.unshot_fraction < 1.0 and settings.threshold > 0.0:
            by_energy = math.log(max(progress.unshot_fraction, 1e-12)) / math.log(
                settings.threshold)
        shots = min(max(by_shots, by_energy, 0.0), 0.999)
        return SET_UP_SHARE + (1.0 - SET_UP_SHARE) * shots

    def status(self, *, takes_esc=False):
        """What the bake does now, for the status bar or a log line (its caller names Luxel);
        ``takes_esc``: say where Esc waits for a stage to end."""
        if not self.is_set_up:
            stage = self.set_up_progress.stage
            note = f" ({UNINTERRUPTIBLE[stage]})" if takes_esc and stage in UNINTERRUPTIBLE else ""
            return f"{stage}{note}, set-up {100.0 * self.set_up_progress.fraction:.0f} % done"
        progress = self.solver.progress
        return (f"{progress.shots:,} of {progress.shot_limit:,} shots, "
                f"{100.0 * progress.unshot_fraction:.2f} % unshot, "
                f"{self.solver.texel_count:,} texels")

    def finish(self):
        """Write the lightmaps, UV maps and stats into the .blend and free the GPU."""
        try:
            with _failures_named("reading the lightmaps from the GPU", GPU_FIX):
                pages = self.solver.result()
                irradiance = self.solver.result(reflected=False)
            progress = self.solver.progress
            with _failures_named("writing the lightmaps", BUG_FIX):
                images = write_back(self.scene, self.export, self.solver.atlas, pages,
                                    irradiance)
            settings = self.scene.luxel
            settings["material_emission"] = {name: list(value) for name, value in
                                             self.export.emission_of_material.items()}
            stats = settings.stats
            stats.texels = self.solver.texel_count
            stats.shots = progress.shots
            stats.unshot = 100.0 * progress.unshot_fraction
            stats.stopped_at_shot_limit = progress.stopped_at_shot_limit
            stats.diverged = progress.diverged
            stats.pages = len(images)
            stats.seconds = time.perf_counter() - self.started
            stats.valid = True
            display.refresh(self.scene)
            return images
        finally:
            self.release()

    def release(self):
        """Free the GPU and drop the set-up where it stands: the .blend is as it was."""
        self._render_evaluation.restore()
        if self._set_up_pieces is not None:
            self._set_up_pieces.close()
            self._set_up_pieces = None
        if self.solver is not None:
            self.solver.release()

    # ------------------------------------------------------------------ the set-up
    def _set_up_step(self):
        following = next(self._set_up_pieces, None)
        if following is None:
            self._set_up_pieces = None
            following = SetUpProgress(stage=self.set_up_progress.stage, fraction=1.0)
        self.set_up_progress = following

    def _set_up(self):
        """The stages' pieces, one per next(); after each but the last, the progress naming
        the next, with the share of the whole set-up done."""
        for index, stage in enumerate(self.stages):
            if index:   # named before its first piece runs
                yield SetUpProgress(stage=stage.name, fraction=index / len(self.stages))
            with _failures_named(stage.name, stage.fix):
                pieces = stage.run()
                if inspect.isgenerator(pieces):
                    for progress in pieces:
                        yield SetUpProgress(stage=progress.stage, fraction=(
                            index + progress.fraction) / len(self.stages))

    def _export(self):
        self.export = yield from self._exporting
        # The later stages (materials, charting) add theirs to the export's, as it reports them.
        self.warnings = self.export.warnings
        if not self.export.receivers:
            raise SceneError("no object gets a lightmap: enable 'Receive Lightmap' on a "
                             "visible mesh (Object properties > Luxel)")
        if self.scene.luxel.output == 'FILES':
            lightmap_directory(self.scene)      # refused now rather than after the bake
        for name in sorted({receiver.object_name for receiver in self.export.receivers}):
            found = self._differences.get(name)
            if found:
                self.warnings.append(
                    f"'{name}' evaluates otherwise in the viewport and in renders "
                    f"({'; '.join(found)}): the bake fits the render's, and where the viewport "
                    "differs it shows the lightmap black; set the viewport's settings as the "
                    "render's to see it there")

    def _evaluate_materials(self):
        try:
            evaluate_materials(self.depsgraph, self.export, self.settings)
        finally:
            self._render_evaluation.restore()

    def _start_solver(self):
        """The solver's own set-up (charting, then preprocessing), a piece at a time."""
        self.solver = Solver(self.export.scene, self.settings, staged=True)
        yield self.solver.set_up_progress       # the charting, named before it runs
        while self.solver.set_up_step():
            yield self.solver.set_up_progress
        for name in sorted({self.export.scene.object_name(triangle)
                            for triangle in self.solver.atlas.unpacked}):
            self.warnings.append(f"'{name}': some triangles are too small to chart at "
                                 "this texel density: they cast shadows but get no "
                                 "lightmap; scale them up or raise the density")
        for index in self.solver.atlas.shrunk:
            self.warnings.append(
                f"'{self.export.scene.object_names[index]}' is too large for one lightmap "
                "image at this texel density and was baked coarser: raise Max Image Size "
                "or lower its Resolution Scale (Object properties > Luxel)")


def remove_lightmaps(scene):
    """Take away everything Luxel's bakes added to ``scene`` and the file: the shown nodes,
    what write_back wrote, and the stats and materials' emission that finish() kept, so that
    the file is as before the first bake."""
    display.hide_baked_lighting(scene)
    scene.luxel.show_baked = False
    remove_written(scene)
    scene.luxel.property_unset("stats")
    scene.luxel.pop("material_emission", None)


def shot_limit_message(stats, threshold):
    """What a bake that stopped at max shots says, before the fix (None when it reached the
    threshold)."""
    if not (stats.valid and stats.stopped_at_shot_limit):
        return None
    return (f"Luxel stopped at the shot limit ({stats.shots:,} shots) with "
            f"{stats.unshot:.2f} % unshot, above the threshold of {100.0 * threshold:.2f} %")


def divergence_message(stats):
    """What a bake that stopped because its unshot power rose says (None otherwise)."""
    if not (stats.valid and stats.diverged):
        return None
    return (f"Luxel's shots made light after {stats.shots:,} shots (the unshot power rose): "
            f"the bake stopped and kept the lightmaps from {stats.unshot:.2f} % unshot; "
            "please report the scene")


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
