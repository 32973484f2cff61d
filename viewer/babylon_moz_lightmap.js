// SPDX-License-Identifier: GPL-3.0-or-later
//
// A Babylon.js glTF loader extension for Luxel's lightmaps: MOZ_lightmap textures holding
// irradiance (W/m²) as RGBD PNGs. A texel decodes to intensity * pow(rgb, 2.2) / a; a
// lightmapped surface then shows irradiance * baseColor * (1 - metallic) / pi, the diffuse
// radiance Blender shows. WebGL (GLSL) only.
//   import { registerGLTFExtension } from "@babylonjs/loaders/glTF/2.0";
//   registerGLTFExtension("MOZ_lightmap", true, (loader) => new MozLightmap(loader));
import { MaterialPluginBase } from "@babylonjs/core/Materials/materialPluginBase.js";
import { RGBD_LIGHTMAP } from "./rgbd_lightmap.js";

const EXTENSION = "MOZ_lightmap";

// PBRMaterial adds its lightmap to the final colour as radiance: this makes it irradiance seen
// through Lambert's BRDF. baseColor, not surfaceAlbedo, which Babylon dims by the dielectric F0
// (4 %) where Blender's diffuse does not.
class LambertLightmap extends MaterialPluginBase {
    constructor(material) {
        // Babylon's default priority, no defines of its own, enabled at once.
        super(material, "LambertLightmap", 500, undefined, true, true);
    }

    getClassName() {
        return "LambertLightmap";
    }

    getCustomCode(shaderType) {
        if (shaderType !== "fragment") return null;
        return {
            CUSTOM_FRAGMENT_DEFINITIONS: RGBD_LIGHTMAP,
            // Luxel's RGBD, decoded before filtering (Babylon's fromRGBD is the same decoding,
            // unless the engine has useExactSrgbConversions, but of the filtered bytes).
            "!fromRGBD\\(lightmapColor\\);": "lightMapAt(lightmapSampler,vLightmapUV+uvOffset);",
            "!(finalColor\\.rgb\\+=lightmapColor\\.rgb);":
                "$1*baseColor*(1.0-reflectivityOut.metallic)*RECIPROCAL_PI;",
        };
    }
}

export class MozLightmap {
    constructor(loader) {
        this.name = EXTENSION;
        this.enabled = true;
        this.loader = loader;
    }

    dispose() {
        this.loader = null;
    }

    loadMaterialPropertiesAsync(context, material, babylonMaterial) {
        const lightmap = material.extensions?.[EXTENSION];
        // Unlit materials show no light (and their shader has no baseColor), as in three.js.
        if (lightmap === undefined || material.extensions.KHR_materials_unlit) return null;
        return this.loadLightmapAsync(context, material, babylonMaterial, lightmap);
    }

    async loadLightmapAsync(context, material, babylonMaterial, lightmap) {
        await this.loader.loadMaterialPropertiesAsync(context, material, babylonMaterial);
        // nonColorData: no sRGB decode by the GPU; gammaSpace false: none in the shader.
        const textureInfo = { index: lightmap.index, texCoord: lightmap.texCoord ?? 1,
            nonColorData: true };
        const texture = await this.loader.loadTextureInfoAsync(
            `${context}/extensions/${EXTENSION}`, textureInfo);
        texture.gammaSpace = false;
        texture.isRGBD = true;
        texture.level = lightmap.intensity ?? 1.0;
        babylonMaterial.lightmapTexture = texture;
        new LambertLightmap(babylonMaterial);
    }
}
