// SPDX-License-Identifier: GPL-3.0-or-later
//
// Luxel's lightmap viewer: the GLB next to this page (or ?glb=NAME), lit by its lightmaps only,
// seen from its baked camera. ?measure=1&width=W&height=H renders the baked camera's view once,
// linear and unclipped, with an object-ID pass, into <pre id="measure"> for the tests.
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { MozLightmapPlugin } from "./moz_lightmap.js";
import { base64, topRowsFirst } from "./measure.js";

const BACKGROUND = 0x333333;
const params = new URLSearchParams(location.search);

function loadGltf(url) {
    const loader = new GLTFLoader();
    loader.register((parser) => new MozLightmapPlugin(parser));
    return loader.loadAsync(url);
}

// A camera of our own at the baked camera's world pose: OrbitControls moves a camera without a
// parent, and the glTF camera hangs under its node.
function bakedCamera(gltf, aspect) {
    const baked = gltf.cameras.find((camera) => camera.isPerspectiveCamera);
    if (baked === undefined) return null;
    gltf.scene.updateMatrixWorld(true);
    const camera = new THREE.PerspectiveCamera(baked.fov, aspect, baked.near, baked.far);
    baked.matrixWorld.decompose(camera.position, camera.quaternion, new THREE.Vector3());
    camera.updateMatrixWorld(true);
    return camera;
}

function framingCamera(bounds, aspect) {
    const sphere = bounds.getBoundingSphere(new THREE.Sphere());
    const radius = Math.max(sphere.radius, 1e-3);
    const camera = new THREE.PerspectiveCamera(45, aspect, radius / 100, radius * 100);
    const distance = radius / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2));
    const direction = new THREE.Vector3(1, 0.6, 1).normalize();
    camera.position.copy(sphere.center).addScaledVector(direction, distance);
    camera.lookAt(sphere.center);
    return camera;
}

// The glTF node that carries a mesh: the Mesh itself or, for several primitives, its parent
// Group. Its name is taken as written (GLTFLoader's object.name drops '.', ':', '/', '[ ]').
function carrierNode(mesh, parser) {
    for (let object = mesh; object !== null; object = object.parent) {
        const index = parser.associations.get(object)?.nodes;
        if (index !== undefined) {
            return { index, name: parser.json.nodes[index].name ?? object.name };
        }
    }
    return { index: -1, name: mesh.name };
}

// The first `channels` channels of the target, top row first.
function readRows(renderer, target, width, height, channels) {
    const rgba = new Float32Array(width * height * 4);
    renderer.readRenderTargetPixels(target, 0, 0, width, height, rgba);
    return topRowsFirst(rgba, width, height, channels);
}

// Writes id + 1, so that the cleared background reads 0 and comes back as -1.
function idMaterial(id, side) {
    return new THREE.ShaderMaterial({
        side,
        uniforms: { objectId: { value: id + 1 } },
        vertexShader: `void main() {
            gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0);
        }`,
        fragmentShader: `uniform float objectId;
        void main() { gl_FragColor = vec4(objectId, 0.0, 0.0, 1.0); }`,
    });
}

// A float render target keeps the values linear: three tone-maps and sRGB-encodes only what
// it draws on the canvas.
function measure(gltf, width, height) {
    const camera = bakedCamera(gltf, width / height);
    if (camera === null) throw new Error("the GLB has no perspective camera to measure from");
    const renderer = new THREE.WebGLRenderer({ antialias: false });
    renderer.setPixelRatio(1);
    renderer.setSize(width, height);
    renderer.toneMapping = THREE.NoToneMapping;
    renderer.toneMappingExposure = 1;
    renderer.setClearColor(0x000000, 1);
    const target = new THREE.WebGLRenderTarget(width, height, {
        type: THREE.FloatType, minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter,
    });
    renderer.setRenderTarget(target);
    const scene = gltf.scene;
    renderer.render(scene, camera);
    const rgb = readRows(renderer, target, width, height, 3);

    const names = [];
    const idOfNode = new Map();
    scene.traverse((object) => {
        if (!object.isMesh) return;
        const node = carrierNode(object, gltf.parser);
        if (!idOfNode.has(node.index)) {
            idOfNode.set(node.index, names.length);
            names.push(node.name);
        }
        object.material = idMaterial(idOfNode.get(node.index), object.material.side);
    });
    renderer.render(scene, camera);
    const idValues = readRows(renderer, target, width, height, 1);
    const ids = Int32Array.from(idValues, (value) => Math.round(value) - 1);
    return { width, height, rgb: base64(rgb), ids: base64(ids), names };
}

function orbitTarget(camera, bounds) {
    // In front of the camera, as deep as the scene's centre.
    const forward = new THREE.Vector3(0, 0, -1).applyQuaternion(camera.quaternion);
    const centre = bounds.getCenter(new THREE.Vector3());
    const depth = Math.max(centre.sub(camera.position).dot(forward), camera.near * 10);
    return camera.position.clone().addScaledVector(forward, depth);
}

function view(gltf) {
    const renderer = new THREE.WebGLRenderer({ antialias: true });
    renderer.setPixelRatio(window.devicePixelRatio);
    renderer.setSize(window.innerWidth, window.innerHeight);
    renderer.toneMapping = THREE.LinearToneMapping;
    renderer.outputColorSpace = THREE.SRGBColorSpace;
    document.body.appendChild(renderer.domElement);

    const scene = new THREE.Scene();
    scene.background = new THREE.Color(BACKGROUND);
    scene.add(gltf.scene);
    const aspect = window.innerWidth / window.innerHeight;
    const bounds = new THREE.Box3().setFromObject(gltf.scene);
    const camera = bakedCamera(gltf, aspect) ?? framingCamera(bounds, aspect);
    const target = orbitTarget(camera, bounds);     // before OrbitControls turns the camera
    const controls = new OrbitControls(camera, renderer.domElement);
    controls.target.copy(target);
    controls.update();

    const lightmapped = [];
    gltf.scene.traverse((object) => {
        if (object.isMesh && object.material.lightMap) lightmapped.push(object.material);
    });
    const intensities = new Map(
        lightmapped.map((material) => [material, material.lightMapIntensity]));

    const exposure = document.getElementById("exposure");
    const exposureLabel = document.getElementById("exposure-value");
    const lightmapOn = document.getElementById("lightmap");
    const render = () => renderer.render(scene, camera);
    const update = () => {
        const stops = Number(exposure.value);
        renderer.toneMappingExposure = 2 ** stops;
        exposureLabel.textContent = `${stops.toFixed(1)} EV`;
        for (const material of lightmapped) {
            material.lightMapIntensity = lightmapOn.checked ? intensities.get(material) : 0;
        }
        render();
    };
    exposure.addEventListener("input", update);
    lightmapOn.addEventListener("change", update);
    controls.addEventListener("change", render);
    window.addEventListener("resize", () => {
        camera.aspect = window.innerWidth / window.innerHeight;
        camera.updateProjectionMatrix();
        renderer.setSize(window.innerWidth, window.innerHeight);
        render();
    });
    update();
}

async function main() {
    const gltf = loadGltf(params.get("glb") ?? "scene.glb");
    if (params.get("measure") !== "1") {
        view(await gltf);
        return;
    }
    const output = document.getElementById("measure");
    try {
        const width = Number(params.get("width") ?? 256);
        const height = Number(params.get("height") ?? 256);
        output.textContent = JSON.stringify(measure(await gltf, width, height));
    } catch (error) {
        output.textContent = JSON.stringify({ error: String(error?.message ?? error) });
    }
}

main().catch((error) => {
    const status = document.getElementById("status");
    status.textContent = `Could not show the GLB: ${error.message ?? error}`;
});
