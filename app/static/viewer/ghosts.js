// Every IK solution of the target as a translucent ghost arm: POST /models/{id}/ik with
// solutions "all", GET /models/{id}/ik/family, FK of the solutions, and (models with collision
// geometry) POST /models/{id}/collision to tint the colliding ones red. On a redundant chain with no
// joint locked the solutions are infinitely many: the target goes to self-motion.js (event
// "self-motion"), which asks slice by slice and has them drawn here (showSolutions).
// (A module of the model viewer; viewer.js is the entry point.)
//
// A ghost is a copy of what robot.js draws for each link (its visuals and meshes, sharing their
// geometry; not the triads) placed at the solution's FK poses, plus its own rods between link
// origins, all in one translucent material per ghost. Clicking a ghost (or its row in the list)
// makes its q the robot's configuration. Requests are debounced (GHOST_DEBOUNCE_MS after the
// target's last move) and the latest wins: an answer of an older request is dropped.

import * as THREE from "three";
import { api } from "./api.js";
import { $, GHOST_COLORS, GHOST_DEBOUNCE_MS, GHOST_MAX_DRAWN, GHOST_OPACITY, state } from "./config.js";
import { ik, ikTargetPose } from "./ik.js";
import { currentQ, setAll } from "./robot.js";
import { Z_AXIS, camera, gizmo, matrixFromRows, renderer, requestRender, scene } from "./scene.js";
import { current, emit, on } from "./state.js";

export const ghostRoot = new THREE.Group();
ghostRoot.name = "ik-ghosts";
scene.add(ghostRoot);
current.framed.push((box) => {           // a camera fit frames the ghosts shown too
  if (!ghostRoot.children.length) return;
  ghostRoot.updateMatrixWorld(true);
  box.expandByObject(ghostRoot);
});

const ghosts = {
  seq: 0,               // the latest request; older answers are dropped
  timer: null,
  inFlight: 0,
  solutions: [],        // the latest answer's records, with `colliding` (true/false/null)
  jointNames: [],
  chosen: -1,
  family: new Map(),    // "model|link" -> GET /ik/family answer
  collides: new Map(),  // model id -> whether it has collision geometry
};

export function ghostsBusy() {
  return ghosts.timer !== null || ghosts.inFlight > 0;
}

function updateBusy() { state.ghostBusy = ghostsBusy(); }

function setGhostStatus(text, kind = "") {
  const el = $("ghost-status");
  el.textContent = text;
  el.className = kind;
}

function disposeGhosts() {
  for (const ghost of [...ghostRoot.children]) {
    ghostRoot.remove(ghost);
    ghost.userData.material.dispose();   // geometries are shared with the robot (or ghostRod)
  }
}

/** Remove the ghosts and the list, and drop any answer still to come. */
export function clearGhosts() {
  ghosts.seq += 1;
  clearTimeout(ghosts.timer);
  ghosts.timer = null;
  ghosts.solutions = [];
  ghosts.chosen = -1;
  disposeGhosts();
  $("ghost-list").replaceChildren();
  setGhostStatus("");
  state.ghosts = null;
  emit("self-motion", null);
  updateBusy();
  requestRender();
}

function ghostsWanted() {
  return ik.enabled && $("ghost-enable").checked && current.model && current.model.joint_names.length > 0;
}

/** The target moved (or the options changed): ask for every solution once it rests. */
export function requestGhosts() {
  if (!ghostsWanted()) { if (ghostRoot.children.length || ghosts.timer !== null) clearGhosts(); return; }
  ghosts.seq += 1;
  clearTimeout(ghosts.timer);
  ghosts.timer = setTimeout(() => { ghosts.timer = null; sendGhosts(); }, GHOST_DEBOUNCE_MS);
  updateBusy();
}

/** The Lock picker lists the model's joints (filled when the model changes). */
function ensureLockOptions() {
  const select = $("ghost-locked");
  if (select.dataset.model === current.model.id) return;
  select.replaceChildren(new Option("none", ""));
  for (const name of current.model.joint_names) select.appendChild(new Option(name, name));
  select.dataset.model = current.model.id;
}

/** `{joint: value}` of the Lock picker, the joint held at its current value, or null. */
function lockedJoints() {
  const name = $("ghost-locked").value;
  const slider = current.sliders.find((s) => s.name === name);
  return slider ? { [name]: slider.value } : null;
}

async function familyOf(id, link, locked) {
  const lock = locked ? Object.entries(locked).map(([k, v]) => `${k}:${v}`)[0] : "";
  const key = `${id}|${link}|${lock}`;
  if (!ghosts.family.has(key)) {
    if (ghosts.family.size > 64) ghosts.family.clear();   // a locked joint's value is part of the key
    const query = `link=${encodeURIComponent(link)}${lock ? `&locked=${encodeURIComponent(lock)}` : ""}`;
    ghosts.family.set(key, await api(`/models/${encodeURIComponent(id)}/ik/family?${query}`));
  }
  return ghosts.family.get(key);
}

async function hasCollisionGeometry(id) {
  if (!ghosts.collides.has(id)) {
    let links = [];
    try {
      links = (await api(`/models/${encodeURIComponent(id)}/collision/matrix`)).links || [];
    } catch (_) { /* no collision support (e.g. the extra is not installed): no tint */ }
    ghosts.collides.set(id, links.length > 0);
  }
  return ghosts.collides.get(id);
}

function familyText(f) {
  if (!f) return "";
  const bound = f.max_solutions === null || f.max_solutions === undefined ? "" : `, at most ${f.max_solutions}`;
  const how = f.closed_form ? "closed form" : "search";
  return ` · family ${f.family} (${how}${bound}${f.near ? ", near" : ""})`;
}

async function sendGhosts() {
  if (!ghostsWanted()) return;
  const seq = ghosts.seq;
  const token = current.loadToken;
  const id = current.model.id;
  const link = state.selectedLink;
  const limits = $("ghost-limits").value;
  const stale = () => seq !== ghosts.seq || token !== current.loadToken;
  if ($("ik-mode").value !== "pose") {
    disposeGhosts();
    $("ghost-list").replaceChildren();
    setGhostStatus("Every solution needs a pose target (Solve: pose).", "warn");
    state.ghosts = { count: null, error: "position target", drawn: 0, solutions: [] };
    emit("self-motion", null);
    return;
  }
  ensureLockOptions();
  const locked = lockedJoints();
  const target = ikTargetPose();
  const seed = currentQ();
  const body = { link, target, seed, solutions: "all", limits };
  if (locked) body.locked = locked;
  ghosts.inFlight += 1;
  state.ghostRequests += 1;
  updateBusy();
  setGhostStatus("Every solution: solving…");
  try {
    const family = await familyOf(id, link, locked).catch(() => null);
    if (stale()) return;
    if (family && family.redundant && !locked) {   // a self-motion: asked for and drawn slice by slice
      emit("self-motion", { link, target, seed, limits, family });
      return;
    }
    emit("self-motion", null);
    const answer = await api(`/models/${encodeURIComponent(id)}/ik`, { method: "POST", body });
    if (stale()) return;
    await showSolutions(answer, { family, limits, link, seed, locked });
  } catch (err) {
    if (stale()) return;
    // Not every chain has a finite set (a position target, 8 free joints): said here, no banner.
    disposeGhosts();
    $("ghost-list").replaceChildren();
    setGhostStatus(`Every solution: ${err.message.replace(/^POST \S+: /, "")}`, "warn");
    state.ghosts = { count: null, error: err.message, drawn: 0, solutions: [] };
  } finally {
    ghosts.inFlight -= 1;
    state.ghostResponses += 1;
    updateBusy();
  }
}

/** Draw the solutions of `answer` (POST /ik, solutions "all") as ghosts, tinted by POST /collision,
 * and list them; `info`: the family answer (or null: the answer's family is named), limits, link,
 * seed, locked joints, and for a self-motion slice `label` ("at q7 = 0.700") and `parameter`.
 * Resolves true once drawn, false when the target or the model changed meanwhile. */
export async function showSolutions(answer, { family = null, limits, link, seed, locked = null, label = "", parameter = null }) {
  const seq = ghosts.seq;
  const token = current.loadToken;
  const id = current.model.id;
  const stale = () => seq !== ghosts.seq || token !== current.loadToken;
  ghosts.inFlight += 1;
  updateBusy();
  try {
    const solutions = answer.solutions.map((s) => ({ ...s, colliding: null }));
    const drawn = solutions.slice(0, GHOST_MAX_DRAWN);
    let poses = [];
    if (drawn.length) {
      const fk = await api(`/models/${encodeURIComponent(id)}/fk`, { method: "POST", body: { q: drawn.map((s) => s.q), links: "all" } });
      if (stale()) return false;
      poses = fk.poses;
    }
    if (solutions.length && await hasCollisionGeometry(id)) {
      try {
        const col = await api(`/models/${encodeURIComponent(id)}/collision`, { method: "POST", body: { q: solutions.map((s) => s.q) } });
        if (stale()) return false;
        col.colliding.forEach((c, i) => { solutions[i].colliding = Boolean(c); });
      } catch (_) { /* the tint is a bonus: the ghosts stay grey-blue */ }
    }
    if (stale()) return false;
    ghosts.solutions = solutions;
    ghosts.jointNames = answer.joint_names;
    ghosts.chosen = -1;
    drawGhosts(poses);
    fillList();
    const colliding = solutions.filter((s) => s.colliding).length;
    const checked = solutions.some((s) => s.colliding !== null);
    const more = solutions.length > drawn.length ? ` (the first ${drawn.length} drawn)` : "";
    const n = answer.count;
    const named = family ? familyText(family) : (answer.family ? ` · family ${answer.family}` : "");
    setGhostStatus(`${n} solution${n === 1 ? "" : "s"}${label ? ` ${label}` : ""}${more}${named}`
      + (checked ? ` · ${colliding} colliding` : ""), n ? "" : "warn");
    state.ghosts = {
      count: n, drawn: drawn.length, family: family ? family.family : answer.family, limits, link, seed,
      locked: locked || {}, parameter,
      method: answer.method, colliding: checked ? colliding : null, chosen: -1,
      solutions: solutions.map((s) => ({
        q: s.q, within_limits: s.within_limits, singular: s.singular, colliding: s.colliding,
        color: `#${ghostColor(s).toString(16).padStart(6, "0")}`,
      })),
    };
    return true;
  } finally {
    ghosts.inFlight -= 1;
    updateBusy();
  }
}

function ghostColor(s) {
  if (s.colliding === true) return GHOST_COLORS.colliding;
  if (s.colliding === false) return GHOST_COLORS.free;
  return GHOST_COLORS.unknown;
}

let rodGeometry = null;
let ballGeometry = null;
let rodSize = 0;

function ghostGeometries() {
  if (rodSize !== current.modelSize) {
    if (rodGeometry) { rodGeometry.dispose(); ballGeometry.dispose(); }
    const r = current.modelSize * 0.011;
    rodGeometry = new THREE.CylinderGeometry(r, r, 1, 10);
    rodGeometry.rotateX(Math.PI / 2);
    rodGeometry.translate(0, 0, 0.5);
    ballGeometry = new THREE.SphereGeometry(r * 1.8, 12, 8);
    rodSize = current.modelSize;
  }
  return [rodGeometry, ballGeometry];
}

function drawGhosts(posesList) {
  disposeGhosts();
  const [rod, ball] = ghostGeometries();
  posesList.forEach((poses, index) => {
    const s = ghosts.solutions[index];
    const material = new THREE.MeshStandardMaterial({
      color: ghostColor(s), transparent: true, opacity: GHOST_OPACITY, depthWrite: false, roughness: 0.7,
    });
    const ghost = new THREE.Group();
    ghost.name = `ghost-${index}`;
    ghost.userData = { index, material };
    for (const [link, group] of Object.entries(current.linkGroups)) {
      if (!poses[link]) continue;
      const copy = group.clone(true);
      for (const triad of copy.children.filter((c) => c.name === "triad")) copy.remove(triad);
      if (!copy.children.length) continue;
      copy.traverse((o) => { if (o.isMesh) o.material = material; });
      copy.matrixAutoUpdate = false;
      copy.matrix.copy(matrixFromRows(poses[link].matrix));
      ghost.add(copy);
    }
    for (const joint of current.model.joints) {
      const a = new THREE.Vector3(...poses[joint.parent].position);
      const b = new THREE.Vector3(...poses[joint.child].position);
      const length = a.distanceTo(b);
      if (length > 1e-9) {
        const mesh = new THREE.Mesh(rod, material);
        mesh.position.copy(a);
        mesh.quaternion.setFromUnitVectors(Z_AXIS, b.clone().sub(a).divideScalar(length));
        mesh.scale.set(1, 1, length);
        ghost.add(mesh);
      }
      const knob = new THREE.Mesh(ball, material);
      knob.position.copy(b);
      ghost.add(knob);
    }
    ghostRoot.add(ghost);
  });
  requestRender();
}

function fmtQ(q) { return q.map((v) => v.toFixed(3)).join(", "); }

function fillList() {
  const list = $("ghost-list");
  list.replaceChildren();
  ghosts.solutions.forEach((s, i) => {
    const li = document.createElement("li");
    const button = document.createElement("button");
    button.type = "button";
    button.dataset.index = String(i);
    if (s.colliding) button.classList.add("colliding");
    const flags = [s.within_limits ? "in limits" : "outside limits"];
    if (s.singular) flags.push("singular");
    if (s.colliding === true) flags.push("colliding");
    else if (s.colliding === false) flags.push("free");
    button.innerHTML = `<b></b> [<span class="q"></span>] <span class="flags"></span>`;
    button.querySelector("b").textContent = `#${i + 1}`;
    button.querySelector(".q").textContent = fmtQ(s.q);
    button.querySelector(".flags").textContent = flags.join(" · ");
    button.title = `position error ${s.position_error.toExponential(1)} m, rotation error ${s.rotation_error.toExponential(1)} rad`;
    button.addEventListener("click", () => chooseGhost(i));
    li.appendChild(button);
    list.appendChild(li);
  });
}

/** Make solution `index` the robot's configuration (the IK target stays where it is). */
export function chooseGhost(index) {
  const s = ghosts.solutions[index];
  if (!s) return false;
  const byName = Object.fromEntries(ghosts.jointNames.map((name, i) => [name, s.q[i]]));
  setAll(current.sliders.map((sl) => (Number.isFinite(byName[sl.name]) ? byName[sl.name] : sl.value)), { fromIk: true });
  ghosts.chosen = index;
  for (const ghost of ghostRoot.children) {
    ghost.userData.material.opacity = ghost.userData.index === index ? GHOST_OPACITY / 3 : GHOST_OPACITY;
  }
  for (const b of $("ghost-list").querySelectorAll("button")) b.classList.toggle("chosen", Number(b.dataset.index) === index);
  if (state.ghosts) state.ghosts.chosen = index;
  requestRender();
  return true;
}

// ---------------------------------------------------------------------------- picking
const raycaster = new THREE.Raycaster();

/** The index of the ghost first hit at canvas (CSS pixel) point (x, y), or -1. */
export function ghostAt(x, y) {
  if (!ghostRoot.children.length) return -1;
  const rect = renderer.domElement.getBoundingClientRect();
  const ndc = new THREE.Vector2((x / rect.width) * 2 - 1, -(y / rect.height) * 2 + 1);
  camera.updateMatrixWorld();
  ghostRoot.updateMatrixWorld(true);
  raycaster.setFromCamera(ndc, camera);
  const hit = raycaster.intersectObject(ghostRoot, true)[0];
  if (!hit) return -1;
  let o = hit.object;
  while (o && o.parent !== ghostRoot) o = o.parent;
  return o ? o.userData.index : -1;
}

/** Canvas (CSS pixel) points on ghost `index` where it is the first ghost hit: points inside its rods,
 * knobs and link meshes (a grid in each one's bounding box), seen from the camera now (for a real
 * click in the tests; with real meshes the other ghosts hide much of each one). */
export function ghostPoints(index) {
  const ghost = ghostRoot.children.find((g) => g.userData.index === index);
  if (!ghost) return [];
  const rect = renderer.domElement.getBoundingClientRect();
  camera.updateMatrixWorld();
  ghost.updateMatrixWorld(true);
  const points = [];
  const fractions = [0.25, 0.5, 0.75];
  ghost.traverse((mesh) => {
    if (!mesh.isMesh || points.length >= 20) return;
    if (!mesh.geometry.boundingBox) mesh.geometry.computeBoundingBox();
    const { min, max } = mesh.geometry.boundingBox;
    for (const fx of fractions) for (const fy of fractions) for (const fz of fractions) {
      const local = new THREE.Vector3(min.x + fx * (max.x - min.x), min.y + fy * (max.y - min.y),
                                      min.z + fz * (max.z - min.z));
      const p = mesh.localToWorld(local).project(camera);
      const x = (p.x + 1) / 2 * rect.width;
      const y = (1 - p.y) / 2 * rect.height;
      if (x > 2 && y > 2 && x < rect.width - 2 && y < rect.height - 2 && ghostAt(x, y) === index) {
        points.push({ x: rect.left + x, y: rect.top + y });
      }
    }
  });
  return points;
}

let press = null;
renderer.domElement.addEventListener("pointerdown", (e) => {
  // a press on a gizmo handle drags the target; anything else may be a click on a ghost
  press = e.button === 0 && !(gizmo.enabled && gizmo.axis) ? { x: e.clientX, y: e.clientY } : null;
});
renderer.domElement.addEventListener("pointerup", (e) => {
  if (!press || gizmo.dragging) { press = null; return; }
  const moved = Math.hypot(e.clientX - press.x, e.clientY - press.y);
  press = null;
  if (moved > 4) return;                 // an orbit, not a click
  const rect = renderer.domElement.getBoundingClientRect();
  const index = ghostAt(e.clientX - rect.left, e.clientY - rect.top);
  if (index >= 0) chooseGhost(index);
});

on("target-moved", () => requestGhosts());   // ik.js: once the target rests (debounced)
on("ik-disabled", () => clearGhosts());
$("ghost-enable").addEventListener("change", () => requestGhosts());
$("ghost-limits").addEventListener("change", () => requestGhosts());
$("ghost-locked").addEventListener("change", () => requestGhosts());
