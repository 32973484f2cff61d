"""Every bake setting, declared once: its type, default, range, unit and help.

The solver's ``Settings`` and ``Settings.validate()``, the Blender properties
(addon/properties.py) and the command-line options (addon/cli.py, ``python -m native``) are
all made from ``SETTINGS``, so that they cannot disagree; tests/test_settings.py and
tests/test_blender_addon.py check that they do not. Ranges include their ends, since Blender's
properties can hold no other kind.
"""
import argparse
from dataclasses import dataclass, make_dataclass
import math

import numpy as np

from .errors import SettingsError


@dataclass(frozen=True)
class Choice:
    """One of the names a setting of kind str takes."""
    identifier: str
    label: str
    help: str


@dataclass(frozen=True)
class Exposed:
    """How Blender (``scene.luxel``) and the command line offer a setting."""
    label: str
    option: str | None         # the command-line flag; None where a SettingPair's sets it
    trades: str                # what it buys and what it costs, for README's settings table
    subtype: str = 'NONE'      # how Blender draws it: 'FACTOR' a 0-1 slider, 'PIXEL' in px
    digits: int | None = None  # decimals Blender shows, where its 2 or 3 hide the value


@dataclass(frozen=True)
class Setting:
    """One of the solver's settings: a field of Settings, and where exposed a Blender
    property and a command-line option."""
    name: str
    kind: type                      # bool, int, float, or str: one of ``choices``
    default: object
    help: str                       # Blender's tooltip, and the option's --help
    unit: str = ""                  # after a number, in words: "texels per metre"
    minimum: float | None = None    # None: no limit
    maximum: float | None = None
    soft_maximum: float | None = None  # the top of Blender's slider: a hint, not a limit
    choices: tuple = ()             # of Choice
    exposed: Exposed | None = None  # None: the solver's own (tests, benchmarks)
    automatic: int | None = None    # a value outside the range asking the solver to choose

    @property
    def lowest(self):
        """The least value the setting takes (Blender's property minimum)."""
        if self.automatic is None or self.minimum is None:
            return self.minimum
        return min(self.automatic, self.minimum)

    @property
    def identifiers(self):
        return tuple(choice.identifier for choice in self.choices)

    @property
    def allowed(self):
        """The values the setting takes, in words ("" when any of its kind will do)."""
        unit = f" {self.unit}" if self.unit else ""
        if self.automatic is not None:
            return f"{self.automatic} (automatic) or {self._range(unit)}"
        return self._range(unit)

    def _range(self, unit):
        if self.choices:
            return f"one of {', '.join(self.identifiers)}"
        if self.minimum is not None and self.maximum is not None:
            return f"from {self.minimum:g} to {self.maximum:g}{unit}"
        if self.minimum is not None:
            return f"at least {self.minimum:g}{unit}"
        if self.maximum is not None:
            return f"at most {self.maximum:g}{unit}"
        return ""

    def problem(self, value):
        """What is wrong with ``value`` for this setting, or None."""
        if self.automatic is not None and value == self.automatic:
            return None
        if self.kind is float and not math.isfinite(value):
            return f"must be a finite number, got {_shown(value)}"
        low, high, given = self.minimum, self.maximum, value
        if self.kind is float:
            # Blender keeps a FloatProperty in single precision: a slider at 0.01 hands over
            # 0.0099999998. Bounds and value compare as Blender holds them.
            low, high, given = (None if x is None else float(np.float32(x))
                                for x in (low, high, given))
        fits = (value in self.identifiers if self.choices else
                (low is None or given >= low) and (high is None or given <= high))
        return None if fits else f"must be {self.allowed}, got {_shown(value)}"


def _shown(value):
    """A value as a message quotes it: names in quotes, numbers as they print."""
    return repr(value) if isinstance(value, str) else str(value)


@dataclass(frozen=True)
class SettingPair:
    """Two settings bounding an interval: the lower must stay below the upper. One
    command-line option sets both."""
    lower: str
    upper: str
    option: str
    help: str

    def problem(self, lower, upper):
        return None if lower < upper else (f"{self.lower} must be below {self.upper}, "
                                           f"got {lower} and {upper}")


PROJECTION_CHOICES = (
    Choice(identifier="HEMICUBE", label="Hemicube",
           help="Five rasterised faces around each shooter (the paper's baseline)"),
    Choice(identifier="HEMISPHERE", label="Hemisphere",
           help="Stereographic projection per vertex: one render, straight edges stay "
           "straight"),
    Choice(identifier="NONLINEAR", label="Non-Linear",
           help="Non-linear hemisphere projection (Gascuel et al. 2008): exact spherical "
           "triangles in one render"),
)
SUBDIVISION_CHOICES = (
    Choice(identifier="NONE", label="None", help="Each texel gathers light at its centre"),
    Choice(identifier="ADAPTIVE", label="Adaptive",
           help="Refine triangles partly in shadow, and the triangles casting the shadow: "
           "sharper shadow edges for less work than Regular"),
    Choice(identifier="REGULAR", label="Regular",
           help="Refine every triangle: each texel gathers light at 4^level points"),
)
VISIBILITY_DRAW_CHOICES = (
    Choice(identifier="AUTO", label="Automatic",
           help="Per face on llvmpipe, one geometry-shader pass elsewhere"),
    Choice(identifier="GEOMETRY_SHADER", label="Geometry Shader",
           help="Every face in one pass: a geometry shader sends each triangle to the faces "
           "it reaches"),
    Choice(identifier="PER_FACE", label="Per Face",
           help="One draw per face of the clusters of triangles that can reach it; needs "
           "GL_ARB_shader_viewport_layer_array"),
)
PROJECTIONS = tuple(choice.identifier for choice in PROJECTION_CHOICES)
SUBDIVISIONS = tuple(choice.identifier for choice in SUBDIVISION_CHOICES)
MAX_SUBDIVISION_LEVEL = 3
# Max Shots 0 stops a bake at this many shots per block of 4^shoot_level texels, at least
# AUTOMATIC_MIN_SHOTS: measured when the blocks were what shot (`python bench/scaling.py
# shot-limit`, BENCHMARKS.md); the patches that shoot now hold as many blocks or more, so the
# limit only grows looser.
AUTOMATIC_SHOTS_PER_BLOCK = 20
AUTOMATIC_MIN_SHOTS = 10000
MAX_SHOOT_LEVEL = 6

# Settings has its fields in this order (and report.json its settings).
SETTINGS = (
    Setting(name="texel_density", kind=float, default=20.0, unit="texels per metre",
            minimum=0.01, soft_maximum=1000.0,
            help="Lightmap texels per metre of surface. Each texel takes about 86 bytes of GPU "
            "memory (at 20: 34 kB per square metre); doubling it makes four times the texels "
            "and 2.8 to 4.2 times the time to the threshold (Cornell box, 60 to 240 texels "
            "per metre)",
            exposed=Exposed(label="Texel Density", option="--density",
                            trades="Finer light and shadow detail against time and GPU memory: "
                                   "each doubling makes 4x the texels")),
    Setting(name="max_atlas_size", kind=int, default=4096, unit="texels", minimum=16,
            soft_maximum=16384, help="Largest lightmap side; more images when exceeded",
            exposed=Exposed(label="Max Image Size", option="--max-image-size",
                            trades="Fewer, larger images against what the target engine or GPU "
                                   "can load",
                            subtype='PIXEL')),
    Setting(name="padding", kind=int, default=2, unit="texels", minimum=1,
            help="Texels between charts"),
    # 0: preprocess.hemicube_resolution() picks it from the texel density and the scene.
    Setting(name="hemicube_resolution", kind=int, default=0, unit="texels", minimum=8,
            maximum=4096, automatic=0, help="Texels on a side of each hemicube face; the "
            "hemisphere projections' maps are twice as wide. 0 (automatic): the least power "
            "of two at which a face texel half the scene's diagonal away spans no more than a "
            "lightmap texel nor 10 cm (2 x that distance x the larger of the texel density and "
            "10 per metre), from 128 to 512 (map 0.4 to 6.3 MB). Cornell box at 160 texels per "
            "metre: 256, relative RMS against Cycles 1.3 % instead of 1.7 % at 128, the bake "
            "1.0 to 1.1 times as long; an office at 4 texels per metre: 256, its furniture 1.8 % "
            "bright against Cycles instead of 4.5 % at 128",
            exposed=Exposed(label="Hemicube Resolution", option="--hemicube",
                            trades="Small occluders' shadows resolved against time and map "
                                   "memory; 0 picks it from the density and the scene's size",
                            subtype='PIXEL')),
    Setting(name="shoot_level", kind=int, default=2, minimum=0, maximum=MAX_SHOOT_LEVEL,
            help="The finest mip level shot from: a shooter spans at least 2^level texels",
            exposed=Exposed(label="Shoot Level", option="--shoot-level",
                            trades="Lower: finer shooters, smoother penumbrae near lights, "
                                   "against more shots")),
    # Shots then follow the scene's light and geometry, not how finely texels sample it.
    Setting(name="patch_size", kind=float, default=0.0, unit="metres", minimum=0.0,
            maximum=1000.0, soft_maximum=10.0, help="Side of the patches that shoot (blocks of texels whose "
            "side is nearest it, no finer than Shoot Level's); 0 sizes them from the scene's "
            "surface area: the Cornell box at 160 texels per metre takes 2,862 shots instead of "
            "8,504 with 4 x 4 texel patches, for the same error",
            exposed=Exposed(label="Patch Size", option="--patch-size",
                            trades="Smaller: more accurate light near surfaces against more "
                                   "shots; 0 sizes the patches from the scene's area",
                            digits=3)),
    Setting(name="threshold", kind=float, default=0.01, minimum=0.0, maximum=0.99,
            help="Stop when this fraction of the emitted power is left unshot (sunlight that "
            "misses the scene does not count). At 0.01 the Cornell box at 160 texels per "
            "metre takes 2,686 shots, relative RMS error against Cycles 1.3 %, objects' means "
            "within 1 %; at 0.003, 3,638 shots, twice the time, 0.95 %, within 0.6 %",
            exposed=Exposed(label="Threshold", option="--threshold",
                            trades="Lower: closer to the converged light against more shots and "
                                   "time",
                            subtype='FACTOR', digits=4)),
    # 0 scales the limit with the scene (shot_limit): shots to converge grow with its blocks.
    Setting(name="max_shots", kind=int, default=0, unit="shots", minimum=1, maximum=2**31 - 1,
            automatic=0,
            help="Stop after this many shots even above the threshold; 0: automatic, "
            f"{AUTOMATIC_SHOTS_PER_BLOCK} per shooting block of texels, at least "
            f"{AUTOMATIC_MIN_SHOTS} (a fixed 10,000 stopped the sample interior at 20 texels "
            "per metre at 1.15 % unshot)",
            exposed=Exposed(label="Max Shots", option="--shots",
                            trades="A bound on a bake's time against stopping above the "
                                   "threshold; 0 scales it with the scene")),
    Setting(name="memory_limit", kind=int, default=4 << 30, unit="bytes", minimum=1,
            help="GPU memory Luxel may use"),
    Setting(name="sky_directions", kind=int, default=256, unit="suns", minimum=1,
            maximum=65536, help="Suns that stand in for a uniform sky (the world colour)"),
    Setting(name="projection", kind=str, default="HEMICUBE", choices=PROJECTION_CHOICES,
            help="How visibility is sampled around each shooter",
            exposed=Exposed(label="Projection", option="--projection",
                            trades="Hemicube: the paper's baseline, lights shot in "
                                   "quarters of a patch; Non-Linear: exact spherical "
                                   "triangles, lights in sixteenths, smoother penumbrae, "
                                   "slower on a CPU; Hemisphere: straight edges where arcs "
                                   "should be, least exact")),
    # llvmpipe runs geometry shaders on the calling thread (docs/benchmarks-log.md, "All four
    # scenes at equal error"); the hemisphere projections draw with their own geometry shaders.
    Setting(name="visibility_draw", kind=str, default="AUTO", choices=VISIBILITY_DRAW_CHOICES,
            help="How the hemicube's and the lights' cube faces are drawn"),
    # Section 5.2 of the paper.
    Setting(name="neighbour_visibility", kind=bool, default=True,
            help="A receiver whose visibility texel an occluder within a map texel of it "
            "covers (a silhouette it stands at) gets the share of the 3x3 texels around that "
            "see it, against dark speckles where the map undersamples; shadows cast from "
            "farther keep their edges, and under an overhang (a roof over a wall's top) only "
            "texels that see the receiver's side of its plane count. Parts touching a floor "
            "in a furnace, hemicube 64: worst texel 14 % off instead of 18 %",
            exposed=Exposed(label="Neighbour Visibility", option="--neighbour-visibility",
                            trades="Fewer dark speckles at silhouettes against more map reads per "
                                   "shadowed receiver")),
    # ADAPTIVE finds each triangle's shadowed share of texels with occlusion queries, and
    # refines the triangles casting those shadows too.
    Setting(name="subdivision", kind=str, default="NONE", choices=SUBDIVISION_CHOICES,
            help="Where texels gather light at several points. Adaptive took 5.7 times as long "
            "on the Cornell box at 160 texels per metre for the same error: it pays where "
            "shadow edges are finer than the texels",
            exposed=Exposed(label="Subdivision", option="--subdivision",
                            trades="Shadow edges finer than a texel against several times the "
                                   "time")),
    # Level 0 gathers at the texel's centre, as NONE does (the paper's Table 2 has NONE at 0).
    Setting(name="subdivision_level", kind=int, default=2, minimum=0,
            maximum=MAX_SUBDIVISION_LEVEL, help="A texel at level k gathers light at 4^k points",
            exposed=Exposed(label="Subdivision Level", option="--subdivision-level",
                            trades="4^level points per refined texel: smoother shadow edges "
                                   "against time")),
    Setting(name="subdivision_shadow_min", kind=float, default=0.02, minimum=0.0, maximum=1.0,
            help="Adaptive refines a triangle when at least this share of its texels is in "
            "shadow",
            exposed=Exposed(label="Shadow Min", option=None,
                            trades="With Shadow Max, which triangles Adaptive refines: a wider "
                                   "range refines more, for more time",
                            subtype='FACTOR')),
    Setting(name="subdivision_shadow_max", kind=float, default=0.98, minimum=0.0, maximum=1.0,
            help="Adaptive refines a triangle when at most this share of its texels is in "
            "shadow",
            exposed=Exposed(label="Shadow Max", option=None,
                            trades="With Shadow Min, which triangles Adaptive refines: a wider "
                                   "range refines more, for more time",
                            subtype='FACTOR')),
    # The paper's future work (Section 5.1).
    Setting(name="adaptive_shoot_level", kind=bool, default=False,
            help="Shooters with little unshot energy shoot from coarser blocks of texels: "
            "fewer, larger shots",
            exposed=Exposed(label="Adaptive Shoot Level", option="--adaptive-shoot-level",
                            trades="Fewer, larger shots from weak shooters: faster, coarser "
                                   "indirect light")),
    Setting(name="shooters_per_selection", kind=int, default=8, unit="shots", minimum=1,
            maximum=64, help="Shots per GPU read-back; 1 is the paper's one by one"),
    # memory.receiver_batch: not with a hemisphere projection or adaptive subdivision.
    Setting(name="batched_receivers", kind=bool, default=True,
            help="The receiver pass gathers the shooters of a selection (up to 8) in one pass "
            "over the texels, against a hemicube each: one read of each texel's maps and one "
            "blend for the batch"),
    # result() adds it; the ledger and the unshot fraction leave it out.
    Setting(name="ambient", kind=bool, default=True,
            help="Add the light still unshot after its first bounce as even light where the "
            "reflected shots reach (an estimate of the unshot share it stands for): a closed "
            "room of albedo 0.99 within 1 % after 600 shots instead of thousands; an open "
            "floor and a sealed room stay within 1 % of their truth; the Cornell box at 1 % "
            "unshot has every object within 1 % of Cycles with it, 0.6 to 4 % dark "
            "without. Costs a read of the maps each time the unshot fraction halves and two "
            "floats per texel on the CPU",
            exposed=Exposed(label="Ambient Term", option="--ambient",
                            trades="Near-final brightness long before convergence against a read "
                                   "of the maps each time the unshot share halves")),
    Setting(name="profile", kind=bool, default=False,
            help="Wait for the GPU after each phase for exact timings"),
)
SETTING_PAIRS = (
    SettingPair(lower="subdivision_shadow_min", upper="subdivision_shadow_max",
                option="--shadow-range", help="Adaptive refines the triangles whose shadowed "
                "share of texels is in [MIN, MAX]"),
)
EXPOSED_SETTINGS = tuple(setting for setting in SETTINGS if setting.exposed)
SETTINGS_BY_NAME = {setting.name: setting for setting in SETTINGS}


def shot_limit(settings, texels):
    """The shots a bake of ``texels`` occupied texels stops at: max_shots, or where that is 0
    the automatic limit."""
    if settings.max_shots:
        return settings.max_shots
    blocks = texels / (1 << settings.shoot_level) ** 2
    return max(AUTOMATIC_MIN_SHOTS, math.ceil(AUTOMATIC_SHOTS_PER_BLOCK * blocks))


def _validate(settings):
    """Raise SettingsError naming the first setting out of its range."""
    for setting in SETTINGS:
        problem = setting.problem(getattr(settings, setting.name))
        if problem:
            raise SettingsError(f"{setting.name} {problem}")
    for pair in SETTING_PAIRS:
        problem = pair.problem(getattr(settings, pair.lower), getattr(settings, pair.upper))
        if problem:
            raise SettingsError(problem)


Settings = make_dataclass(
    "Settings", [(setting.name, setting.kind, setting.default) for setting in SETTINGS],
    namespace={"validate": _validate, "__module__": __name__,   # for pickle and repr
               "__doc__": "The solver's settings, one field per entry of "
               "native.settings.SETTINGS (its help, unit and range)."})


# ---------------------------------------------------------------------- command line
class _CheckedValue(argparse.Action):
    """Stores an option's value once its setting's declaration accepts it."""

    def __init__(self, option_strings, dest, setting, **kwargs):
        super().__init__(option_strings, dest, **kwargs)
        self.setting = setting

    def __call__(self, parser, namespace, value, option_string=None):
        problem = self.setting.problem(value)
        if problem:
            raise argparse.ArgumentError(self, problem)
        setattr(namespace, self.dest, value)


class _CheckedPair(argparse.Action):
    """Stores MIN and MAX into a SettingPair's two settings, each checked and in order."""

    def __init__(self, option_strings, dest, pair, **kwargs):
        super().__init__(option_strings, dest, **kwargs)
        self.pair = pair

    def __call__(self, parser, namespace, values, option_string=None):
        for name, value in zip((self.pair.lower, self.pair.upper), values):
            problem = SETTINGS_BY_NAME[name].problem(value)
            if problem:
                raise argparse.ArgumentError(self, f"{name} {problem}")
        problem = self.pair.problem(*values)
        if problem:
            raise argparse.ArgumentError(self, problem)
        setattr(namespace, self.pair.lower, values[0])
        setattr(namespace, self.pair.upper, values[1])


# --help's placeholder for a number; a name's option lists its choices instead.
_METAVARS = {int: "N", float: "X"}


def _option_help(what, allowed, default):
    """--help's line: what the option does, its range and, where there is one, its default;
    a percent sign doubled, since argparse formats the line with %."""
    parts = [what, allowed] + ([] if default is None else [f"default {default}"])
    return "; ".join(part for part in parts if part).replace("%", "%%")


def add_options(parser, defaults=None):
    """An option on ``parser`` for every exposed setting, checked against its declaration as
    it is parsed; the values land under the settings' names. ``defaults`` (a Settings) is
    what an option left out parses to, named in the help; without it, None."""
    def default_of(name):
        return None if defaults is None else getattr(defaults, name)

    for setting in EXPOSED_SETTINGS:
        option, default = setting.exposed.option, default_of(setting.name)
        line = _option_help(setting.help, setting.allowed, default)
        if option is None:   # a SettingPair's option sets it
            parser.set_defaults(**{setting.name: default})
        elif setting.kind is bool:   # --ambient and --no-ambient, whatever the default
            parser.add_argument(option, dest=setting.name, default=default, help=line,
                                action=argparse.BooleanOptionalAction)
        else:
            parser.add_argument(option, dest=setting.name, default=default, help=line,
                                type=setting.kind, choices=setting.identifiers or None,
                                metavar=_METAVARS.get(setting.kind), action=_CheckedValue,
                                setting=setting)
    for pair in SETTING_PAIRS:
        lower = SETTINGS_BY_NAME[pair.lower]
        defaults_shown = (None if defaults is None else
                          f"{default_of(pair.lower)} {default_of(pair.upper)}")
        parser.add_argument(pair.option, nargs=2, type=lower.kind, metavar=("MIN", "MAX"),
                            default=argparse.SUPPRESS, action=_CheckedPair, pair=pair,
                            help=_option_help(pair.help, f"each {lower.allowed}, MIN below "
                                              "MAX", defaults_shown))


def given_settings(args):
    """{name: value} of the settings an ``add_options`` parse holds, those left out (None)
    left out."""
    values = {setting.name: getattr(args, setting.name) for setting in EXPOSED_SETTINGS}
    return {name: value for name, value in values.items() if value is not None}
