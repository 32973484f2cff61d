"""Scene description handed to the solver: plain numpy arrays, validated on construction."""
from dataclasses import asdict, dataclass, field, fields
import json
import math

import numpy as np

from .errors import SceneError

UV_TOLERANCE = 1e-6     # a lightmap UV this far outside [0, 1] is still inside


def triangle_areas(corners):
    """Areas of (T, 3, 3) corner triangles and which are degenerate (zero area): at most 1e-7
    of their longest edge squared. Scene refuses those; the extension skips them."""
    doubled = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    area = 0.5 * np.linalg.norm(doubled, axis=1)
    edge = np.max(np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2), axis=1)
    return area, area <= 1e-7 * np.maximum(edge, 1e-30) ** 2


def _vec3(value, name):
    array = np.asarray(value, dtype=np.float64).reshape(-1)
    if array.shape != (3,):
        raise SceneError(f"{name} must have 3 components, got {array.shape[0]}")
    return array


@dataclass
class PointLight:
    """Blender point light of ``power`` watts: intensity power * color / (4 pi) W/sr."""
    position: tuple
    power: float
    color: tuple = (1.0, 1.0, 1.0)
    name: str = "Point"

    def intensity(self):
        return self.power * _vec3(self.color, "color") / (4.0 * math.pi)

    def emitted_power(self):
        return self.power * _vec3(self.color, "color")


@dataclass
class SpotLight(PointLight):
    """Blender spot light: a point light's intensity cut to a cone of full angle ``spot_size``
    (radians) around ``direction`` with Blender's ``spot_blend`` soft edge; the power is not
    concentrated into the cone."""
    direction: tuple = (0.0, 0.0, -1.0)
    spot_size: float = math.radians(45.0)
    spot_blend: float = 0.15
    name: str = "Spot"

    def cos_half_angle(self):
        return math.cos(min(self.spot_size, math.pi) * 0.5)

    def smooth_width(self):
        return (1.0 - self.cos_half_angle()) * self.spot_blend

    def emitted_power(self):
        # Integral of the smoothstep mask over the sphere, in cosine units: the blend band
        # contributes half its width.
        cos_half = self.cos_half_angle()
        return self.intensity() * 2.0 * math.pi * ((1.0 - cos_half) - 0.5 * self.smooth_width())


@dataclass
class SunLight:
    """Blender sun of ``strength`` W/m^2; ``direction`` is the way the light travels."""
    direction: tuple
    strength: float
    color: tuple = (1.0, 1.0, 1.0)
    name: str = "Sun"

    def irradiance(self):
        return self.strength * _vec3(self.color, "color")


@dataclass
class Scene:
    """Triangles in world space (metres) with per-triangle materials and point-like lights.

    vertices (V, 3), triangles (T, 3) vertex indices, counter-clockwise seen from the front.
    normals (V, 3), optional shading normals; face normals otherwise.
    albedo (T, 3) diffuse reflectance in [0, 1): what the lightmap shows, rho E / pi;
    reflectance (T, 3) in [0, 1): what the surface reflects into the room, as if diffuse (more
    than the albedo where glossy layers reflect too); None (default): the albedo, whatever it
    is when solved (reflected() resolves it); emission (T, 3) emitted radiance
    (Blender's emission colour x strength); emission_two_sided (T,) emits from both faces
    as Blender's emission shader does (default) or only from the front.
    receive (T,) gets a lightmap; non-receiving triangles still occlude and emit.
    occlude (T,) casts shadows (default); off for Blender area lights, which emit but are
    invisible to other light.
    receive_back (T,) the back face receives and reflects light too, on texels of its own
    (Blender's surfaces are two-sided; off by default because the back of a closed mesh is
    inside it): solved as a mirrored copy, see with_back_faces().
    polygon (T,) the face each triangle comes from, numbered across the scene (-1: a face of
    its own): Blender keeps one lightmap UV per face corner, so the atlas keeps a face's
    triangles in one chart.
    object_index (T,) into object_names, used in messages and by the add-on;
    object_texel_scale, one factor per object name, multiplies the texel density there.
    object_layout, object_slot, object_block (one integer per object name; each object its
    own by default) say how the atlas lays objects out, as Blender shows instances: objects
    of one layout are copies of one mesh (their charted triangles correspond one to one, in
    order) and share one chart layout, charted on the largest copy; each block (an object
    shown by itself, or the objects one collection instance shows) is placed whole on one
    page, and a slot (an object instanced in several blocks) sits at the same offset within
    each block it is in, so that one offset per slot and one per block place every copy.
    lightmap_uv (T, 3, 2), optional: an object's own lightmap UVs in [0, 1], packed as they
    are (one scale and offset per object, see charting.overlapping_faces for the check the
    add-on makes first); NaN where Luxel charts. An object has them on all its triangles or
    on none.
    albedo_texture_index (T,) into albedo_textures ((H, W, 3 or 4) linear float arrays, row 0
    at v = 0) sampled through albedo_uv (T, 3, 2); -1 for none. The texture is multiplied by
    the triangle's albedo.
    emission_texture_index (T,) into emission_textures (the same, in radiance, 0 or more),
    sampled through albedo_uv too and multiplied by the triangle's emission, which then bounds
    its scale (emitted_power() counts the triangle's emission, untextured). The add-on gives
    reflectance_texture_index (T,) into reflectance_textures likewise, times the reflectance.
    roughness (T,) in [0, 1], 1 by default: the roughness of the layers that reflect what the
    reflectance holds beyond the albedo (a Principled BSDF's specular, coat, metal). That
    share leaves in a lobe about the mirror direction of the light that came in, the wider
    the rougher; at 1 it leaves as if diffuse (lobes.py). glossy_fresnel: those layers are a
    Principled BSDF's, whose albedo rises towards grazing light (Fresnel) while the diffuse
    part below keeps what they leave (lobes.reflect); off, they reflect the reflectance's
    share whatever the angle.
    The add-on gives the three per lightmap page: Cycles' evaluation of the materials at each
    texel.
    """
    vertices: np.ndarray
    triangles: np.ndarray
    albedo: np.ndarray = None
    emission: np.ndarray = None
    normals: np.ndarray = None
    emission_two_sided: np.ndarray = None
    receive: np.ndarray = None
    object_index: np.ndarray = None
    object_names: list = field(default_factory=lambda: ["mesh"])
    object_texel_scale: list = None
    albedo_uv: np.ndarray = None
    albedo_texture_index: np.ndarray = None
    albedo_textures: list = field(default_factory=list)
    lights: list = field(default_factory=list)
    occlude: np.ndarray = None
    sky: tuple = (0.0, 0.0, 0.0)
    receive_back: np.ndarray = None
    polygon: np.ndarray = None
    object_layout: np.ndarray = None
    object_slot: np.ndarray = None
    object_block: np.ndarray = None
    lightmap_uv: np.ndarray = None
    emission_texture_index: np.ndarray = None
    emission_textures: list = field(default_factory=list)
    reflectance: np.ndarray = None
    reflectance_texture_index: np.ndarray = None
    reflectance_textures: list = field(default_factory=list)
    roughness: np.ndarray = None
    glossy_fresnel: bool = False

    def __post_init__(self):
        self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float64)
        self.triangles = np.ascontiguousarray(self.triangles, dtype=np.int64)
        if self.vertices.ndim != 2 or self.vertices.shape[1] != 3:
            raise SceneError(f"vertices must be an array of shape (V, 3), got {self.vertices.shape}")
        if self.triangles.ndim != 2 or self.triangles.shape[1] != 3:
            raise SceneError(f"triangles must be an array of shape (T, 3), got {self.triangles.shape}")
        count = len(self.triangles)
        if count == 0:
            raise SceneError("the scene has no triangles: add at least one mesh with faces")

        def per_triangle(value, default, dtype, width=None):
            if value is None:
                shape = (count,) if width is None else (count, width)
                return np.full(shape, default, dtype=dtype)
            array = np.ascontiguousarray(value, dtype=dtype)
            expected = (count,) if width is None else (count, width)
            if array.shape != expected:
                raise SceneError(f"per-triangle array has shape {array.shape}, expected {expected}")
            return array

        self.albedo = per_triangle(self.albedo, 0.8, np.float64, 3)
        # No copy of the albedo: one would go stale when the albedo is changed after
        # construction (in place or by dataclasses.replace).
        if self.reflectance is not None:
            self.reflectance = per_triangle(self.reflectance, 0.0, np.float64, 3)
        self.emission = per_triangle(self.emission, 0.0, np.float64, 3)
        self.roughness = per_triangle(self.roughness, 1.0, np.float64)
        self.emission_two_sided = per_triangle(self.emission_two_sided, True, bool)
        self.receive = per_triangle(self.receive, True, bool)
        self.occlude = per_triangle(self.occlude, True, bool)
        self.receive_back = per_triangle(self.receive_back, False, bool)
        self.polygon = per_triangle(self.polygon, -1, np.int64)
        self.back_of = None   # with_back_faces(): the original of each copy, -1 for originals
        self.sky = _vec3(self.sky, "sky")
        self.object_index = per_triangle(self.object_index, 0, np.int64)
        self.albedo_texture_index = per_triangle(self.albedo_texture_index, -1, np.int64)
        self.emission_texture_index = per_triangle(self.emission_texture_index, -1, np.int64)
        self.reflectance_texture_index = per_triangle(self.reflectance_texture_index, -1,
                                                      np.int64)
        if self.albedo_uv is not None:
            self.albedo_uv = np.ascontiguousarray(self.albedo_uv, dtype=np.float64)
        if self.lightmap_uv is not None:
            self.lightmap_uv = np.ascontiguousarray(self.lightmap_uv, dtype=np.float64)
        if self.object_texel_scale is None:
            self.object_texel_scale = [1.0] * len(self.object_names)
        objects = len(self.object_names)
        for name in ("object_layout", "object_slot", "object_block"):
            value = getattr(self, name)
            value = np.arange(objects) if value is None else np.asarray(value, dtype=np.int64)
            if value.shape != (objects,):
                raise SceneError(f"{name} needs one integer per object name, got shape "
                                 f"{value.shape}")
            setattr(self, name, value)
        self._validate()

    def object_name(self, triangle):
        index = int(self.object_index[triangle])
        if 0 <= index < len(self.object_names):
            return self.object_names[index]
        return f"object {index}"

    def _fail(self, message, triangle=None):
        name = None if triangle is None else self.object_name(triangle)
        where = "" if triangle is None else f"object '{name}', triangle {int(triangle)}: "
        raise SceneError(where + message, name)

    def _validate(self):
        vertex_count = len(self.vertices)
        out_of_range = (self.triangles < 0) | (self.triangles >= vertex_count)
        if out_of_range.any():
            self._fail("vertex index out of range", int(np.argmax(out_of_range.any(axis=1))))
        used = np.zeros(vertex_count, dtype=bool)
        used[self.triangles.ravel()] = True
        bad = used & ~np.isfinite(self.vertices).all(axis=1)
        if bad.any():
            vertex = int(np.argmax(bad))
            users = np.nonzero((self.triangles == vertex).any(axis=1))[0]
            self._fail(f"vertex {vertex} is not finite {self.vertices[vertex].tolist()}; "
                       "fix or delete it", users[0])
        if self.normals is not None:
            self.normals = np.ascontiguousarray(self.normals, dtype=np.float64)
            if self.normals.shape != self.vertices.shape or not np.isfinite(self.normals).all():
                raise SceneError("normals must be finite and of the same shape as vertices")

        area, degenerate = triangle_areas(self.vertices[self.triangles])
        if degenerate.any():
            self._fail("the triangle is degenerate (zero area); merge its vertices or delete it",
                       int(np.argmax(degenerate)))
        self.triangle_area = area

        for name, values in (("albedo", self.albedo), ("reflectance", self.reflected()),
                             ("emission", self.emission)):
            bad = ~np.isfinite(values).all(axis=1)
            if bad.any():
                self._fail(f"{name} is not finite", int(np.argmax(bad)))
        for name, values in (("albedo", self.albedo), ("reflectance", self.reflected())):
            bad = ((values < 0.0) | (values >= 1.0)).any(axis=1)
            if bad.any():
                triangle = int(np.argmax(bad))
                self._fail(f"{name} {values[triangle].tolist()} is outside [0, 1); a surface "
                           "cannot reflect all light: lower the base colour below 1", triangle)
        bad = ~((self.roughness >= 0.0) & (self.roughness <= 1.0))
        if bad.any():
            self._fail(f"roughness {float(self.roughness[np.argmax(bad)])} is outside [0, 1]; "
                       "set the material's roughness between 0 and 1", int(np.argmax(bad)))
        bad = (self.emission < 0.0).any(axis=1)
        if bad.any():
            self._fail("emission is negative; use a colour and strength of 0 or more",
                       int(np.argmax(bad)))

        scales = np.asarray(self.object_texel_scale, dtype=np.float64)
        if scales.shape != (len(self.object_names),) or not (np.isfinite(scales) & (scales > 0)).all():
            raise SceneError("object_texel_scale needs one positive factor per object name")

        layouts_of_slot = np.unique(np.stack([self.object_slot, self.object_layout]), axis=1)[0]
        if len(layouts_of_slot) != len(np.unique(self.object_slot)):
            raise SceneError("objects of one object_slot must share one object_layout")
        pairs = np.stack([self.object_block, self.object_slot], axis=1)
        if len(np.unique(pairs, axis=0)) != len(pairs):
            raise SceneError("a block holds each object_slot once: give the second copy a "
                             "slot of its own")

        if self.lightmap_uv is not None:
            self._validate_lightmap_uv()

        for kind, index, textures, top in (
                ("albedo", self.albedo_texture_index, self.albedo_textures, 1.0),
                ("emission", self.emission_texture_index, self.emission_textures, np.inf),
                ("reflectance", self.reflectance_texture_index, self.reflectance_textures,
                 1.0)):
            self._validate_textures(kind, index, textures, top)

        for light in self.lights:
            self._validate_light(light)
        if not np.isfinite(self.sky).all() or self.sky.min() < 0.0:
            raise SceneError(f"sky radiance {self.sky.tolist()} must be finite and not negative; "
                             "fix the world colour")
        sun_power = sum(float(np.sum(light.irradiance())) for light in self.lights
                        if isinstance(light, SunLight))
        if self.emitted_power().sum() <= 0.0 and sun_power <= 0.0 and self.sky.sum() <= 0.0:
            raise SceneError("the scene has no light: add a light with positive power or a "
                             "material with emission colour and strength above 0")

    def _validate_textures(self, kind, index, textures, top):
        """Texture indices in range, UVs where they are used, and values in [0, top)."""
        if not (index >= 0).any():
            return
        if self.albedo_uv is None or self.albedo_uv.shape != (len(self.triangles), 3, 2):
            raise SceneError(f"albedo_uv of shape (T, 3, 2) is needed with {kind} textures")
        if (index >= len(textures)).any():
            self._fail(f"{kind} texture index out of range",
                       int(np.argmax(index >= len(textures))))
        for number, image in enumerate(textures):
            image = np.asarray(image)
            if image.ndim != 3 or image.shape[2] not in (3, 4) or not np.isfinite(image).all():
                raise SceneError(f"{kind} texture {number} must be a finite (H, W, 3|4) array")
            if image[..., :3].min() < 0.0 or image[..., :3].max() >= top:
                raise SceneError(f"{kind} texture {number} has values outside [0, {top})")

    def _validate_lightmap_uv(self):
        uv = self.lightmap_uv
        if uv.shape != (len(self.triangles), 3, 2):
            raise SceneError(f"lightmap_uv must have shape (T, 3, 2), got {uv.shape}")
        given = np.isfinite(uv).all(axis=(1, 2))
        mixed = np.isfinite(uv).any(axis=(1, 2)) & ~given
        if mixed.any():
            self._fail("lightmap_uv is partly NaN; give all three corners or none",
                       int(np.argmax(mixed)))
        objects = len(self.object_names)
        with_uv = np.bincount(self.object_index, weights=given, minlength=objects)
        total = np.bincount(self.object_index, minlength=objects)
        partly = np.nonzero((with_uv > 0) & (with_uv < total))[0]
        if len(partly):
            raise SceneError(f"object '{self.object_names[partly[0]]}' has lightmap_uv on some "
                             "of its triangles only; give them on all or none",
                             self.object_names[partly[0]])
        outside = given & ((uv < -UV_TOLERANCE) | (uv > 1.0 + UV_TOLERANCE)).any(axis=(1, 2))
        if outside.any():
            self._fail("lightmap_uv lies outside [0, 1]", int(np.argmax(outside)))

    def _validate_light(self, light):
        label = f"light '{light.name}'"
        numbers = []
        for attribute in ("position", "direction", "color"):
            if hasattr(light, attribute):
                numbers.extend(np.asarray(getattr(light, attribute), dtype=np.float64).ravel())
        for attribute in ("power", "strength", "spot_size", "spot_blend"):
            if hasattr(light, attribute):
                numbers.append(float(getattr(light, attribute)))
        if not np.isfinite(numbers).all():
            raise SceneError(f"{label} has a value that is not finite", light.name)
        if min(np.asarray(light.color, dtype=np.float64)) < 0.0:
            raise SceneError(f"{label} has a negative colour", light.name)
        if getattr(light, "power", 0.0) < 0.0 or getattr(light, "strength", 0.0) < 0.0:
            raise SceneError(f"{label} has negative power; use 0 or more", light.name)
        if hasattr(light, "direction") and np.linalg.norm(light.direction) == 0.0:
            raise SceneError(f"{label} has no direction", light.name)
        if isinstance(light, SpotLight) and not (0.0 < light.spot_size <= math.pi
                                                 and 0.0 <= light.spot_blend <= 1.0):
            raise SceneError(f"{label}: spot size must be in (0, 180] degrees and blend in [0, 1]",
                             light.name)

    def reflected(self):
        """(T, 3): what each triangle reflects into the room, its reflectance or else its
        albedo."""
        return self.albedo if self.reflectance is None else self.reflectance

    def emitted_power(self):
        """Analytic RGB power (W) leaving the emitting triangles, plus point and spot lights.
        Suns are counted by the solver, which knows the area they cover."""
        sides = np.where(self.emission_two_sided, 2.0, 1.0)
        total = (math.pi * self.emission * (self.triangle_area * sides)[:, None]).sum(axis=0)
        for light in self.lights:
            if isinstance(light, PointLight):
                total = total + light.emitted_power()
        return total

    def with_back_faces(self):
        """The scene with a mirrored copy of each triangle whose back face the solver must
        model: receiving triangles flagged in receive_back (the copy receives and reflects on
        texels of its own) and emitters that emit from both faces (the copy emits what the
        original emitted from its back; the original then emits from its front only, so every
        emitter the solver sees is one-sided). A copy has its own vertices (so it charts
        apart), is wound the other way and does not occlude twice. Copies follow the
        original triangles."""
        receiving_back = self.receive_back & self.receive
        emitting_back = self.emission_two_sided & (self.emission.max(axis=1) > 0.0)
        backs = self.back_face_originals()
        if len(backs) == 0:
            return self
        count, vertex_count = len(self.triangles), len(self.vertices)
        corners = self.triangles[backs][:, ::-1]
        extend = lambda array, values: np.concatenate([array, values])
        back_emission = np.where(emitting_back[backs, None], self.emission[backs], 0.0)
        copy = Scene(
            vertices=extend(self.vertices, self.vertices[corners.ravel()]),
            triangles=extend(self.triangles,
                             vertex_count + np.arange(3 * len(backs)).reshape(-1, 3)),
            albedo=extend(self.albedo, self.albedo[backs]),
            emission=extend(self.emission, back_emission),
            normals=None if self.normals is None else extend(self.normals,
                                                            -self.normals[corners.ravel()]),
            emission_two_sided=np.zeros(count + len(backs), bool),
            receive=extend(self.receive, receiving_back[backs]),
            object_index=extend(self.object_index, self.object_index[backs]),
            object_names=list(self.object_names), object_texel_scale=list(self.object_texel_scale),
            object_layout=self.object_layout, object_slot=self.object_slot,
            object_block=self.object_block,
            albedo_uv=None if self.albedo_uv is None else extend(self.albedo_uv,
                                                                self.albedo_uv[backs][:, ::-1]),
            lightmap_uv=None if self.lightmap_uv is None else extend(
                self.lightmap_uv, self.lightmap_uv[backs][:, ::-1]),
            albedo_texture_index=extend(self.albedo_texture_index,
                                        self.albedo_texture_index[backs]),
            albedo_textures=self.albedo_textures,
            emission_texture_index=extend(self.emission_texture_index,
                                          self.emission_texture_index[backs]),
            emission_textures=self.emission_textures,
            reflectance=None if self.reflectance is None else extend(
                self.reflectance, self.reflectance[backs]),
            reflectance_texture_index=extend(self.reflectance_texture_index,
                                             self.reflectance_texture_index[backs]),
            reflectance_textures=self.reflectance_textures,
            roughness=extend(self.roughness, self.roughness[backs]),
            glossy_fresnel=self.glossy_fresnel, lights=self.lights,
            occlude=extend(self.occlude, np.zeros(len(backs), bool)), sky=self.sky,
            polygon=extend(self.polygon, np.full(len(backs), -1)))   # no UV map shows copies
        copy.back_of = extend(np.full(count, -1), backs)  # the original of each copy
        return copy

    def back_face_originals(self):
        """The triangles with_back_faces() copies, in the order of their copies (appended
        after the scene's triangles)."""
        receiving_back = self.receive_back & self.receive
        emitting_back = self.emission_two_sided & (self.emission.max(axis=1) > 0.0)
        return np.nonzero(receiving_back | emitting_back)[0]

    def bounds(self):
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def save(self, path):
        """Write the scene to a compressed .npz that load() reads back without Blender or
        pickle: every field, the lights as JSON with their type, the textures one per key."""
        arrays = {}
        for name in (f.name for f in fields(self)):
            value = getattr(self, name)
            if name == "lights":
                value = json.dumps([{"type": type(light).__name__, **_plain(asdict(light))}
                                    for light in value])
            elif name in _TEXTURE_KEYS:
                for index, image in enumerate(value):
                    arrays[f"{_TEXTURE_KEYS[name]}{index}"] = np.asarray(image)
                continue
            elif value is None:
                continue
            arrays[name] = np.asarray(value)
        with open(path, "wb") as file:
            np.savez_compressed(file, **arrays)

    @classmethod
    def load(cls, path):
        """The scene save() wrote, validated again as any new scene is."""
        with np.load(path, allow_pickle=False) as stored:
            values = {key: stored[key] for key in stored.files}
        for name, prefix in _TEXTURE_KEYS.items():
            keys = sorted((key for key in values if key.startswith(prefix)),
                          key=lambda key: int(key[len(prefix):]))
            values[name] = [values.pop(key) for key in keys]
        values["lights"] = [_LIGHT_TYPES[light.pop("type")](**light)
                            for light in json.loads(str(values["lights"]))]
        values["object_names"] = [str(name) for name in values["object_names"]]
        values["object_texel_scale"] = values["object_texel_scale"].tolist()
        if "glossy_fresnel" in values:
            values["glossy_fresnel"] = bool(values["glossy_fresnel"])
        return cls(**values)


_TEXTURE_KEYS = {"albedo_textures": "albedo_textures_",
                 "emission_textures": "emission_textures_",
                 "reflectance_textures": "reflectance_textures_"}
_LIGHT_TYPES = {light.__name__: light for light in (PointLight, SpotLight, SunLight)}


def _plain(light_fields):
    """Light fields as JSON numbers and lists (positions may be numpy arrays)."""
    return {key: np.asarray(value).tolist() if not isinstance(value, str) else value
            for key, value in light_fields.items()}
