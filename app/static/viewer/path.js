// A Cartesian path through waypoints of the IK target: POST /models/{id}/ik/path, drawn as the
// line through its interpolated targets and played back row by row.
// (A module of the model viewer; viewer.js is the entry point.)
//
// "Add target as waypoint" appends the IK target's pose (T_world_link, the gizmo's); the first one
// also keeps the current joint values as the path's seed (the configuration it starts from).
// "Plan" asks for the path, then FK of every achieved row at once, so playback places the answer's
// poses frame by frame (one row per PATH_FRAME_MS) with no request per frame; when it pauses or
// ends, the row becomes the sliders' configuration through the usual FK request. Where the path
// stops (`stopped.index`, `reason`) a red ball marks that target and the status says why.

import * as THREE from "three";
import { api, showError } from "./api.js";
import { $, PATH_FRAME_MS, state } from "./config.js";
import { ik, ikTargetPose } from "./ik.js";
import { applyPoses, currentQ, setAll, showSliderValue } from "./robot.js";
import { requestRender, scene } from "./scene.js";
import { current } from "./state.js";

const pathRoot = new THREE.Group();
pathRoot.name = "ik-path";
scene.add(pathRoot);

const path = {
  waypoints: [],   // poses {position, quaternion}
  link: null,
  seed: null,
  answer: null,
  poses: [],       // FK of every achieved row (links "all")
  row: 0,
  playing: false,
  timer: null,
  inFlight: false,
  token: 0,
};

export function pathBusy() { return path.inFlight || path.playing; }

function setPathStatus(text, kind = "") {
  const el = $("path-status");
  el.textContent = text;
  el.className = kind;
}

function clearDrawing() {
  for (const child of [...pathRoot.children]) {
    pathRoot.remove(child);
    child.geometry.dispose();
    child.material.dispose();
  }
}

function marker(position, color, scale) {
  const mesh = new THREE.Mesh(new THREE.SphereGeometry(current.modelSize * scale, 14, 10),
    new THREE.MeshBasicMaterial({ color, transparent: true, opacity: 0.85, depthTest: false }));
  mesh.position.set(...position);
  mesh.renderOrder = 2;
  return mesh;
}

function polyline(points, color) {
  const geometry = new THREE.BufferGeometry().setFromPoints(points.map((p) => new THREE.Vector3(...p)));
  const line = new THREE.Line(geometry, new THREE.LineBasicMaterial({ color, depthTest: false, transparent: true }));
  line.renderOrder = 1;
  return line;
}

function drawWaypoints() {
  clearDrawing();
  const positions = path.waypoints.map((w) => w.position);
  if (positions.length > 1) pathRoot.add(polyline(positions, 0x98a2b3));
  for (const p of positions) pathRoot.add(marker(p, 0xff7f0e, 0.012));
  requestRender();
}

function drawAnswer(answer) {
  clearDrawing();
  const targets = answer.targets.map((T) => [T[0][3], T[1][3], T[2][3]]);
  const reached = targets.slice(0, Math.max(answer.q.length, 1));
  pathRoot.add(polyline(targets, 0x98a2b3));                        // the whole path asked for
  if (reached.length > 1) pathRoot.add(polyline(reached, 0x16a34a)); // the part achieved
  for (const w of path.waypoints) pathRoot.add(marker(w.position, 0xff7f0e, 0.012));
  if (answer.stopped && targets[answer.stopped.index]) {
    const stop = marker(targets[answer.stopped.index], 0xd62728, 0.022);
    stop.name = "path-stop";
    pathRoot.add(stop);
  }
  requestRender();
}

function showWaypointCount() {
  const n = path.waypoints.length;
  $("path-waypoints").textContent = n ? `${n} waypoint${n === 1 ? "" : "s"} of ${path.link}` : "no waypoint";
  $("path-plan").disabled = n < 2;
}

function updateState() {
  const a = path.answer;
  state.path = {
    waypoints: path.waypoints.length, link: path.link, rows: a ? a.q.length : 0, targets: a ? a.targets.length : 0,
    row: path.row, playing: path.playing, complete: a ? a.complete : null, fraction: a ? a.fraction : null,
    stopped: a ? a.stopped : null, q: a ? a.q : null, max_joint_step: a ? a.max_joint_step : null,
  };
}

function stopTimer() {
  clearInterval(path.timer);
  path.timer = null;
  path.playing = false;
  $("path-play").textContent = "Play";
}

/** Forget the waypoints and the planned path. */
export function clearPath() {
  stopTimer();
  path.token += 1;
  path.waypoints = [];
  path.link = null;
  path.seed = null;
  path.answer = null;
  path.poses = [];
  path.row = 0;
  clearDrawing();
  showWaypointCount();
  $("path-play").disabled = true;
  $("path-row").disabled = true;
  $("path-row").max = "0";
  $("path-row").value = "0";
  $("path-row-label").textContent = "";
  setPathStatus("");
  state.path = null;
  requestRender();
}

export function addWaypoint() {
  if (!ik.enabled || !current.model) { setPathStatus("Tick IK target first: waypoints are poses of the target.", "warn"); return false; }
  if (path.link !== null && path.link !== state.selectedLink) clearPath();
  if (path.answer) { path.answer = null; path.poses = []; stopTimer(); $("path-play").disabled = true; $("path-row").disabled = true; }
  if (!path.waypoints.length) { path.seed = currentQ(); path.link = state.selectedLink; }
  path.waypoints.push(ikTargetPose());
  drawWaypoints();
  showWaypointCount();
  setPathStatus("");
  updateState();
  return true;
}

export async function planPath() {
  if (path.waypoints.length < 2 || !current.model) return;
  stopTimer();
  const token = current.loadToken;
  const mine = ++path.token;
  const id = current.model.id;
  const body = { link: path.link, waypoints: path.waypoints, seed: path.seed };
  path.inFlight = true;
  state.pathRequests += 1;
  setPathStatus("Planning…");
  try {
    const answer = await api(`/models/${encodeURIComponent(id)}/ik/path`, { method: "POST", body });
    let poses = [];
    if (answer.q.length) {
      poses = (await api(`/models/${encodeURIComponent(id)}/fk`, { method: "POST", body: { q: answer.q, links: "all" } })).poses;
    }
    if (token !== current.loadToken || mine !== path.token) return;
    path.answer = answer;
    path.poses = poses;
    path.row = 0;
    drawAnswer(answer);
    const rows = answer.q.length;
    $("path-row").max = String(Math.max(rows - 1, 0));
    $("path-row").value = "0";
    $("path-row").disabled = rows === 0;
    $("path-play").disabled = rows === 0;
    const pct = `${(100 * answer.fraction).toFixed(0)} %`;
    if (answer.complete) {
      setPathStatus(`Complete: ${rows} rows, largest joint step ${answer.max_joint_step.toFixed(3)}.`, "ok");
    } else {
      const s = answer.stopped || {};
      setPathStatus(`Stopped at target ${s.index} of ${answer.targets.length} (${s.reason}): ${pct} of the path `
        + `achieved in ${rows} rows (red ball).`, "warn");
    }
    if (rows) showRow(0, { sync: true });
  } catch (err) {
    if (token !== current.loadToken || mine !== path.token) return;
    setPathStatus("The path request failed (see the message above).", "warn");
    showError(err);
  } finally {
    if (mine === path.token) path.inFlight = false;
    state.pathResponses += 1;
    updateState();
  }
}

/** Draw row `i` of the path: the sliders show its q, the robot its FK poses (no request);
 * `sync` also sends it through the usual FK (pose panel, velocities). */
function showRow(i, { sync = false } = {}) {
  const a = path.answer;
  if (!a || !a.q.length) return;
  path.row = Math.min(Math.max(i, 0), a.q.length - 1);
  const q = a.q[path.row];
  const byName = Object.fromEntries(a.joint_names.map((name, k) => [name, q[k]]));
  const values = current.sliders.map((s) => (Number.isFinite(byName[s.name]) ? byName[s.name] : s.value));
  if (sync) {
    setAll(values, { fromIk: true });
  } else {
    current.sliders.forEach((s, k) => { s.value = values[k]; s.input.value = String(values[k]); showSliderValue(s); });
    state.lastQ = values;
    applyPoses(path.poses[path.row]);
  }
  $("path-row").value = String(path.row);
  $("path-row-label").textContent = `${path.row + 1} / ${a.q.length}`;
  updateState();
}

export function playPath() {
  const a = path.answer;
  if (!a || !a.q.length) return;
  if (path.playing) { stopTimer(); showRow(path.row, { sync: true }); return; }
  if (path.row >= a.q.length - 1) showRow(0);
  path.playing = true;
  $("path-play").textContent = "Pause";
  updateState();
  path.timer = setInterval(() => {
    if (!path.answer) { stopTimer(); return; }
    const next = path.row + 1;
    if (next >= path.answer.q.length - 1) {
      stopTimer();
      showRow(path.answer.q.length - 1, { sync: true });
    } else {
      showRow(next);
    }
  }, PATH_FRAME_MS);
}

$("path-add").addEventListener("click", () => addWaypoint());
$("path-clear").addEventListener("click", () => clearPath());
$("path-plan").addEventListener("click", () => planPath());
$("path-play").addEventListener("click", () => playPath());
$("path-row").addEventListener("input", () => { if (path.playing) stopTimer(); showRow(Number($("path-row").value)); });
$("path-row").addEventListener("change", () => showRow(Number($("path-row").value), { sync: true }));

// Test hook entries (merged into window.viewerTest by test-hook.js).
export const pathTest = {
  addWaypoint: () => addWaypoint(),
  async planPath() { await planPath(); return state.path; },
  playPath: () => playPath(),
  path: () => state.path,
  pathStopMarker: () => pathRoot.getObjectByName("path-stop") !== undefined,
  currentQ: () => currentQ(),
};
