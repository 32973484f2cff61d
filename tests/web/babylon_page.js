// SPDX-License-Identifier: GPL-3.0-or-later
//
// Babylon.js's view of scene.glb through the MOZ_lightmap extension, for tests/test_babylon.py:
// ?width=W&height=H renders the glTF camera's view once, linear and unclipped, with an
// object-ID pass, into <pre id="measure"> in the JSON of viewer/viewer.js's measurement mode.
import { Engine } from "@babylonjs/core/Engines/engine.js";
import { Scene } from "@babylonjs/core/scene.js";
import { Color4 } from "@babylonjs/core/Maths/math.color.js";
import { Constants } from "@babylonjs/core/Engines/constants.js";
import { RenderTargetTexture } from "@babylonjs/core/Materials/Textures/renderTargetTexture.js";
import { ShaderMaterial } from "@babylonjs/core/Materials/shaderMaterial.js";
import { LoadAssetContainerAsync } from "@babylonjs/core/Loading/sceneLoader.js";
import { registerBuiltInLoaders } from "@babylonjs/loaders/dynamic.js";
import { registerGLTFExtension } from "@babylonjs/loaders/glTF/2.0/glTFLoaderExtensionRegistry.js";
import { MozLightmap } from "./babylon_moz_lightmap.js";
import { base64, topRowsFirst } from "./measure.js";

const params = new URLSearchParams(location.search);

registerBuiltInLoaders();
registerGLTFExtension("MOZ_lightmap", true, (loader) => new MozLightmap(loader));

// The first `channels` channels of the target, top row first.
async function readRows(target, width, height, channels) {
    return topRowsFirst(await target.readPixels(), width, height, channels);
}

// The glTF node a mesh stands for: the mesh itself or, for several primitives, its parent.
function gltfNode(mesh) {
    for (let node = mesh; node !== null; node = node.parent) {
        const pointer = node._internalMetadata?.gltf?.pointers?.find((p) => /^\/nodes\/\d+$/.test(p));
        if (pointer !== undefined) return { pointer, name: node.name };
    }
    return { pointer: mesh.uniqueId, name: mesh.name };
}

// Writes id + 1, so that the cleared background reads 0 and comes back as -1.
function idMaterial(scene, id, original) {
    const material = new ShaderMaterial(`id ${id}`, scene, {
        vertexSource: `precision highp float;
            attribute vec3 position;
            uniform mat4 worldViewProjection;
            void main() { gl_Position = worldViewProjection * vec4(position, 1.0); }`,
        fragmentSource: `precision highp float;
            uniform float objectId;
            void main() { gl_FragColor = vec4(objectId, 0.0, 0.0, 1.0); }`,
    }, { attributes: ["position"], uniforms: ["worldViewProjection", "objectId"] });
    material.setFloat("objectId", id + 1);
    material.backFaceCulling = original.backFaceCulling;
    material.sideOrientation = original.sideOrientation;
    return material;
}

async function measure(width, height) {
    const canvas = document.getElementById("canvas");
    canvas.width = width;
    canvas.height = height;
    const engine = new Engine(canvas, false);
    const scene = new Scene(engine);
    scene.clearColor = new Color4(0, 0, 0, 1);
    // Linear and unclipped: tone mapping and the sRGB curve are left to a post-process, and
    // none is added.
    scene.imageProcessingConfiguration.applyByPostProcess = true;
    scene.imageProcessingConfiguration.skipFinalColorClamp = true;

    const container = await LoadAssetContainerAsync("scene.glb", scene);
    container.addAllToScene();
    const camera = container.cameras[0];
    if (camera === undefined) throw new Error("the GLB has no camera to measure from");
    scene.activeCamera = camera;

    const target = new RenderTargetTexture("measure", { width, height }, scene, {
        generateMipMaps: false, type: Constants.TEXTURETYPE_FLOAT,
        samplingMode: Constants.TEXTURE_NEAREST_SAMPLINGMODE,
    });
    target.activeCamera = camera;
    target.renderList = scene.meshes;
    target.clearColor = new Color4(0, 0, 0, 1);
    await scene.whenReadyAsync();
    target.render();
    const rgb = await readRows(target, width, height, 3);

    const names = [];
    const idOfNode = new Map();
    for (const mesh of scene.meshes) {
        // The loader's __root__ (glTF's right-handed axes in Babylon's left-handed scene) has
        // no material, nor geometry.
        if (mesh.material === null) continue;
        const node = gltfNode(mesh);
        if (!idOfNode.has(node.pointer)) {
            idOfNode.set(node.pointer, names.length);
            names.push(node.name);
        }
        mesh.material = idMaterial(scene, idOfNode.get(node.pointer), mesh.material);
    }
    await scene.whenReadyAsync();
    target.render();
    const idValues = await readRows(target, width, height, 1);
    const ids = Int32Array.from(idValues, (value) => Math.round(value) - 1);
    return { width, height, rgb: base64(rgb), ids: base64(ids), names };
}

const output = document.getElementById("measure");
measure(Number(params.get("width") ?? 256), Number(params.get("height") ?? 256))
    .then((measured) => { output.textContent = JSON.stringify(measured); })
    .catch((error) => {
        output.textContent = JSON.stringify({ error: String(error?.stack ?? error) });
    });
