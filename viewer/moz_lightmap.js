// SPDX-License-Identifier: GPL-3.0-or-later
//
// A GLTFLoader plugin for Luxel's lightmaps: MOZ_lightmap textures holding irradiance (W/m²) as
// RGBD PNGs. A texel decodes to intensity * pow(rgb, 2.2) / a; a lightmapped surface then shows
// irradiance * baseColor * (1 - metalness) / pi, the diffuse radiance Blender shows. WebGL 2.
//   loader.register((parser) => new MozLightmapPlugin(parser));
import { NoColorSpace, ShaderChunk } from "three";
import { RGBD_LIGHTMAP } from "./rgbd_lightmap.js";

const EXTENSION = "MOZ_lightmap";

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
        "#include <lightmap_pars_fragment>\n" + RGBD_LIGHTMAP);
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
