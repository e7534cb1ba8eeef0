// Model viewer: draws a model of the service as a kinematic skeleton and lets a person move
// its joints, or drag an IK target for a link. All kinematics comes from the service
// (POST /models/{id}/fk, /jacobian, /ik): this file does no robotics math, it only places what
// the service returns. The "Closed form" tab and the DH editor show the service's closed forms
// (POST /models/{id}/symbolic, /symbolic/dh, format latex), typeset by the vendored KaTeX
// (vendor/katex/, a classic script defining window.katex).
//
// Frames: the scene is the world frame of the model (the root link's frame), z up, metres.
// Every link pose comes from FK with links "all" as T_world_link (row-major 4x4). There is no
// conversion between the two: the camera's up vector is +z instead (no y-up rotation of the
// robot), so a scene object's position and quaternion are a pose in the model's world frame,
// which is what the IK target gizmo sends to POST /models/{id}/ik.

import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { TransformControls } from "three/addons/controls/TransformControls.js";

const ROOT = document.body.dataset.root || "";
const FK_LINKS_ALL = "all";
const JACOBIAN_REFERENCE = "local_world_aligned";
const CONTINUOUS_RANGE = Math.PI;         // slider range of a joint without limits (rad)
const UNLIMITED_PRISMATIC_RANGE = 1.0;    // slider range of an unlimited prismatic joint (m)
const SLIDER_STEPS = 10000;
const VISUAL_OPACITY = 0.35;
const TRIAD_FRACTION = 0.05;              // link triad length / model size
const SELECTED_TRIAD_SCALE = 2.2;         // the selected link's triad is drawn this much larger
const AXIS_ARROW_FRACTION = 0.1;          // joint axis arrow length / model size
const DIGITS = 4;
const API_KEY_STORAGE = "kinematics-api-key";  // sessionStorage: forgotten when the tab closes
const IK_THROTTLE_MS = 100;               // while dragging: at most one IK request per this, one in flight
const IK_DRAG_RESTARTS = 0;               // while dragging: follow from the current q only (smooth, fast)
const IK_TARGET_OPACITY = 0.45;           // the target's ghost triad
const FIT_DIRECTION = [1.0, -1.3, 0.8];   // the view direction (from the model) of a freshly loaded model
const FIT_MARGIN = 1.15;                  // the bounding sphere fills 1 / FIT_MARGIN of the narrower field of view
const CLOUD_POINT_FRACTION = 0.02;        // workspace point size / model size
const CLOUD_COLOR_QUANTILE = 0.95;        // the colour scale tops out at this quantile of the manipulability
const VELOCITY_ARROW_FRACTION = 0.33;     // the longest velocity arrow / model size

// Test hook (tests/app/test_viewer.py reads it); also handy from the browser console.
const state = {
  ready: false,
  modelId: null,
  fkRequests: 0,
  fkResponses: 0,
  jacobianRequests: 0,
  selectedLink: null,
  lastQ: null,        // q (joint_names order) of the poses drawn
  lastPose: null,
  lastError: null,
  dhBuilt: null,
  dhBuilds: 0,
  renders: 0,
  fits: 0,
  workspace: null,    // {link, samples, points, maxManipulability}
  wsRequests: 0,
  wsResponses: 0,
  velocityRequests: 0,
  velocityResponses: 0,
  velocityArrows: 0,  // arrows drawn (links whose origin moves)
  lastVelocity: null, // {q, qdot, linear: {link: [vx, vy, vz]}}
  ikEnabled: false,
  ikRequests: 0,
  ikResponses: 0,
  ikBusy: false,      // a request in flight, or a target change not sent yet
  ikLast: null,       // {link, mode, target, seed, q, success, position_error, rotation_error, iterations}
  ikStatus: "",
  cfRequests: 0,
  cfResponses: 0,
  closedForm: null,   // {tip, ok, katex (elements typeset), items, status}
  dhClosed: null,     // {ok, parameters, katex, status}
};
window.viewerState = state;

const $ = (id) => document.getElementById(id);

// ---------------------------------------------------------------------------- API
class ApiError extends Error {
  constructor(message, status = null, type = null) {
    super(message);
    this.status = status;   // HTTP status of a problem answer
    this.type = type;       // its problem type (urn:kinematics:problem:<slug>)
  }
}

async function api(path, { method = "GET", body, text = false, binary = null } = {}) {
  const init = { method, headers: {} };
  if (binary) init.headers.Accept = binary;
  const key = sessionStorage.getItem(API_KEY_STORAGE);
  if (key) init.headers["X-API-Key"] = key;
  if (body !== undefined) {
    init.headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(body);
  }
  let response;
  try {
    response = await fetch(ROOT + path, init);
  } catch (err) {
    throw new ApiError(`${method} ${path}: the service cannot be reached (${err.message})`);
  }
  if (!response.ok) {
    let detail = `${response.status} ${response.statusText}`;
    let type = null;
    try {
      const problem = await response.json();
      if (problem && typeof problem.type === "string") type = problem.type;
      if (problem && problem.detail !== undefined) {
        detail = typeof problem.detail === "string" ? problem.detail : JSON.stringify(problem.detail);
      } else if (problem && problem.title) {
        detail = problem.title;
      }
    } catch (_) { /* not JSON: keep the status line */ }
    throw new ApiError(`${method} ${path}: ${detail}`, response.status, type);
  }
  if (binary) return response.arrayBuffer();
  return text ? response.text() : response.json();
}

function showError(err) {
  const message = err instanceof Error ? err.message : String(err);
  state.lastError = message;
  $("error-text").textContent = message;
  $("error").hidden = false;
  console.warn(message);
}

function clearError() {
  $("error").hidden = true;
  state.lastError = null;
}

// ---------------------------------------------------------------------------- scene
const host = $("canvas-host");
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
renderer.setClearColor(0xf7f8fa, 1);
host.appendChild(renderer.domElement);

const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(45, 1, 0.001, 1000);
camera.up.set(0, 0, 1);                   // robotics convention: z up
camera.position.set(1.5, -1.5, 1.2);
// The IK target gizmo is created before the orbit controls so that its pointerdown handler runs
// first: grabbing a handle turns orbiting off before the orbit controls see the press.
const gizmo = new TransformControls(camera, renderer.domElement);
const controls = new OrbitControls(camera, renderer.domElement);
controls.addEventListener("change", () => requestRender());

scene.add(new THREE.HemisphereLight(0xffffff, 0x8890a0, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(2, -3, 5);
scene.add(sun);

let grid = null;                          // ground grid in the world xy plane
let cloud = null;                         // THREE.Points: the sampled workspace of the selected link
let robot = null;                         // THREE.Group holding the current model's objects

let renderQueued = false;
function requestRender() {
  if (renderQueued) return;
  renderQueued = true;
  requestAnimationFrame(() => {
    renderQueued = false;
    renderer.render(scene, camera);
    state.renders += 1;
  });
}

function resize() {
  const w = Math.max(1, host.clientWidth);
  const h = Math.max(1, host.clientHeight);
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  requestRender();
}
new ResizeObserver(resize).observe(host);

/** THREE.Matrix4 from a row-major nested 4x4 list (the API's `matrix`). */
function matrixFromRows(rows) {
  const m = new THREE.Matrix4();
  m.set(...rows[0], ...rows[1], ...rows[2], ...rows[3]);
  return m;
}

/** A mesh for one primitive visual (box/cylinder/sphere), in its link's frame; null for meshes. */
function visualObject(visual, material) {
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
const Z_AXIS = new THREE.Vector3(0, 0, 1);
const COLORS = { x: 0xd62728, y: 0x2ca02c, z: 0x1f5fd6, bone: 0x3b4256, revolute: 0xe0a000, prismatic: 0xb0179a };

/** A solid arrow of unit length along +z (shaft from `from` to 1 - head, then a cone). */
function unitArrowGeometry(from = 0, headFraction = 0.28, shaftRadius = 0.045, headRadius = 0.11) {
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
function makeTriad(length, geometries, materials) {
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

// ---------------------------------------------------------------------------- model state
let model = null;       // GET /models/{id}
let sliders = [];       // one per entry of joint_names: {name, input, value, lower, upper, type}
let linkGroups = {};    // link name -> THREE.Group (matrix = T_world_link)
let bones = [];         // {joint, mesh}: a rod from the parent link origin to the child link origin
let axisArrows = [];    // {joint, arrow}: the joint axis through the joint (= child link) origin
let lastPoses = null;   // link -> pose object of the last FK answer
let fkInFlight = false;
let fkPending = false;
let modelSize = 1;
let loadToken = 0;
let jacobianSeq = 0;
let snapTargetAfterFk = false;  // the next settled FK answer moves the IK target onto the link

function disposeRobot() {
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

function buildRobot(info, visuals, poses) {
  disposeRobot();
  robot = new THREE.Group();
  linkGroups = {};
  bones = [];
  axisArrows = [];

  // Size of the model at the first configuration: sets triad size, arrows and the camera.
  const box = new THREE.Box3();
  for (const link of info.links) box.expandByPoint(new THREE.Vector3(...poses[link].position));
  const extent = box.getSize(new THREE.Vector3()).length();
  modelSize = Math.max(extent, 0.2);
  const triadLength = modelSize * TRIAD_FRACTION;
  const rodRadius = modelSize * 0.006;

  const triadGeometries = unitArrowGeometry(0, 0.25, 0.05, 0.12);
  const triadMaterials = {
    x: new THREE.MeshBasicMaterial({ color: COLORS.x }),
    y: new THREE.MeshBasicMaterial({ color: COLORS.y }),
    z: new THREE.MeshBasicMaterial({ color: COLORS.z }),
  };
  const visualMaterial = new THREE.MeshStandardMaterial({
    color: 0x8fa3bf, transparent: true, opacity: VISUAL_OPACITY, depthWrite: false, side: THREE.DoubleSide,
  });
  for (const link of info.links) {
    const group = new THREE.Group();
    group.matrixAutoUpdate = false;
    group.name = link;
    const triad = makeTriad(triadLength, triadGeometries, triadMaterials);
    triad.name = "triad";
    group.add(triad);
    for (const v of (visuals && visuals[link]) || []) {
      const mesh = visualObject(v, visualMaterial);
      if (mesh) group.add(mesh);
    }
    linkGroups[link] = group;
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
    bones.push({ joint, mesh, ball });
    robot.add(mesh, ball);
  }

  // Joint axes: arrows through the child link origin along the joint axis (the axis is given
  // in the joint frame, which is the child link frame), centred on the joint.
  const arrowLength = modelSize * AXIS_ARROW_FRACTION;
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

  // Ground grid (1 2 5 steps) and world axes scaled to the model.
  if (grid) { scene.remove(grid); grid.geometry.dispose(); grid.material.dispose(); }
  const step = niceStep(modelSize / 5);
  grid = new THREE.GridHelper(step * 20, 20, 0x9aa1b1, 0xd3d7df);
  grid.rotateX(Math.PI / 2);             // GridHelper lies in xz; the ground is xy
  scene.add(grid);

  // The camera is placed by fitCamera() once the poses are applied (loadModel).
}

/** The bounding sphere of the model at its current pose: every link origin and every drawn
 * primitive visual (and the workspace cloud while it is shown). */
function modelSphere() {
  const box = new THREE.Box3();
  if (lastPoses) for (const pose of Object.values(lastPoses)) box.expandByPoint(new THREE.Vector3(...pose.position));
  if (robot) {
    robot.updateMatrixWorld(true);
    for (const group of Object.values(linkGroups)) {
      for (const child of group.children) if (child.isMesh) box.expandByObject(child);
    }
  }
  if (cloud && cloud.visible) {
    cloud.geometry.computeBoundingBox();
    box.union(cloud.geometry.boundingBox);
  }
  const sphere = new THREE.Sphere();
  if (box.isEmpty()) return new THREE.Sphere(new THREE.Vector3(), 0.5);
  box.getBoundingSphere(sphere);
  sphere.radius = Math.max(sphere.radius, 0.05);
  return sphere;
}

/** Frame the whole model: its bounding sphere (current pose) fills the narrower of the two fields
 * of view (vertical, or horizontal on a narrow canvas), seen from `direction` (default: the current
 * view direction, or a three-quarter view from above for a fresh model). */
function fitCamera(direction = null) {
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
function niceStep(x) {
  const p = Math.pow(10, Math.floor(Math.log10(x)));
  for (const m of [1, 2, 5, 10]) if (m * p >= x) return m * p;
  return 10 * p;
}

function applyPoses(poses) {
  lastPoses = poses;
  for (const [link, group] of Object.entries(linkGroups)) {
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

function highlightSelected() {
  for (const [link, group] of Object.entries(linkGroups)) {
    const triad = group.getObjectByName("triad");
    if (triad) triad.scale.setScalar(modelSize * TRIAD_FRACTION * (link === state.selectedLink ? SELECTED_TRIAD_SCALE : 1));
  }
}

// ---------------------------------------------------------------------------- sliders
function fmt(x, digits = DIGITS) {
  if (x === null || x === undefined) return "-";
  if (typeof x === "string") return x;
  if (!Number.isFinite(x)) return String(x);
  const v = Math.abs(x) < 0.5 * Math.pow(10, -digits) ? 0 : x;   // no "-0.0000"
  return v.toFixed(digits);
}

function sliderRange(joint) {
  const lim = joint.limits;
  const finite = lim && Number.isFinite(lim.lower) && Number.isFinite(lim.upper) && lim.upper > lim.lower;
  if (finite) return [lim.lower, lim.upper];
  if (joint.type === "prismatic") return [-UNLIMITED_PRISMATIC_RANGE, UNLIMITED_PRISMATIC_RANGE];
  return [-CONTINUOUS_RANGE, CONTINUOUS_RANGE];
}

function initialValue(joint) {
  const [lower, upper] = sliderRange(joint);
  return Math.min(Math.max(0, lower), upper);
}

function buildSliders(info) {
  const container = $("sliders");
  container.replaceChildren();
  sliders = [];
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
    const initial = initialValue(joint);
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
    sliders.push(slider);
    container.appendChild(div);
  });
}

function showSliderValue(slider) {
  const text = slider.joint.type === "prismatic"
    ? `${fmt(slider.value)} m`
    : `${fmt(slider.value)} (${fmt(slider.value * 180 / Math.PI, 1)}°)`;
  slider.div.querySelector(".value").textContent = text;
}

/** Set every joint (the slider thumbs snap to their step; `slider.value` keeps the exact value,
 * which the label shows and FK, IK seeds and the test hook use). An IK answer leaves the IK
 * target where it is; any other change moves the target onto the link. */
function setAll(values, { fromIk = false } = {}) {
  sliders.forEach((s, i) => {
    s.value = values[i];
    s.input.value = String(values[i]);
    showSliderValue(s);
  });
  if (!fromIk) snapTargetAfterFk = true;
  requestFk();
}

function currentQ() {
  return sliders.map((s) => s.value);
}

// ---------------------------------------------------------------------------- FK / Jacobian
function requestFk() {
  if (!model) return;
  if (fkInFlight) { fkPending = true; return; }
  runFk();
}

async function runFk() {
  fkInFlight = true;
  fkPending = false;
  const id = model.id;
  const token = loadToken;
  const q = currentQ();
  state.fkRequests += 1;
  try {
    const answer = await api(`/models/${encodeURIComponent(id)}/fk`, { method: "POST", body: { q, links: FK_LINKS_ALL } });
    if (token !== loadToken) return;
    state.fkResponses += 1;
    state.lastQ = q;
    applyPoses(answer.poses);
    if (snapTargetAfterFk && !fkPending) {
      snapTargetAfterFk = false;
      if (ik.enabled && !gizmo.dragging && !ikBusy()) placeTargetAtLink();
    }
    showOutOfLimits(answer.out_of_limits || []);
    requestVelocity();
    await showSelectedPose(q);
  } catch (err) {
    showError(err);
  } finally {
    fkInFlight = false;
    if (fkPending && token === loadToken) runFk();
  }
}

function showOutOfLimits(names) {
  const el = $("out-of-limits");
  const list = Array.isArray(names[0]) ? names[0] : names;
  sliders.forEach((s) => s.div.classList.toggle("out", list.includes(s.name)));
  el.hidden = list.length === 0;
  el.textContent = list.length ? `Outside limits: ${list.join(", ")}` : "";
}

async function showSelectedPose(q) {
  const link = state.selectedLink;
  if (!link || !lastPoses || !lastPoses[link]) return;
  const pose = lastPoses[link];
  const quat = pose.quaternion;
  $("pose-link").textContent = link;
  $("pose-position").textContent = pose.position.map((v) => fmt(v)).join(", ");
  $("pose-quaternion").textContent = [quat.w, quat.x, quat.y, quat.z].map((v) => fmt(v)).join(", ");
  $("pose-rpy").textContent = pose.rpy.map((v) => fmt(v)).join(", ");
  $("pose-rpy-deg").textContent = pose.rpy.map((v) => fmt(v * 180 / Math.PI, 2)).join(", ");
  state.lastPose = { link, position: pose.position, quaternion: quat, rpy: pose.rpy };
  const id = model.id;
  const seq = ++jacobianSeq;             // only the latest answer is shown
  state.jacobianRequests += 1;
  try {
    const jac = await api(`/models/${encodeURIComponent(id)}/jacobian`, {
      method: "POST", body: { q: q || currentQ(), link, reference: JACOBIAN_REFERENCE },
    });
    if (seq !== jacobianSeq || !model || model.id !== id || state.selectedLink !== link) return;
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

// ---------------------------------------------------------------------------- IK target
// A TransformControls gizmo (three.js addon, vendored) moves `ikTarget`, a scene object drawn as
// a ghost triad. Its position and quaternion are T_world_target (the scene is the world frame,
// see the top of this file); every change while dragging asks POST /models/{id}/ik (throttled:
// one request in flight, at most one per IK_THROTTLE_MS, restarts off so the arm follows
// smoothly), and releasing the handle asks once more right away with the service's default
// random restarts. Every request is seeded with the current joint values; the answer's q
// becomes the sliders' values and is drawn by the usual FK request.
const ikTarget = new THREE.Group();
ikTarget.name = "ik-target";
ikTarget.visible = false;
scene.add(ikTarget);
scene.add(gizmo.getHelper());
gizmo.setSpace("world");

const ik = {
  enabled: false,
  inFlight: false,
  dirty: false,        // the target moved since the last request
  final: false,        // the next request is a drag end: no throttle, restarts on
  lastSent: -Infinity,
  timer: null,
  seq: 0,              // answers of an older sequence (reset target, other link/model) are dropped
  markerSize: 0,
};

function ikBusy() {
  return ik.inFlight || ik.dirty || ik.timer !== null;
}

function updateIkBusy() {
  state.ikBusy = ikBusy();
}

gizmo.addEventListener("change", () => requestRender());
gizmo.addEventListener("dragging-changed", (event) => {
  controls.enabled = !event.value;
  if (!event.value) requestIk({ final: true });   // drag end
});
gizmo.addEventListener("objectChange", () => { if (gizmo.dragging) requestIk(); });

/** The target's ghost triad, sized like the selected link's triad. */
function ensureTargetMarker() {
  const size = modelSize * TRIAD_FRACTION * SELECTED_TRIAD_SCALE * 1.25;
  if (ik.markerSize === size && ikTarget.children.length) return;
  for (const child of [...ikTarget.children]) {
    ikTarget.remove(child);
    child.traverse((o) => { if (o.geometry) o.geometry.dispose(); if (o.material) o.material.dispose(); });
  }
  const ghost = (color) => new THREE.MeshBasicMaterial({ color, transparent: true, opacity: IK_TARGET_OPACITY, depthWrite: false });
  const triad = makeTriad(size, unitArrowGeometry(0, 0.25, 0.05, 0.12), { x: ghost(COLORS.x), y: ghost(COLORS.y), z: ghost(COLORS.z) });
  const ball = new THREE.Mesh(new THREE.SphereGeometry(size * 0.12, 16, 10), ghost(0xff7f0e));
  ikTarget.add(triad, ball);
  ik.markerSize = size;
}

/** Put the target on the selected link's current pose (from the last FK answer). */
function placeTargetAtLink() {
  const pose = lastPoses && lastPoses[state.selectedLink];
  if (!pose) return false;
  matrixFromRows(pose.matrix).decompose(ikTarget.position, ikTarget.quaternion, ikTarget.scale);
  ikTarget.scale.set(1, 1, 1);
  ikTarget.updateMatrixWorld(true);
  requestRender();
  return true;
}

/** The target as POST /models/{id}/ik takes it: T_world_target, quaternion as {w, x, y, z}. */
function ikTargetPose() {
  const p = ikTarget.position;
  const q = ikTarget.quaternion;          // three.js keeps (x, y, z, w); the API names them
  return { position: [p.x, p.y, p.z], quaternion: { w: q.w, x: q.x, y: q.y, z: q.z } };
}

function setIkStatus(text, kind = "") {
  const el = $("ik-status");
  el.textContent = text;
  el.className = kind;
  state.ikStatus = text;
}

/** Drop pending and in-flight IK work and put the target back on the selected link. */
function resetIkTarget() {
  ik.seq += 1;
  ik.dirty = false;
  ik.final = false;
  clearTimeout(ik.timer);
  ik.timer = null;
  updateIkBusy();
  ensureTargetMarker();
  placeTargetAtLink();
  if (ik.enabled) {
    const link = state.selectedLink;
    setIkStatus(model && model.joint_names.length === 0
      ? "IK: this model has no moving joint."
      : `IK: drag the gizmo to move the target of ${link}.`);
  }
}

function setIkEnabled(on) {
  ik.enabled = Boolean(on) && model !== null;
  $("ik-enable").checked = ik.enabled;
  state.ikEnabled = ik.enabled;
  if (ik.enabled) {
    resetIkTarget();
    ikTarget.visible = true;
    gizmo.attach(ikTarget);
  } else {
    gizmo.detach();
    controls.enabled = true;
    ikTarget.visible = false;
    ik.seq += 1;
    ik.dirty = false;
    clearTimeout(ik.timer);
    ik.timer = null;
    updateIkBusy();
    setIkStatus("");
  }
  requestRender();
}

/** The target moved: ask for IK now (drag end) or when the throttle allows (while dragging). */
function requestIk({ final = false } = {}) {
  if (!ik.enabled || !model || model.joint_names.length === 0) return;
  ik.dirty = true;
  ik.final = ik.final || final;
  pumpIk();
}

function pumpIk() {
  if (!ik.dirty || ik.inFlight) { updateIkBusy(); return; }
  const wait = ik.lastSent + IK_THROTTLE_MS - performance.now();
  if (!ik.final && wait > 0) {
    if (ik.timer === null) ik.timer = setTimeout(() => { ik.timer = null; pumpIk(); }, wait);
    updateIkBusy();
    return;
  }
  clearTimeout(ik.timer);
  ik.timer = null;
  sendIk();
}

function fmtError(x) {
  if (!Number.isFinite(x)) return String(x);
  if (x === 0) return "0";
  return Math.abs(x) < 1e-3 ? x.toExponential(1) : x.toPrecision(3);
}

async function sendIk() {
  const id = model.id;
  const token = loadToken;
  const seq = ik.seq;
  const link = state.selectedLink;
  const mode = $("ik-mode").value;
  const final = ik.final;
  const target = ikTargetPose();
  const seed = currentQ();
  const body = { link, target, seed, mode };
  if (!final) body.restarts = IK_DRAG_RESTARTS;
  ik.dirty = false;
  ik.final = false;
  ik.inFlight = true;
  ik.lastSent = performance.now();
  state.ikRequests += 1;
  updateIkBusy();
  try {
    const answer = await api(`/models/${encodeURIComponent(id)}/ik`, { method: "POST", body });
    state.ikResponses += 1;
    if (token !== loadToken || seq !== ik.seq || !ik.enabled) return;
    const byName = Object.fromEntries(answer.joint_names.map((name, i) => [name, answer.q[i]]));
    const q = sliders.map((s) => (Number.isFinite(byName[s.name]) ? byName[s.name] : s.value));
    state.ikLast = {
      link, mode, target, seed, q, final, success: answer.success, position_error: answer.position_error,
      rotation_error: answer.rotation_error, iterations: answer.iterations,
    };
    setAll(q, { fromIk: true });
    const errors = mode === "position"
      ? `position error ${fmtError(answer.position_error)} m`
      : `position error ${fmtError(answer.position_error)} m, rotation error ${fmtError(answer.rotation_error)} rad`;
    if (answer.success) {
      setIkStatus(`IK: solved in ${answer.iterations} iterations (${errors})`, "ok");
    } else {
      setIkStatus(`IK: not reachable — best effort shown (${errors})`, "warn");
    }
  } catch (err) {
    state.ikResponses += 1;
    if (token !== loadToken || seq !== ik.seq) return;
    setIkStatus("IK: the request failed (see the message above).", "warn");
    showError(err);
  } finally {
    ik.inFlight = false;
    pumpIk();                            // a target change made meanwhile (for the model shown now)
    updateIkBusy();
  }
}

$("ik-enable").addEventListener("change", () => setIkEnabled($("ik-enable").checked));
$("ik-gizmo-mode").addEventListener("change", () => { gizmo.setMode($("ik-gizmo-mode").value); requestRender(); });
$("ik-mode").addEventListener("change", () => requestIk({ final: true }));
$("ik-reset").addEventListener("click", () => { if (ik.enabled) resetIkTarget(); });

// Test hook for the IK target (tests/app/test_viewer.py); also handy from the browser console.
function settled() {
  return !ikBusy() && !fkInFlight && !fkPending;
}

async function whenSettled() {
  while (!settled()) await new Promise((resolve) => setTimeout(resolve, 10));
}

window.viewerTest = {
  setIkEnabled(on) { setIkEnabled(on); return ik.enabled; },
  setGizmoMode(mode) { $("ik-gizmo-mode").value = mode; gizmo.setMode(mode); requestRender(); },
  /** Move the target to `position` [x, y, z] and `quaternion` {w, x, y, z} (world frame) and
   * run what a drag end runs; resolves when the answer is drawn. */
  async ikTo(position, quaternion) {
    if (!ik.enabled) throw new Error("the IK target is off");
    ikTarget.position.set(...position);
    ikTarget.quaternion.set(quaternion.x, quaternion.y, quaternion.z, quaternion.w).normalize();
    ikTarget.updateMatrixWorld(true);
    requestRender();
    requestIk({ final: true });
    await whenSettled();
    return { q: currentQ(), status: state.ikStatus, last: state.ikLast };
  },
  whenSettled: async () => { await whenSettled(); return true; },
  /** Canvas (CSS pixel) coordinates of every link origin as the camera sees it now, and the
   * canvas size: {width, height, points: {link: [x, y, depth]}} (depth in (-1, 1) when between
   * the near and far planes). */
  projectLinks() {
    camera.updateMatrixWorld();
    const rect = renderer.domElement.getBoundingClientRect();
    const points = {};
    for (const [link, pose] of Object.entries(lastPoses || {})) {
      const p = new THREE.Vector3(...pose.position).project(camera);
      points[link] = [(p.x + 1) / 2 * rect.width, (1 - p.y) / 2 * rect.height, p.z];
    }
    return { width: rect.width, height: rect.height, points };
  },
  fit: () => { fitCamera(); return state.fits; },
  /** Move the camera (a zoom or orbit by hand), e.g. to test the fit button. */
  moveCamera(position, target) {
    camera.position.set(...position);
    controls.target.set(...target);
    controls.update();
    requestRender();
  },
  async sampleWorkspace(samples = 5000) {
    $("ws-samples").value = String(samples);
    const before = state.wsResponses;
    sampleWorkspace();
    while (state.wsResponses === before) await new Promise((resolve) => setTimeout(resolve, 20));
    return state.workspace;
  },
  /** Set the joint velocities and wait for their arrows. */
  async setQdot(values) {
    qdotInputs.forEach((input, i) => { input.value = String(values[i]); });
    const before = state.velocityResponses;
    requestVelocity();
    if (values.every((v) => v === 0)) return state.lastVelocity;
    while (state.velocityResponses === before || velocityInFlight || velocityPending) {
      await new Promise((resolve) => setTimeout(resolve, 20));
    }
    return state.lastVelocity;
  },
  /** The exact joint values (the thumbs of the range inputs are rounded to their step). */
  sliderValues: () => currentQ(),
  targetPose: () => ikTargetPose(),
  /** Client (CSS pixel) coordinates of a point on the translate gizmo's handle for `axis`
   * ("X", "Y" or "Z"), for a real mouse drag. Mirrors TransformControls' own handle scale:
   * its pickers run from 0 to 0.6 along the axis in units of factor * size / 4. */
  gizmoHandlePoint(axis = "X", along = 0.45) {
    camera.updateMatrixWorld();
    const factor = ikTarget.position.distanceTo(camera.position)
      * Math.min(1.9 * Math.tan(Math.PI * camera.fov / 360) / camera.zoom, 7);
    const unit = { X: [1, 0, 0], Y: [0, 1, 0], Z: [0, 0, 1] }[axis];
    const point = new THREE.Vector3(...unit).multiplyScalar(along * factor * gizmo.size / 4).add(ikTarget.position);
    point.project(camera);
    const rect = renderer.domElement.getBoundingClientRect();
    return { x: rect.left + (point.x + 1) / 2 * rect.width, y: rect.top + (1 - point.y) / 2 * rect.height };
  },
};

// ---------------------------------------------------------------------------- fit
$("btn-fit").addEventListener("click", () => { if (model) fitCamera(); });

// ---------------------------------------------------------------------------- workspace cloud
// POST /models/{id}/workspace with Accept: application/x-npy answers an (N, 4) float64 array of
// rows x, y, z, manipulability (world frame): drawn as points coloured by manipulability / max.
let wsSeq = 0;

/** The float64 array of a NumPy .npy file (format 1.x/2.x, little-endian '<f8', C order) and its shape. */
function parseNpy(buffer) {
  const bytes = new Uint8Array(buffer);
  if (bytes[0] !== 0x93 || String.fromCharCode(...bytes.slice(1, 6)) !== "NUMPY") throw new Error("not a .npy answer");
  const major = bytes[6];
  const view = new DataView(buffer);
  const headerLength = major === 1 ? view.getUint16(8, true) : view.getUint32(8, true);
  const start = (major === 1 ? 10 : 12) + headerLength;
  const header = new TextDecoder().decode(bytes.slice(major === 1 ? 10 : 12, start));
  if (!header.includes("'<f8'") || header.includes("'fortran_order': True")) throw new Error(`unexpected .npy header ${header}`);
  const shape = (header.match(/'shape': \(([^)]*)\)/)[1]).split(",").filter((x) => x.trim()).map(Number);
  return { data: new Float64Array(buffer, start), shape };
}

/** Viridis at t in [0, 1] (five stops, linear between them). */
const VIRIDIS = [[0x44, 0x01, 0x54], [0x3b, 0x52, 0x8b], [0x21, 0x91, 0x8c], [0x5e, 0xc9, 0x62], [0xfd, 0xe7, 0x25]];
function viridis(t, out, k) {
  const x = Math.min(Math.max(t, 0), 1) * (VIRIDIS.length - 1);
  const i = Math.min(Math.floor(x), VIRIDIS.length - 2);
  const f = x - i;
  for (let c = 0; c < 3; c++) out[k + c] = (VIRIDIS[i][c] + f * (VIRIDIS[i + 1][c] - VIRIDIS[i][c])) / 255;
}

function clearWorkspace() {
  wsSeq += 1;
  if (cloud) {
    scene.remove(cloud);
    cloud.geometry.dispose();
    cloud.material.dispose();
    cloud = null;
  }
  state.workspace = null;
  $("ws-show").disabled = true;
  $("ws-clear").disabled = true;
  $("ws-colorbar").hidden = true;
  $("ws-status").textContent = "";
  requestRender();
}

function setWsStatus(text, kind = "") {
  $("ws-status").textContent = text;
  $("ws-status").className = kind;
}

async function sampleWorkspace() {
  if (!model) return;
  const id = model.id;
  const link = state.selectedLink;
  const samples = Math.round(Number($("ws-samples").value) || 20000);
  const seed = Math.round(Number($("ws-seed").value) || 0);
  const seq = ++wsSeq;
  state.wsRequests += 1;
  setWsStatus(`Sampling ${samples} configurations for ${link}...`);
  try {
    const body = { link, samples, random_seed: seed };
    const [buffer, summary] = await Promise.all([
      api(`/models/${encodeURIComponent(id)}/workspace`, { method: "POST", body, binary: "application/x-npy" }),
      api(`/models/${encodeURIComponent(id)}/workspace`, { method: "POST", body }),
    ]);
    state.wsResponses += 1;
    if (seq !== wsSeq || !model || model.id !== id) return;
    const { data, shape } = parseNpy(buffer);
    const n = shape[0];
    const positions = new Float32Array(3 * n);
    const colors = new Float32Array(3 * n);
    let best = 0;
    const values = new Float64Array(n);
    for (let i = 0; i < n; i++) { values[i] = data[4 * i + 3]; best = Math.max(best, values[i]); }
    values.sort();
    const top = n ? values[Math.min(n - 1, Math.floor(CLOUD_COLOR_QUANTILE * n))] || best : 0;
    for (let i = 0; i < n; i++) {
      positions[3 * i] = data[4 * i];
      positions[3 * i + 1] = data[4 * i + 1];
      positions[3 * i + 2] = data[4 * i + 2];
      viridis(top > 0 ? data[4 * i + 3] / top : 0, colors, 3 * i);
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute("position", new THREE.BufferAttribute(positions, 3));
    geometry.setAttribute("color", new THREE.BufferAttribute(colors, 3));
    const material = new THREE.PointsMaterial({ size: modelSize * CLOUD_POINT_FRACTION, vertexColors: true,
                                                 transparent: true, opacity: 0.7, depthWrite: false });
    if (cloud) { scene.remove(cloud); cloud.geometry.dispose(); cloud.material.dispose(); }
    cloud = new THREE.Points(geometry, material);
    cloud.name = "workspace-cloud";
    cloud.visible = $("ws-show").checked;
    scene.add(cloud);
    state.workspace = { link, samples: n, maxManipulability: best, colorTop: top, volume: summary.volume,
                        area: summary.area ?? null, reach: summary.reach };
    $("ws-show").disabled = false;
    $("ws-clear").disabled = false;
    $("ws-colorbar").hidden = false;
    $("ws-max").textContent = `${fmt(top, 4)} (95th percentile; max ${fmt(best, 4)})`;
    const size = summary.dimension === 3 ? `volume ${fmt(summary.volume, 3)} m³` : `area ${fmt(summary.area, 3)} m²`;
    setWsStatus(`${link}: ${n} samples, reach ${fmt(summary.reach, 3)} m, ${size}.`);
    if (cloud.visible) fitCamera();        // frame the cloud around the model
    requestRender();
  } catch (err) {
    state.wsResponses += 1;
    if (seq !== wsSeq) return;
    setWsStatus("Sampling failed (see the message above).", "warn");
    showError(err);
  }
}

$("ws-sample").addEventListener("click", () => sampleWorkspace());
$("ws-clear").addEventListener("click", () => clearWorkspace());
$("ws-show").addEventListener("change", () => { if (cloud) { cloud.visible = $("ws-show").checked; requestRender(); } });

// ---------------------------------------------------------------------------- link velocities
// With joint velocities set, every FK answer is followed by POST /models/{id}/velocity (links
// "all") and an arrow on each moving link shows the velocity of its origin (world axes).
let qdotInputs = [];
let velocityArrows = {};  // link -> THREE.Group (unit arrow along +z)
let velocityGroup = null;
let velocitySeq = 0;
let velocityInFlight = false;
let velocityPending = false;

function buildQdotInputs(info) {
  const container = $("qdot-inputs");
  container.replaceChildren();
  qdotInputs = info.joint_names.map((name) => {
    const joint = info.joints.find((j) => j.name === name);
    const row = document.createElement("label");
    row.className = "qdot";
    row.innerHTML = `<span></span><input type="number" step="0.1" value="0">`;
    row.querySelector("span").textContent = `${name} [${joint && joint.type === "prismatic" ? "m/s" : "rad/s"}]`;
    const input = row.querySelector("input");
    input.dataset.joint = name;
    input.addEventListener("input", () => requestVelocity());
    container.appendChild(row);
    return input;
  });
  clearVelocityArrows();
  $("qd-status").textContent = "";
}

function currentQdot() {
  return qdotInputs.map((input) => (Number.isFinite(Number(input.value)) ? Number(input.value) : 0));
}

function clearVelocityArrows() {
  velocitySeq += 1;
  if (velocityGroup) {
    scene.remove(velocityGroup);
    velocityGroup.traverse((o) => { if (o.geometry) o.geometry.dispose(); if (o.material) o.material.dispose(); });
  }
  velocityGroup = null;
  velocityArrows = {};
  state.velocityArrows = 0;
  state.lastVelocity = null;
  requestRender();
}

function requestVelocity() {
  if (!model || !qdotInputs.length) return;
  if (currentQdot().every((v) => v === 0)) {
    if (velocityGroup) clearVelocityArrows();
    $("qd-status").textContent = "";
    return;
  }
  if (velocityInFlight) { velocityPending = true; return; }
  runVelocity();
}

async function runVelocity() {
  velocityInFlight = true;
  velocityPending = false;
  const id = model.id;
  const token = loadToken;
  const seq = ++velocitySeq;
  const q = currentQ();
  const qdot = currentQdot();
  state.velocityRequests += 1;
  try {
    const answer = await api(`/models/${encodeURIComponent(id)}/velocity`, { method: "POST", body: { q, qdot, links: "all" } });
    state.velocityResponses += 1;
    if (token !== loadToken || seq !== velocitySeq || !lastPoses) return;
    drawVelocityArrows(answer.velocities, q, qdot);
  } catch (err) {
    state.velocityResponses += 1;
    showError(err);
  } finally {
    velocityInFlight = false;
    if (velocityPending && token === loadToken) runVelocity();
  }
}

function drawVelocityArrows(velocities, q, qdot) {
  if (!velocityGroup) {
    velocityGroup = new THREE.Group();
    velocityGroup.name = "velocity-arrows";
    scene.add(velocityGroup);
  }
  let vmax = 0;
  const linear = {};
  for (const [link, v] of Object.entries(velocities)) {
    linear[link] = v.linear;
    vmax = Math.max(vmax, Math.hypot(...v.linear));
  }
  const scale = vmax > 0 ? (modelSize * VELOCITY_ARROW_FRACTION) / vmax : 0;
  let drawn = 0;
  for (const [link, v] of Object.entries(linear)) {
    const speed = Math.hypot(...v);
    let arrow = velocityArrows[link];
    if (!arrow) {
      arrow = new THREE.Group();
      const material = new THREE.MeshBasicMaterial({ color: 0xff5a1f });
      for (const g of unitArrowGeometry(0, 0.22, 0.035, 0.09)) arrow.add(new THREE.Mesh(g, material));
      arrow.name = `velocity:${link}`;
      velocityArrows[link] = arrow;
      velocityGroup.add(arrow);
    }
    const pose = lastPoses[link];
    arrow.visible = speed * scale > modelSize * 1e-3 && Boolean(pose);
    if (!arrow.visible) continue;
    drawn += 1;
    arrow.position.set(...pose.position);
    arrow.quaternion.setFromUnitVectors(Z_AXIS, new THREE.Vector3(...v).divideScalar(speed));
    arrow.scale.setScalar(speed * scale);
  }
  state.velocityArrows = drawn;
  state.lastVelocity = { q, qdot, linear, scale };
  $("qd-status").textContent = vmax > 0
    ? `Fastest link origin: ${fmt(vmax, 3)} m/s (arrow ${fmt(modelSize * VELOCITY_ARROW_FRACTION, 3)} m).`
    : "No link moves.";
  requestRender();
}

$("qd-zero").addEventListener("click", () => { for (const input of qdotInputs) input.value = "0"; requestVelocity(); });
$("qd-random").addEventListener("click", () => {
  for (const input of qdotInputs) input.value = (Math.random() * 2 - 1).toFixed(2);
  requestVelocity();
});

// ---------------------------------------------------------------------------- links panel
/** The leaf link farthest (in moving joints) from the root: a sensible first selection. */
function defaultLink(info) {
  const parentJoint = Object.fromEntries(info.joints.map((j) => [j.child, j]));
  const hasChild = new Set(info.joints.map((j) => j.parent));
  let best = info.root;
  let bestDepth = -1;
  for (const link of info.links) {
    if (hasChild.has(link)) continue;
    let depth = 0;
    for (let j = parentJoint[link]; j; j = parentJoint[j.parent]) if (j.type !== "fixed") depth += 1;
    if (depth > bestDepth) { best = link; bestDepth = depth; }
  }
  return best;
}

// A <select> filled with the model's links (label(link): the text shown), the default link selected.
function fillLinkOptions(select, info, label = (link) => link) {
  select.replaceChildren();
  for (const link of info.links) {
    const opt = document.createElement("option");
    opt.value = link;
    opt.textContent = label(link);
    select.appendChild(opt);
  }
  select.value = defaultLink(info);
}

function buildLinkList(info) {
  fillLinkOptions($("link-list"), info);
  state.selectedLink = defaultLink(info);
}

$("link-list").addEventListener("change", () => {
  state.selectedLink = $("link-list").value;
  highlightSelected();
  if (ik.enabled) resetIkTarget();
  requestRender();
  showSelectedPose();
});

// ---------------------------------------------------------------------------- loading
async function loadCatalogue(selected) {
  const models = await api("/models");
  const list = Array.isArray(models) ? models : (models.models || []);
  const picker = $("model-picker");
  picker.replaceChildren();
  const groups = {};
  for (const m of list) {
    const source = m.source || "other";
    if (!groups[source]) {
      groups[source] = document.createElement("optgroup");
      groups[source].label = source;
      picker.appendChild(groups[source]);
    }
    const opt = document.createElement("option");
    opt.value = m.id;
    opt.textContent = m.error ? `${m.id} (cannot be loaded)` : `${m.id} (${m.dof} dof)`;
    if (m.error) { opt.disabled = true; opt.title = m.error; }
    groups[source].appendChild(opt);
  }
  if (selected) picker.value = selected;
  return list;
}

async function loadModel(id, { push = true } = {}) {
  const token = ++loadToken;
  state.ready = false;
  clearError();
  try {
    const info = await api(`/models/${encodeURIComponent(id)}`);
    let visuals = {};
    try {
      visuals = (await api(`/viewer/api/${encodeURIComponent(id)}/visuals`)).visuals || {};
    } catch (err) {
      showError(err);                    // the skeleton is still worth showing
    }
    // Start at q = 0 clamped into the limits (the sliders' initial values).
    const byName = Object.fromEntries(info.joints.map((j) => [j.name, j]));
    const q = info.joint_names.map((name) => initialValue(byName[name]));
    state.fkRequests += 1;
    const fk = await api(`/models/${encodeURIComponent(id)}/fk`, { method: "POST", body: { q, links: FK_LINKS_ALL } });
    state.fkResponses += 1;
    if (token !== loadToken) return;
    state.lastQ = q;
    model = info;
    buildSliders(info);
    if (model.id === undefined) model.id = id;
    state.modelId = model.id;
    buildLinkList(info);
    fillClosedFormTips(info);
    buildRobot(info, visuals, fk.poses);
    applyPoses(fk.poses);
    resize();
    fitCamera(FIT_DIRECTION);
    clearWorkspace();
    buildQdotInputs(info);
    showOutOfLimits(fk.out_of_limits || []);
    $("model-picker").value = model.id;
    $("model-summary").textContent = `${info.name || model.id}: ${info.dof} dof, ${info.links.length} links, root ${info.root}`;
    const meshCount = Object.values(visuals).flat().filter((v) => v.kind === "mesh").length;
    const notes = [...(info.warnings || [])];
    if (meshCount) notes.push(`${meshCount} mesh visual(s) not drawn (meshes are never loaded).`);
    $("model-warnings").hidden = notes.length === 0;
    $("model-warnings").textContent = notes.join(" ");
    $("download-urdf").disabled = false;
    $("dh-edit-current").hidden = !info.dh_table;
    document.title = `${model.id} - model viewer`;
    if (push) history.pushState({ id: model.id }, "", `${ROOT}/viewer/${encodeURIComponent(model.id)}`);
    if (ik.enabled) resetIkTarget();
    await showSelectedPose(q);
    requestRender();
    await new Promise((resolve) => requestAnimationFrame(() => requestAnimationFrame(resolve)));
    if (token === loadToken) state.ready = true;
  } catch (err) {
    showError(err);
  }
}

$("model-picker").addEventListener("change", () => loadModel($("model-picker").value));
window.addEventListener("popstate", (e) => { if (e.state && e.state.id) loadModel(e.state.id, { push: false }); });
$("btn-zero").addEventListener("click", () => setAll(sliders.map((s) => Math.min(Math.max(0, s.lower), s.upper))));
$("btn-random").addEventListener("click", () => setAll(sliders.map((s) => s.lower + Math.random() * (s.upper - s.lower))));
$("error-close").addEventListener("click", clearError);
$("api-key").addEventListener("click", () => {
  const key = window.prompt("API key of the service (sent as X-API-Key; kept for this tab only). Empty to forget it.",
    sessionStorage.getItem(API_KEY_STORAGE) || "");
  if (key === null) return;
  if (key) sessionStorage.setItem(API_KEY_STORAGE, key); else sessionStorage.removeItem(API_KEY_STORAGE);
  if (model) loadModel(model.id, { push: false }); else start();
});

async function downloadUrdf(id) {
  try {
    const text = await api(`/models/${encodeURIComponent(id)}/urdf`, { text: true });
    const url = URL.createObjectURL(new Blob([text], { type: "application/xml" }));
    const a = document.createElement("a");
    a.href = url;
    a.download = `${id}.urdf`;
    document.body.appendChild(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 1000);
  } catch (err) {
    showError(err);
  }
}
$("download-urdf").addEventListener("click", () => model && downloadUrdf(model.id));

// ---------------------------------------------------------------------------- tabs
for (const button of document.querySelectorAll(".tabs button")) {
  button.addEventListener("click", () => {
    for (const b of document.querySelectorAll(".tabs button")) b.classList.toggle("active", b === button);
    for (const tab of document.querySelectorAll(".tab")) tab.hidden = tab.id !== `tab-${button.dataset.tab}`;
    $("left").classList.toggle("wide", button.dataset.tab === "closed");
    resize();
  });
}

// ---------------------------------------------------------------------------- closed forms (KaTeX)
const PROBLEM_PREFIX = "urn:kinematics:problem:";
let cfSeq = 0;

/** Typeset `tex` into `element` with the vendored KaTeX (DOM nodes: no inline style attributes). */
function typeset(tex, element) {
  if (!window.katex) throw new Error("KaTeX did not load (vendor/katex/katex.min.js)");
  window.katex.render(tex, element, { displayMode: true, throwOnError: false, strict: "ignore" });
}

/** Render a symbolic answer (format latex) into `container`: T, and on request the factors A_i
 * (with base and tool) and the Jacobians. Returns the number of typeset items. */
function renderClosedForm(container, body, { factors = false, jacobian = false } = {}) {
  container.replaceChildren();
  const items = [[`T_world_${body.tip}`, `T = ${body.T}`]];
  if (factors) {
    if (body.base) items.push(["base", `\\mathrm{base} = ${body.base}`]);
    (body.A || []).forEach((a, i) => items.push([`A_${i + 1}: frame ${body.frames[i]}`, `A_{${i + 1}} = ${a}`]));
    if (body.tool) items.push(["tool", `\\mathrm{tool} = ${body.tool}`]);
  }
  if (jacobian && body.jacobian) {
    for (const [reference, m] of Object.entries(body.jacobian)) {
      items.push([`Jacobian, ${reference} (6 x n, linear rows first)`, `J = ${m}`]);
    }
  }
  const vars = (body.joint_variables || []).map((v) => `${v.symbol} = ${v.joint}`);
  const note = document.createElement("p");
  note.className = "cf-variables";
  note.textContent = [vars.length ? `joint variables: ${vars.join(", ")}` : "no joint variables",
    body.parameters && body.parameters.length ? `parameters: ${body.parameters.join(", ")}` : "",
    `derived in ${Number(body.seconds).toFixed(2)} s${body.simplified ? " (simplified)" : ""}`]
    .filter(Boolean).join("; ");
  container.appendChild(note);
  for (const [label, tex] of items) {
    const item = document.createElement("div");
    item.className = "cf-item";
    const caption = document.createElement("div");
    caption.className = "cf-label";
    caption.textContent = label;
    const math = document.createElement("div");
    math.className = "cf-math";
    item.append(caption, math);
    container.appendChild(item);
    typeset(tex, math);
  }
  return items.length;
}

/** A problem answer of a symbolic request, said plainly (413/422: limits, time limit, bad input). */
function closedFormProblem(err) {
  const slug = err.type && err.type.startsWith(PROBLEM_PREFIX) ? err.type.slice(PROBLEM_PREFIX.length) : null;
  const hints = {
    "time-budget-exceeded": "The derivation ran over the service's time limit: untick simplify, or pick a tip nearer the root.",
    "invalid-symbolic-request": "The service cannot derive this chain's closed form as asked.",
    "invalid-dh-table": "The table cannot be read: check the cells named.",
  };
  const head = err.status ? `${err.status}${slug ? ` ${slug}` : ""}: ` : "";
  const hint = (slug && hints[slug]) || (err.status === 413 ? "The request is over a limit of the service." : "");
  return `${head}${err.message}${hint ? ` ${hint}` : ""}`;
}

function fillClosedFormTips(info) {
  fillLinkOptions($("cf-tip"), info,
                  (link) => (info.leaf_links && info.leaf_links.includes(link) ? `${link} (leaf)` : link));
  $("cf-output").replaceChildren();
  $("cf-status").textContent = "";
  $("cf-status").className = "";
  state.closedForm = null;
}

async function deriveClosedForm() {
  if (!model) return;
  const seq = ++cfSeq;
  const tip = $("cf-tip").value;
  const factors = $("cf-factors").checked;
  const jacobian = $("cf-jacobian").checked;
  const what = jacobian ? ["transforms", "jacobian"] : ["transforms"];
  const status = $("cf-status");
  status.className = "";
  status.textContent = `Deriving the closed form to ${tip}...`;
  $("cf-derive").disabled = true;
  state.cfRequests += 1;
  try {
    const body = await api(`/models/${encodeURIComponent(model.id)}/symbolic`, {
      method: "POST", body: { tip, what, format: "latex", simplify: $("cf-simplify").checked },
    });
    if (seq !== cfSeq) return;
    const count = renderClosedForm($("cf-output"), body, { factors, jacobian });
    status.textContent = `${model.id}: ${body.root} to ${body.tip}, ${body.joint_variables.length} joint variable(s).`;
    state.closedForm = { tip, ok: true, items: count, katex: $("cf-output").querySelectorAll(".katex").length,
      status: status.textContent };
  } catch (err) {
    if (seq !== cfSeq) return;
    $("cf-output").replaceChildren();
    status.className = "warn";
    status.textContent = closedFormProblem(err);
    state.closedForm = { tip, ok: false, items: 0, katex: 0, status: status.textContent, httpStatus: err.status || null };
  } finally {
    if (seq === cfSeq) $("cf-derive").disabled = false;
    state.cfResponses += 1;
  }
}

$("cf-derive").addEventListener("click", deriveClosedForm);

// ---------------------------------------------------------------------------- DH editor
const DH_EXAMPLE = [   // a planar 2R arm with a prismatic wrist lift (standard, degrees)
  { type: "revolute", a: 0.4, alpha: 0, d: 0.3, theta: 0, lower: -170, upper: 170, name: "" },
  { type: "revolute", a: 0.3, alpha: 180, d: 0, theta: 0, lower: -150, upper: 150, name: "" },
  { type: "prismatic", a: 0, alpha: 0, d: 0.1, theta: 0, lower: 0, upper: 0.2, name: "" },
];
const DH_FIELDS = ["a", "alpha", "d", "theta", "lower", "upper"];
const DH_SYMBOLIC_FIELDS = ["a", "alpha", "d", "theta"];   // cells that may hold symbols (POST /symbolic/dh)

/** The cells of a table read with symbols that are not numbers. */
function dhSymbolicCells(table) {
  return table.joints.flatMap((j) => DH_SYMBOLIC_FIELDS.filter((f) => typeof j[f] === "string").map((f) => j[f]));
}

/** POST /symbolic/dh of the editor's table (symbols allowed) and its closed form under the editor. */
async function showDhClosedForm(table) {
  const out = $("dh-closed-form");
  out.hidden = false;
  out.replaceChildren();
  const status = document.createElement("p");
  status.id = "dh-closed-status";
  status.textContent = "Deriving the table's closed form...";
  out.appendChild(status);
  state.cfRequests += 1;
  try {
    const body = await api("/symbolic/dh", { method: "POST", body: { table, what: ["transforms"], format: "latex" } });
    const holder = document.createElement("div");
    renderClosedForm(holder, body, { factors: true });
    status.textContent = `Closed form of the table (${body.joint_variables.length} joint variable(s)` +
      `${body.parameters.length ? `; parameters ${body.parameters.join(", ")}` : ""}).`;
    out.appendChild(holder);
    state.dhClosed = { ok: true, parameters: body.parameters, katex: out.querySelectorAll(".katex").length,
      T: body.T, status: status.textContent };
  } catch (err) {
    status.className = "warn";
    status.textContent = closedFormProblem(err);
    state.dhClosed = { ok: false, parameters: [], katex: 0, T: null, status: status.textContent };
  } finally {
    state.cfResponses += 1;
  }
}

function addDhRow(row = { type: "revolute", a: 0, alpha: 0, d: 0, theta: 0, lower: "", upper: "", name: "" }) {
  const tr = document.createElement("tr");
  const cells = [`<td class="idx"></td>`,
    `<td><select data-field="type"><option value="revolute">R</option><option value="prismatic">P</option></select></td>`];
  for (const f of DH_FIELDS) cells.push(`<td><input type="text" inputmode="decimal" data-field="${f}"></td>`);
  cells.push(`<td><input type="text" data-field="name"></td>`);
  cells.push(`<td><button type="button" class="remove" title="remove row">&minus;</button></td>`);
  tr.innerHTML = cells.join("");
  tr.querySelector('[data-field="type"]').value = row.type;
  for (const f of [...DH_FIELDS, "name"]) tr.querySelector(`[data-field="${f}"]`).value = row[f] ?? "";
  tr.querySelector(".remove").addEventListener("click", () => { tr.remove(); numberDhRows(); });
  $("dh-table").tBodies[0].appendChild(tr);
  numberDhRows();
}

function numberDhRows() {
  [...$("dh-table").tBodies[0].rows].forEach((tr, i) => { tr.querySelector(".idx").textContent = String(i + 1); });
}

/** The DH table as POST /models/dh takes it; throws naming the row and column of bad input.
 * With `symbols`, a, alpha, d and theta may also be symbols or expressions (`a1`, `-d4`, `pi/2`),
 * kept as strings for POST /symbolic/dh (which reads and checks them). */
function readDhTable({ symbols = false } = {}) {
  const joints = [...$("dh-table").tBodies[0].rows].map((tr, i) => {
    const get = (f) => tr.querySelector(`[data-field="${f}"]`).value.trim();
    const num = (f, optional = false) => {
      const text = get(f);
      if (text === "" && optional) return null;
      const v = Number(text);
      // a symbol or expression names something (a1, pi/2); "1.2.3" is a mistyped number
      if (text !== "" && !Number.isFinite(v) && symbols && DH_SYMBOLIC_FIELDS.includes(f) && /[A-Za-z_]/.test(text)) {
        return text;
      }
      if (text === "" || !Number.isFinite(v)) {
        throw new Error(`DH row ${i + 1}, ${f}: "${text}" is not a number${symbols && DH_SYMBOLIC_FIELDS.includes(f)
          ? " (nor a symbol or expression such as a1 or pi/2)" : ""}`);
      }
      return v;
    };
    const joint = { type: get("type"), a: num("a"), alpha: num("alpha"), d: num("d"), theta: num("theta") };
    const lower = num("lower", true);
    const upper = num("upper", true);
    if ((lower === null) !== (upper === null)) throw new Error(`DH row ${i + 1}: give both limits or none`);
    if (lower !== null) joint.limits = [lower, upper];
    if (get("name")) joint.name = get("name");
    return joint;
  });
  const table = {
    name: $("dh-name").value.trim() || "dh_model",
    convention: $("dh-convention").value,
    angles: $("dh-angles").value,
    joints,
  };
  for (const key of ["base", "tool"]) {
    const text = $(`dh-${key}`).value.trim();
    if (!text) continue;
    try {
      table[key] = JSON.parse(text);
    } catch (_) {
      throw new Error(`DH ${key}: not JSON (a 4x4 matrix as a list of 4 rows)`);
    }
  }
  return table;
}

const IDENTITY = JSON.stringify([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]);

/** Fill the editor from a DH table as the service returns it (model info's `dh_table`). */
function fillDhEditor(table) {
  $("dh-name").value = table.name || "";
  $("dh-convention").value = table.convention || "standard";
  $("dh-angles").value = table.angles || "radians";
  $("dh-table").tBodies[0].replaceChildren();
  for (const j of table.joints || []) {
    const limits = j.limits || ["", ""];
    addDhRow({ type: j.type, a: j.a, alpha: j.alpha, d: j.d, theta: j.theta, lower: limits[0], upper: limits[1], name: j.name || "" });
  }
  for (const key of ["base", "tool"]) {
    const m = table[key];
    $(`dh-${key}`).value = m && JSON.stringify(m) !== IDENTITY ? JSON.stringify(m) : "";
  }
}

$("dh-add").addEventListener("click", () => addDhRow());
$("dh-edit-current").addEventListener("click", () => { if (model && model.dh_table) fillDhEditor(model.dh_table); });
$("dh-build").addEventListener("click", async () => {
  const result = $("dh-result");
  result.className = "";
  result.textContent = "";
  let table;
  try {
    table = readDhTable({ symbols: true });
  } catch (err) {
    showError(err);
    return;
  }
  const symbolic = dhSymbolicCells(table);
  if (symbolic.length) {   // a table with symbols has a closed form, not a model
    result.textContent = `The table has symbols (${[...new Set(symbolic)].join(", ")}): its closed form is shown ` +
      "below; give numbers in every cell to build a model.";
    await showDhClosedForm(table);
    return;
  }
  try {
    const info = await api("/models/dh", { method: "POST", body: table });
    clearError();
    state.dhBuilt = info.id;
    state.dhBuilds += 1;
    result.className = "ok";
    result.textContent = `Built model ${info.id}: ${info.dof} dof, ${info.links.length} links.`;
    $("dh-download").disabled = false;
    $("dh-download").dataset.id = info.id;
    await loadCatalogue(info.id);
    await loadModel(info.id);
  } catch (err) {
    result.textContent = "Build failed (see the message above).";
    showError(err);
  }
});
$("dh-download").addEventListener("click", () => downloadUrdf($("dh-download").dataset.id));
$("dh-closed").addEventListener("click", async () => {
  let table;
  try {
    table = readDhTable({ symbols: true });
  } catch (err) {
    showError(err);
    return;
  }
  await showDhClosedForm(table);
});

// ---------------------------------------------------------------------------- start
async function start() {
  if (!$("dh-table").tBodies[0].rows.length) DH_EXAMPLE.forEach((row) => addDhRow(row));
  resize();
  const fromPath = document.body.dataset.model || "";
  try {
    const list = await loadCatalogue(fromPath);
    const id = fromPath || (list.find((m) => m.id === "ur5") || list[0] || {}).id;
    if (!id) throw new ApiError("The catalogue is empty.");
    history.replaceState({ id }, "", `${ROOT}/viewer/${encodeURIComponent(id)}`);
    await loadModel(id, { push: false });
  } catch (err) {
    showError(err);
  }
}
start();
