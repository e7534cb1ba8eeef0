// The IK target: a gizmo dragged in the world, solved by POST /models/{id}/ik.
// (A module of the model viewer; viewer.js is the entry point.)

import * as THREE from "three";
import { api, showError } from "./api.js";
import { $, IK_DRAG_RESTARTS, IK_TARGET_OPACITY, IK_THROTTLE_MS, SELECTED_TRIAD_SCALE, TRIAD_FRACTION, state } from "./config.js";
import { currentQ, setAll } from "./robot.js";
import { COLORS, controls, gizmo, makeTriad, matrixFromRows, requestRender, scene, unitArrowGeometry } from "./scene.js";
import { current, emit, on } from "./state.js";

// ---------------------------------------------------------------------------- IK target
// A TransformControls gizmo (three.js addon, vendored) moves `ikTarget`, a scene object drawn as
// a ghost triad. Its position and quaternion are T_world_target (the scene is the world frame,
// see the top of this file); every change while dragging asks POST /models/{id}/ik (throttled:
// one request in flight, at most one per IK_THROTTLE_MS, restarts off so the arm follows
// smoothly), and releasing the handle asks once more right away with the service's default
// random restarts. Every request is seeded with the current joint values; the answer's q
// becomes the sliders' values and is drawn by the usual FK request.
export const ikTarget = new THREE.Group();
ikTarget.name = "ik-target";
ikTarget.visible = false;
scene.add(ikTarget);
scene.add(gizmo.getHelper());
gizmo.setSpace("world");

export const ik = {
  enabled: false,
  inFlight: false,
  dirty: false,        // the target moved since the last request
  final: false,        // the next request is a drag end: no throttle, restarts on
  lastSent: -Infinity,
  timer: null,
  seq: 0,              // answers of an older sequence (reset target, other link/model) are dropped
  markerSize: 0,
};

export function ikBusy() {
  return ik.inFlight || ik.dirty || ik.timer !== null;
}

export function updateIkBusy() {
  state.ikBusy = ikBusy();
}

gizmo.addEventListener("change", () => requestRender());
gizmo.addEventListener("dragging-changed", (event) => {
  controls.enabled = !event.value;
  if (!event.value) requestIk({ final: true });   // drag end
});
gizmo.addEventListener("objectChange", () => { if (gizmo.dragging) requestIk(); });

/** The target's ghost triad, sized like the selected link's triad. */
export function ensureTargetMarker() {
  const size = current.modelSize * TRIAD_FRACTION * SELECTED_TRIAD_SCALE * 1.25;
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
export function placeTargetAtLink() {
  const pose = current.lastPoses && current.lastPoses[state.selectedLink];
  if (!pose) return false;
  matrixFromRows(pose.matrix).decompose(ikTarget.position, ikTarget.quaternion, ikTarget.scale);
  ikTarget.scale.set(1, 1, 1);
  ikTarget.updateMatrixWorld(true);
  requestRender();
  emit("target-moved");                  // every solution of the target where it is now (ghosts.js)
  return true;
}

/** The target as POST /models/{id}/ik takes it: T_world_target, quaternion as {w, x, y, z}. */
export function ikTargetPose() {
  const p = ikTarget.position;
  const q = ikTarget.quaternion;          // three.js keeps (x, y, z, w); the API names them
  return { position: [p.x, p.y, p.z], quaternion: { w: q.w, x: q.x, y: q.y, z: q.z } };
}

export function setIkStatus(text, kind = "") {
  const el = $("ik-status");
  el.textContent = text;
  el.className = kind;
  state.ikStatus = text;
}

/** Drop pending and in-flight IK work and put the target back on the selected link. */
export function resetIkTarget() {
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
    setIkStatus(current.model && current.model.joint_names.length === 0
      ? "IK: this model has no moving joint."
      : `IK: drag the gizmo to move the target of ${link}.`);
  }
}

export function setIkEnabled(on) {
  ik.enabled = Boolean(on) && current.model !== null;
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
    emit("ik-disabled");
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
export function requestIk({ final = false } = {}) {
  if (!ik.enabled || !current.model || current.model.joint_names.length === 0) return;
  ik.dirty = true;
  ik.final = ik.final || final;
  pumpIk();
  emit("target-moved");                  // ghosts.js asks once the target rests (debounced)
}

export function pumpIk() {
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

export function fmtError(x) {
  if (!Number.isFinite(x)) return String(x);
  if (x === 0) return "0";
  return Math.abs(x) < 1e-3 ? x.toExponential(1) : x.toPrecision(3);
}

export async function sendIk() {
  const id = current.model.id;
  const token = current.loadToken;
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
    if (token !== current.loadToken || seq !== ik.seq || !ik.enabled) return;
    const byName = Object.fromEntries(answer.joint_names.map((name, i) => [name, answer.q[i]]));
    const q = current.sliders.map((s) => (Number.isFinite(byName[s.name]) ? byName[s.name] : s.value));
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
    if (token !== current.loadToken || seq !== ik.seq) return;
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
// A hand-made move of the joints (robot.js): the target follows the link, unless it is being
// dragged or solved for.
on("link-moved", () => { if (ik.enabled && !gizmo.dragging && !ikBusy()) placeTargetAtLink(); });
