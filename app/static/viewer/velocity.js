// Link velocities for joint velocities (POST /models/{id}/velocity), drawn as arrows.
// (A module of the model viewer; viewer.js is the entry point.)

import * as THREE from "three";
import { api, showError } from "./api.js";
import { $, VELOCITY_ARROW_FRACTION, state } from "./config.js";
import { currentQ, fmt } from "./robot.js";
import { Z_AXIS, requestRender, scene, unitArrowGeometry } from "./scene.js";
import { current, on } from "./state.js";

// ---------------------------------------------------------------------------- link velocities
// With joint velocities set, every FK answer is followed by POST /models/{id}/velocity (links
// "all") and an arrow on each moving link shows the velocity of its origin (world axes).
let qdotInputs = [];
let velocityArrows = {};  // link -> THREE.Group (unit arrow along +z)
let velocityGroup = null;
let velocitySeq = 0;
let velocityInFlight = false;
let velocityPending = false;

/** A velocity request in flight or one waiting for it. */
export function velocityBusy() { return velocityInFlight || velocityPending; }

/** Set the joint velocity inputs to `values` and ask for the arrows. */
export function setQdot(values) {
  qdotInputs.forEach((input, i) => { input.value = String(values[i]); });
  requestVelocity();
}

export function buildQdotInputs(info) {
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

export function currentQdot() {
  return qdotInputs.map((input) => (Number.isFinite(Number(input.value)) ? Number(input.value) : 0));
}

export function clearVelocityArrows() {
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

export function requestVelocity() {
  if (!current.model || !qdotInputs.length) return;
  if (currentQdot().every((v) => v === 0)) {
    if (velocityGroup) clearVelocityArrows();
    $("qd-status").textContent = "";
    return;
  }
  if (velocityInFlight) { velocityPending = true; return; }
  runVelocity();
}

export async function runVelocity() {
  velocityInFlight = true;
  velocityPending = false;
  const id = current.model.id;
  const token = current.loadToken;
  const seq = ++velocitySeq;
  const q = currentQ();
  const qdot = currentQdot();
  state.velocityRequests += 1;
  try {
    const answer = await api(`/models/${encodeURIComponent(id)}/velocity`, { method: "POST", body: { q, qdot, links: "all" } });
    state.velocityResponses += 1;
    if (token !== current.loadToken || seq !== velocitySeq || !current.lastPoses) return;
    drawVelocityArrows(answer.velocities, q, qdot);
  } catch (err) {
    state.velocityResponses += 1;
    showError(err);
  } finally {
    velocityInFlight = false;
    if (velocityPending && token === current.loadToken) runVelocity();
  }
}

export function drawVelocityArrows(velocities, q, qdot) {
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
  const scale = vmax > 0 ? (current.modelSize * VELOCITY_ARROW_FRACTION) / vmax : 0;
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
    const pose = current.lastPoses[link];
    arrow.visible = speed * scale > current.modelSize * 1e-3 && Boolean(pose);
    if (!arrow.visible) continue;
    drawn += 1;
    arrow.position.set(...pose.position);
    arrow.quaternion.setFromUnitVectors(Z_AXIS, new THREE.Vector3(...v).divideScalar(speed));
    arrow.scale.setScalar(speed * scale);
  }
  state.velocityArrows = drawn;
  state.lastVelocity = { q, qdot, linear, scale };
  $("qd-status").textContent = vmax > 0
    ? `Fastest link origin: ${fmt(vmax, 3)} m/s (arrow ${fmt(current.modelSize * VELOCITY_ARROW_FRACTION, 3)} m).`
    : "No link moves.";
  requestRender();
}

on("fk-drawn", () => requestVelocity());   // robot.js: a new configuration drawn
$("qd-zero").addEventListener("click", () => { for (const input of qdotInputs) input.value = "0"; requestVelocity(); });
$("qd-random").addEventListener("click", () => {
  for (const input of qdotInputs) input.value = (Math.random() * 2 - 1).toFixed(2);
  requestVelocity();
});
