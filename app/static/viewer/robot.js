// The model being shown: its skeleton, the joint sliders, FK and the selected link's pose and Jacobian.
// (A module of the model viewer; viewer.js is the entry point.)

import * as THREE from "three";
import { api, showError } from "./api.js";
import { $, AXIS_ARROW_FRACTION, DIGITS, FIT_DIRECTION, FIT_MARGIN, FK_LINKS_ALL, JACOBIAN_REFERENCE, SELECTED_TRIAD_SCALE, SLIDER_STEPS, TRIAD_FRACTION, state } from "./config.js";
import { COLORS, Z_AXIS, camera, controls, makeTriad, matrixFromRows, requestRender, scene, unitArrowGeometry } from "./scene.js";
import { current, emit } from "./state.js";
import { colourLinks, hasServedMeshes, linkColours, linkVisuals, loadMeshes, resetMeshState } from "./meshes.js";
import { requestCollision, resetCollision } from "./self-collision.js";
import { initialValue, sliderRange } from "./defaults.js";

// ---------------------------------------------------------------------------- model state
// What other modules read of the model shown (the model, sliders, link groups, poses, size, load
// token) is `current` (state.js); what only this module draws and counts stays here.
let grid = null;                          // ground grid in the world xy plane
let robot = null;                         // THREE.Group holding the current model's objects
let bones = [];         // {joint, mesh}: a rod from the parent link origin to the child link origin
let axisArrows = [];    // {joint, arrow}: the joint axis through the joint (= child link) origin
let fkInFlight = false;
let fkPending = false;
let jacobianSeq = 0;
let snapTargetAfterFk = false;  // the next settled FK answer moves the IK target onto the link

/** An FK request in flight or one waiting for it. */
export function fkBusy() { return fkInFlight || fkPending; }

/** The model being shown (GET /models/{id}); set by the loader. */
export function setModel(info) { current.model = info; }

/** A new load: the token that tells its answers from those of an older load. */
export function nextLoadToken() { return ++current.loadToken; }

export function disposeRobot() {
  if (!robot) return;
  scene.remove(robot);
  const seen = new Set();
  robot.traverse((o) => {
    for (const r of [o.geometry, ...(Array.isArray(o.material) ? o.material : [o.material])]) {
      if (r && !seen.has(r)) { seen.add(r); r.dispose(); }
    }
  });
  robot = null;
}

export function buildRobot(info, visuals, poses) {
  disposeRobot();
  robot = new THREE.Group();
  current.linkGroups = {};
  bones = [];
  axisArrows = [];

  // Size of the model at the first configuration: sets triad size, arrows and the camera.
  const box = new THREE.Box3();
  for (const link of info.links) box.expandByPoint(new THREE.Vector3(...poses[link].position));
  const extent = box.getSize(new THREE.Vector3()).length();
  current.modelSize = Math.max(extent, 0.2);
  const triadLength = current.modelSize * TRIAD_FRACTION;
  const rodRadius = current.modelSize * 0.006;

  const triadGeometries = unitArrowGeometry(0, 0.25, 0.05, 0.12);
  const triadMaterials = {
    x: new THREE.MeshBasicMaterial({ color: COLORS.x }),
    y: new THREE.MeshBasicMaterial({ color: COLORS.y }),
    z: new THREE.MeshBasicMaterial({ color: COLORS.z }),
  };
  // Drawn as it looks when the service serves its meshes: then primitives are solid too; else
  // primitives semi-transparent over the skeleton (a mesh without a URL is not drawn).
  const solid = hasServedMeshes(visuals);
  for (const link of info.links) {
    const group = new THREE.Group();
    group.matrixAutoUpdate = false;
    group.name = link;
    const triad = makeTriad(triadLength, triadGeometries, triadMaterials);
    triad.name = "triad";
    group.add(triad);
    for (const object of linkVisuals(visuals && visuals[link], solid)) group.add(object);
    current.linkGroups[link] = group;
    robot.add(group);
  }

  // Bones: a rod from every joint's parent link origin to its child link origin (unit
  // length along +z, scaled and turned on every update), and a ball at each joint.
  const rodGeometry = new THREE.CylinderGeometry(rodRadius, rodRadius, 1, 10);
  rodGeometry.rotateX(Math.PI / 2);
  rodGeometry.translate(0, 0, 0.5);
  const boneMaterial = new THREE.MeshStandardMaterial({ color: COLORS.bone, roughness: 0.6 });
  const ballGeometry = new THREE.SphereGeometry(rodRadius * 2.2, 14, 10);
  for (const joint of info.joints) {
    const mesh = new THREE.Mesh(rodGeometry, boneMaterial);
    const ball = new THREE.Mesh(ballGeometry, boneMaterial);
    mesh.userData.link = joint.child;     // stands for its child link when that has no visual
    bones.push({ joint, mesh, ball });
    robot.add(mesh, ball);
  }

  // Joint axes: arrows through the child link origin along the joint axis (the axis is given
  // in the joint frame, which is the child link frame), centred on the joint.
  const arrowLength = current.modelSize * AXIS_ARROW_FRACTION;
  const arrowGeometries = unitArrowGeometry(-0.5, 0.22, 0.03, 0.08);
  const arrowMaterials = {
    revolute: new THREE.MeshStandardMaterial({ color: COLORS.revolute }),
    prismatic: new THREE.MeshStandardMaterial({ color: COLORS.prismatic }),
  };
  for (const joint of info.joints) {
    if (joint.type === "fixed") continue;
    const arrow = new THREE.Group();
    const material = joint.type === "prismatic" ? arrowMaterials.prismatic : arrowMaterials.revolute;
    for (const g of arrowGeometries) arrow.add(new THREE.Mesh(g, material));
    arrow.scale.setScalar(arrowLength);
    axisArrows.push({ joint, arrow });
    robot.add(arrow);
  }
  scene.add(robot);
  resetMeshState();
  resetCollision();
  const built = robot;
  loadMeshes(built, () => robot === built);

  // Ground grid (1 2 5 steps) and world axes scaled to the model.
  if (grid) { scene.remove(grid); grid.geometry.dispose(); grid.material.dispose(); }
  const step = niceStep(current.modelSize / 5);
  grid = new THREE.GridHelper(step * 20, 20, 0x9aa1b1, 0xd3d7df);
  grid.rotateX(Math.PI / 2);             // GridHelper lies in xz; the ground is xy
  scene.add(grid);

  // The camera is placed by fitCamera() once the poses are applied (loadModel).
}

/** The bounding sphere of the model at its current pose: every link origin and every drawn
 * primitive visual, and what `current.framed` adds (the workspace cloud and the IK ghosts while
 * they are shown). */
export function modelSphere() {
  const box = new THREE.Box3();
  if (current.lastPoses) for (const pose of Object.values(current.lastPoses)) box.expandByPoint(new THREE.Vector3(...pose.position));
  if (robot) {
    robot.updateMatrixWorld(true);
    for (const group of Object.values(current.linkGroups)) {
      for (const child of group.children) if (child.isMesh || child.userData.visual) box.expandByObject(child);
    }
  }
  for (const frame of current.framed) frame(box);
  const sphere = new THREE.Sphere();
  if (box.isEmpty()) return new THREE.Sphere(new THREE.Vector3(), 0.5);
  box.getBoundingSphere(sphere);
  sphere.radius = Math.max(sphere.radius, 0.05);
  return sphere;
}

/** Frame the whole model: its bounding sphere (current pose) fills the narrower of the two fields
 * of view (vertical, or horizontal on a narrow canvas), seen from `direction` (default: the current
 * view direction, or a three-quarter view from above for a fresh model). */
export function fitCamera(direction = null) {
  const sphere = modelSphere();
  const dir = direction
    ? new THREE.Vector3(...direction).normalize()
    : camera.position.clone().sub(controls.target).normalize();
  if (!(dir.lengthSq() > 0.5)) dir.set(...FIT_DIRECTION).normalize();
  const vHalf = THREE.MathUtils.degToRad(camera.fov / 2);
  const hHalf = Math.atan(Math.tan(vHalf) * camera.aspect);
  const distance = FIT_MARGIN * sphere.radius / Math.sin(Math.min(vHalf, hHalf));
  camera.near = Math.min(Math.max(distance - 4 * sphere.radius, distance / 1000), sphere.radius / 50);
  camera.far = distance + 200 * sphere.radius;
  camera.position.copy(sphere.center).addScaledVector(dir, distance);
  camera.updateProjectionMatrix();
  controls.target.copy(sphere.center);
  controls.update();
  state.fits += 1;
  requestRender();
}

/** The smallest of 1, 2, 5 x 10^k not below x. */
export function niceStep(x) {
  const p = Math.pow(10, Math.floor(Math.log10(x)));
  for (const m of [1, 2, 5, 10]) if (m * p >= x) return m * p;
  return 10 * p;
}

export function applyPoses(poses) {
  current.lastPoses = poses;
  for (const [link, group] of Object.entries(current.linkGroups)) {
    const pose = poses[link];
    if (!pose) continue;
    group.matrix.copy(matrixFromRows(pose.matrix));
    group.matrixWorldNeedsUpdate = true;
  }
  for (const { joint, mesh, ball } of bones) {
    const a = new THREE.Vector3(...poses[joint.parent].position);
    const b = new THREE.Vector3(...poses[joint.child].position);
    const length = a.distanceTo(b);
    mesh.visible = length > 1e-9;
    mesh.position.copy(a);
    if (mesh.visible) mesh.quaternion.setFromUnitVectors(Z_AXIS, b.clone().sub(a).divideScalar(length));
    mesh.scale.set(1, 1, Math.max(length, 1e-9));
    ball.position.copy(b);
  }
  for (const { joint, arrow } of axisArrows) {
    const T = matrixFromRows(poses[joint.child].matrix);
    const direction = new THREE.Vector3(...joint.axis).transformDirection(T);
    arrow.position.setFromMatrixPosition(T);
    arrow.quaternion.setFromUnitVectors(Z_AXIS, direction);
  }
  highlightSelected();
  requestRender();
}

export function highlightSelected() {
  for (const [link, group] of Object.entries(current.linkGroups)) {
    const triad = group.getObjectByName("triad");
    if (triad) triad.scale.setScalar(current.modelSize * TRIAD_FRACTION * (link === state.selectedLink ? SELECTED_TRIAD_SCALE : 1));
  }
}

// ---------------------------------------------------------------------------- self-collision
/** Link -> the rods into it: what is drawn red for a link without visuals (a stick figure). */
function bonesByLink() {
  const out = {};
  for (const { mesh } of bones) (out[mesh.userData.link] ||= []).push(mesh);
  return out;
}

/** Ask whether configuration `q` (the one drawn) is in self-collision; its colliding links turn red. */
export function checkCollision(q) {
  if (!current.model || !robot) return;
  const built = robot;
  requestCollision(current.model.id, q, (links) => colourLinks(current.linkGroups, links, bonesByLink()), () => robot === built);
}

// Test hook: the colours (hex numbers) a link's visuals (or its rod) are drawn in now.
window.viewerDebug = Object.assign(window.viewerDebug || {}, {
  linkColours: (link) => linkColours(current.linkGroups, link, bonesByLink()),
});

// ---------------------------------------------------------------------------- sliders
export function fmt(x, digits = DIGITS) {
  if (x === null || x === undefined) return "-";
  if (typeof x === "string") return x;
  if (!Number.isFinite(x)) return String(x);
  const v = Math.abs(x) < 0.5 * Math.pow(10, -digits) ? 0 : x;   // no "-0.0000"
  return v.toFixed(digits);
}

/** The joint sliders of `info`, set to `q` (default: q = 0 clamped into the limits). */
export function buildSliders(info, q = null) {
  const container = $("sliders");
  container.replaceChildren();
  current.sliders = [];
  const byName = Object.fromEntries(info.joints.map((j) => [j.name, j]));
  if (info.joint_names.length === 0) {
    const p = document.createElement("p");
    p.className = "hint";
    p.textContent = "This model has no moving joint.";
    container.appendChild(p);
  }
  info.joint_names.forEach((name, i) => {
    const joint = byName[name];
    const [lower, upper] = sliderRange(joint);
    const initial = q ? q[i] : initialValue(joint);
    const div = document.createElement("div");
    div.className = "slider";
    div.innerHTML = `<div class="label"><span class="name"></span><span class="value"></span></div>
      <input type="range"><div class="range"></div>`;
    div.querySelector(".name").textContent = name;
    div.querySelector(".name").title = `${name} (${joint.type}) ${joint.parent} -> ${joint.child}`;
    const input = div.querySelector("input");
    input.min = String(lower);
    input.max = String(upper);
    input.step = String((upper - lower) / SLIDER_STEPS);
    input.value = String(initial);
    input.dataset.joint = name;
    input.dataset.index = String(i);
    input.setAttribute("aria-label", name);
    const unit = joint.type === "prismatic" ? "m" : "rad";
    const limited = joint.limits ? "" : " (no limits)";
    div.querySelector(".range").textContent = `${joint.type} [${fmt(lower, 3)}, ${fmt(upper, 3)}] ${unit}${limited}`;
    const slider = { name, joint, input, div, lower, upper, value: initial };
    input.addEventListener("input", () => {
      slider.value = Number(input.value);
      showSliderValue(slider);
      snapTargetAfterFk = true;          // a hand-made move: the IK target follows the link
      requestFk();
    });
    showSliderValue(slider);
    current.sliders.push(slider);
    container.appendChild(div);
  });
}

export function showSliderValue(slider) {
  const text = slider.joint.type === "prismatic"
    ? `${fmt(slider.value)} m`
    : `${fmt(slider.value)} (${fmt(slider.value * 180 / Math.PI, 1)}°)`;
  slider.div.querySelector(".value").textContent = text;
}

/** Set every joint (the slider thumbs snap to their step; `slider.value` keeps the exact value,
 * which the label shows and FK, IK seeds and the test hook use). An IK answer leaves the IK
 * target where it is; any other change moves the target onto the link. */
export function setAll(values, { fromIk = false } = {}) {
  current.sliders.forEach((s, i) => {
    s.value = values[i];
    s.input.value = String(values[i]);
    showSliderValue(s);
  });
  if (!fromIk) snapTargetAfterFk = true;
  requestFk();
}

export function currentQ() {
  return current.sliders.map((s) => s.value);
}

// ---------------------------------------------------------------------------- FK / Jacobian
export function requestFk() {
  if (!current.model) return;
  if (fkInFlight) { fkPending = true; return; }
  runFk();
}

export async function runFk() {
  fkInFlight = true;
  fkPending = false;
  const id = current.model.id;
  const token = current.loadToken;
  const q = currentQ();
  state.fkRequests += 1;
  try {
    const answer = await api(`/models/${encodeURIComponent(id)}/fk`, { method: "POST", body: { q, links: FK_LINKS_ALL } });
    if (token !== current.loadToken) return;
    state.fkResponses += 1;
    state.lastQ = q;
    applyPoses(answer.poses);
    checkCollision(q);
    if (snapTargetAfterFk && !fkPending) {
      snapTargetAfterFk = false;
      emit("link-moved");                // by hand, not by IK: the IK target follows (ik.js)
    }
    showOutOfLimits(answer.out_of_limits || []);
    emit("fk-drawn", q);                 // the link velocities follow (velocity.js)
    await showSelectedPose(q);
  } catch (err) {
    showError(err);
  } finally {
    fkInFlight = false;
    if (fkPending && token === current.loadToken) runFk();
  }
}

export function showOutOfLimits(names) {
  const el = $("out-of-limits");
  const list = Array.isArray(names[0]) ? names[0] : names;
  current.sliders.forEach((s) => s.div.classList.toggle("out", list.includes(s.name)));
  el.hidden = list.length === 0;
  el.textContent = list.length ? `Outside limits: ${list.join(", ")}` : "";
}

export async function showSelectedPose(q) {
  const link = state.selectedLink;
  if (!link || !current.lastPoses || !current.lastPoses[link]) return;
  const pose = current.lastPoses[link];
  const quat = pose.quaternion;
  $("pose-link").textContent = link;
  $("pose-position").textContent = pose.position.map((v) => fmt(v)).join(", ");
  $("pose-quaternion").textContent = [quat.w, quat.x, quat.y, quat.z].map((v) => fmt(v)).join(", ");
  $("pose-rpy").textContent = pose.rpy.map((v) => fmt(v)).join(", ");
  $("pose-rpy-deg").textContent = pose.rpy.map((v) => fmt(v * 180 / Math.PI, 2)).join(", ");
  state.lastPose = { link, position: pose.position, quaternion: quat, rpy: pose.rpy };
  const id = current.model.id;
  const seq = ++jacobianSeq;             // only the latest answer is shown
  state.jacobianRequests += 1;
  try {
    const jac = await api(`/models/${encodeURIComponent(id)}/jacobian`, {
      method: "POST", body: { q: q || currentQ(), link, reference: JACOBIAN_REFERENCE },
    });
    if (seq !== jacobianSeq || !current.model || current.model.id !== id || state.selectedLink !== link) return;
    $("pose-manipulability").textContent = fmt(jac.manipulability, 6);
    // JSON has no infinity: a singular Jacobian's condition number may come as null or a string
    const cond = jac.condition_number;
    $("pose-condition").textContent = cond === null || cond === "inf" || cond === "Infinity" ? "∞ (singular)" : fmt(cond, 3);
    state.lastPose.manipulability = jac.manipulability;
  } catch (err) {
    if (seq !== jacobianSeq) return;
    $("pose-manipulability").textContent = "-";
    $("pose-condition").textContent = "-";
    showError(err);
  }
}

$("btn-fit").addEventListener("click", () => { if (current.model) fitCamera(); });
