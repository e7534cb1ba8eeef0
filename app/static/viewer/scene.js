// The three.js scene, camera, controls and the IK gizmo; drawing helpers (triads, arrows).
// (A module of the model viewer; viewer.js is the entry point.)

import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { TransformControls } from "three/addons/controls/TransformControls.js";
import { $, state } from "./config.js";

// ---------------------------------------------------------------------------- scene
export const host = $("canvas-host");
export const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
renderer.setClearColor(0xf7f8fa, 1);
host.appendChild(renderer.domElement);

export const scene = new THREE.Scene();
export const camera = new THREE.PerspectiveCamera(45, 1, 0.001, 1000);
camera.up.set(0, 0, 1);                   // robotics convention: z up
camera.position.set(1.5, -1.5, 1.2);
// The IK target gizmo is created before the orbit controls so that its pointerdown handler runs
// first: grabbing a handle turns orbiting off before the orbit controls see the press.
export const gizmo = new TransformControls(camera, renderer.domElement);
export const controls = new OrbitControls(camera, renderer.domElement);
controls.addEventListener("change", () => requestRender());

scene.add(new THREE.HemisphereLight(0xffffff, 0x8890a0, 2.0));
export const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(2, -3, 5);
scene.add(sun);


let renderQueued = false;
export function requestRender() {
  if (renderQueued) return;
  renderQueued = true;
  requestAnimationFrame(() => {
    renderQueued = false;
    renderer.render(scene, camera);
    state.renders += 1;
  });
}

export function resize() {
  const w = Math.max(1, host.clientWidth);
  const h = Math.max(1, host.clientHeight);
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  requestRender();
}
new ResizeObserver(resize).observe(host);

/** THREE.Matrix4 from a row-major nested 4x4 list (the API's `matrix`). */
export function matrixFromRows(rows) {
  const m = new THREE.Matrix4();
  m.set(...rows[0], ...rows[1], ...rows[2], ...rows[3]);
  return m;
}

/** A mesh for one primitive visual (box/cylinder/sphere), in its link's frame; null for meshes. */
export function visualObject(visual, material) {
  let geometry;
  const s = visual.size;
  if (visual.kind === "box") {
    geometry = new THREE.BoxGeometry(s[0], s[1], s[2]);
  } else if (visual.kind === "cylinder") {
    // URDF cylinders run along z; three.js cylinders along y.
    geometry = new THREE.CylinderGeometry(s[0], s[0], s[1], 24);
    geometry.rotateX(Math.PI / 2);
  } else if (visual.kind === "sphere") {
    geometry = new THREE.SphereGeometry(s[0], 20, 14);
  } else {
    return null;
  }
  const mesh = new THREE.Mesh(geometry, material);
  mesh.matrixAutoUpdate = false;
  mesh.matrix.copy(matrixFromRows(visual.origin));   // T_link_visual
  return mesh;
}

// ---------------------------------------------------------------------------- drawing helpers
export const Z_AXIS = new THREE.Vector3(0, 0, 1);
export const COLORS = { x: 0xd62728, y: 0x2ca02c, z: 0x1f5fd6, bone: 0x3b4256, revolute: 0xe0a000, prismatic: 0xb0179a };

/** A solid arrow of unit length along +z (shaft from `from` to 1 - head, then a cone). */
export function unitArrowGeometry(from = 0, headFraction = 0.28, shaftRadius = 0.045, headRadius = 0.11) {
  const shaftLength = 1 - headFraction - from;
  const shaft = new THREE.CylinderGeometry(shaftRadius, shaftRadius, shaftLength, 10);
  shaft.rotateX(Math.PI / 2);
  shaft.translate(0, 0, from + shaftLength / 2);
  const head = new THREE.ConeGeometry(headRadius, headFraction, 14);
  head.rotateX(Math.PI / 2);
  head.translate(0, 0, 1 - headFraction / 2);
  return [shaft, head];
}

/** An RGB triad (x red, y green, z blue) of the given length, as one group. */
export function makeTriad(length, geometries, materials) {
  const triad = new THREE.Group();
  const directions = { x: new THREE.Euler(0, Math.PI / 2, 0), y: new THREE.Euler(-Math.PI / 2, 0, 0), z: new THREE.Euler() };
  for (const axis of ["x", "y", "z"]) {
    for (const g of geometries) {
      const mesh = new THREE.Mesh(g, materials[axis]);
      mesh.rotation.copy(directions[axis]);
      triad.add(mesh);
    }
  }
  triad.scale.setScalar(length);
  return triad;
}
