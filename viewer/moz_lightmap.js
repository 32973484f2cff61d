// SPDX-License-Identifier: GPL-3.0-or-later
//
// A GLTFLoader plugin for Luxel's lightmaps: MOZ_lightmap textures holding irradiance (W/m²) as
// RGBD PNGs. A texel decodes to intensity * pow(rgb, 2.2) / a; a lightmapped surface then shows
// irradiance * baseColor * (1 - metalness) / pi, the diffuse radiance Blender shows. WebGL 2.
//   loader.register((parser) => new MozLightmapPlugin(parser));
import { NoColorSpace, ShaderChunk } from "three";

const EXTENSION = "MOZ_lightmap";

// The GPU would filter the encoded bytes, whose decoding is not linear: seams where a texel's
// divisor differs from its neighbour's. The four texels around the point are decoded first.
const DECODE_RGBD = `
vec3 decodeLightMapRGBD(const in vec4 texel) {
    return pow(texel.rgb, vec3(2.2)) / max(texel.a, 1.0 / 255.0);
}
vec3 lightMapAt(const in sampler2D map, const in vec2 uv) {
    ivec2 last = textureSize(map, 0) - 1;
    vec2 position = uv * vec2(last + 1) - 0.5;
    vec2 weight = fract(position);
    ivec2 corner = ivec2(floor(position));
    vec3 texels[4];
    for (int i = 0; i < 4; i++) {
        ivec2 at = clamp(corner + ivec2(i & 1, i >> 1), ivec2(0), last);
        texels[i] = decodeLightMapRGBD(texelFetch(map, at, 0));
    }
    return mix(mix(texels[0], texels[1], weight.x), mix(texels[2], texels[3], weight.x),
               weight.y);
}`;

// three's lightmap lines in its lights_fragment_maps chunk (three 0.187).
const LIGHTMAP_LINES = `
		vec4 lightMapTexel = texture2D( lightMap, vLightMapUv );
		vec3 lightMapIrradiance = lightMapTexel.rgb * lightMapIntensity;
		irradiance += lightMapIrradiance;`;

const DECODED_IRRADIANCE = `
    vec3 lightMapIrradiance = lightMapAt(lightMap, vLightMapUv) * lightMapIntensity;`;

// MeshStandardMaterial dims the irradiance it is given by its specular albedo (about 4 % at
// roughness 0.5, varying with the view angle): the lightmap's light is added after that, as
// plain Lambert, to match Blender.
const LIGHTMAP_TERM = `
#include <lights_fragment_end>
#ifdef USE_LIGHTMAP
    reflectedLight.indirectDiffuse +=
        lightMapIrradiance * BRDF_Lambert(material.diffuseContribution);
#endif`;

function replaceOnce(source, search, replacement) {
    if (!source.includes(search)) {
        throw new Error("MOZ_lightmap: this three.js's shaders are not those of three 0.187, "
            + "which the plugin patches");
    }
    return source.replace(search, () => replacement);
}

function decodeRGBD(shader) {
    const lightsMaps = replaceOnce(ShaderChunk.lights_fragment_maps, LIGHTMAP_LINES,
        DECODED_IRRADIANCE);
    let fragment = replaceOnce(shader.fragmentShader, "#include <lightmap_pars_fragment>",
        "#include <lightmap_pars_fragment>\n" + DECODE_RGBD);
    fragment = replaceOnce(fragment, "#include <lights_fragment_maps>", lightsMaps);
    shader.fragmentShader = replaceOnce(fragment, "#include <lights_fragment_end>", LIGHTMAP_TERM);
}

export class MozLightmapPlugin {
    constructor(parser) {
        this.parser = parser;
        this.name = EXTENSION;
    }

    lightmapOf(materialIndex) {
        return this.parser.json.materials?.[materialIndex]?.extensions?.[EXTENSION];
    }

    extendMaterialParams(materialIndex, materialParams) {
        const lightmap = this.lightmapOf(materialIndex);
        if (lightmap === undefined) return Promise.resolve();
        materialParams.lightMapIntensity = lightmap.intensity ?? 1.0;
        // assignTexture sets texture.channel from texCoord; the texture keeps flipY false.
        const textureInfo = { index: lightmap.index, texCoord: lightmap.texCoord ?? 1 };
        return this.parser.assignTexture(materialParams, "lightMap", textureInfo, NoColorSpace);
    }

    // GLTFLoader makes the material after extendMaterialParams: its shader is patched here.
    // (GLTFLoader calls no plugin's extendMaterialParams for KHR_materials_unlit materials,
    // which keep no lightmap.)
    afterRoot(gltf) {
        gltf.scene.traverse((object) => {
            const material = object.material;
            if (!object.isMesh || !material.isMeshStandardMaterial || !material.lightMap) return;
            const reference = this.parser.associations.get(material);
            if (reference?.materials === undefined || !this.lightmapOf(reference.materials)) return;
            material.onBeforeCompile = decodeRGBD;
            material.customProgramCacheKey = () => "rgbd-lightmap";
        });
    }
}
