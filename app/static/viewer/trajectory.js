// A Cartesian path timed and played in time: POST /models/{id}/trajectory with the planned path's q
// as waypoints, the user's velocity and acceleration limits, then the arm animated along `t` and
// each joint's velocity and acceleration drawn against its limit on a small canvas chart.
// (A module of the model viewer; viewer.js is the entry point.)
//
// It reads the path only through `state.path` (path.js fills it), so path.js needs no hook. The
// trajectory is sampled at TRAJ_RATE; FK of every sample is asked once, so playback places the
// answer's poses by the wall clock (sample floor(elapsed * rate)) with no request per frame; at
// the end the last sample becomes the sliders' configuration through the usual FK request. The
// chart plots qd_j / v_j and qdd_j / a_j (the answer's `limits`, per joint): the service holds every
// curve within the dashed +-1 lines; a cursor marks the sample shown. Nothing is computed here but
// the chart's scale.

import { api, showError } from "./api.js";
import { $, state } from "./config.js";
import { applyPoses, setAll, showSliderValue } from "./robot.js";
import { current } from "./state.js";

const TRAJ_RATE = 50;   // samples per second asked of the service (the animation's frame times)
const COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];

const traj = { answer: null, modelId: null, poses: [], sample: 0, playing: false, start: 0, frame: null, token: 0 };

function setStatus(text, kind = "") {
  const el = $("traj-status");
  el.textContent = text;
  el.className = kind;
}

/** The largest |value / limit| over every sample and joint (1 at a saturated limit). */
function peakRatio(rows, limits) {
  let peak = 0;
  for (const row of rows) row.forEach((v, j) => { peak = Math.max(peak, Math.abs(v / limits[j])); });
  return peak;
}

function updateState() {
  const a = traj.answer;
  state.trajectory = a ? {
    duration: a.duration, method: a.method, samples: a.t.length, sample: traj.sample, t: a.t[traj.sample],
    playing: traj.playing, waypoints: traj.waypoints, limits: a.limits,
    velocityRatio: peakRatio(a.qd, a.limits.velocity), accelerationRatio: peakRatio(a.qdd, a.limits.acceleration),
  } : null;
}

/** One band of the chart: every joint's `rows[k][j] / limits[j]` against `t`, the +-1 limit lines dashed. */
function band(ctx, { top, height, left, width }, t, rows, limits, label) {
  const span = Math.max(1, peakRatio(rows, limits)) * 1.08;
  const x = (s) => left + (width * s) / (t[t.length - 1] || 1);
  const y = (r) => top + height / 2 - (height / 2) * (r / span);
  ctx.strokeStyle = "#98a2b3";
  ctx.lineWidth = 1;
  ctx.setLineDash([]);
  ctx.strokeRect(left, top, width, height);
  ctx.beginPath(); ctx.moveTo(left, y(0)); ctx.lineTo(left + width, y(0)); ctx.stroke();
  ctx.strokeStyle = "#d62728";
  ctx.setLineDash([5, 4]);
  for (const r of [1, -1]) { ctx.beginPath(); ctx.moveTo(left, y(r)); ctx.lineTo(left + width, y(r)); ctx.stroke(); }
  ctx.setLineDash([]);
  ctx.fillStyle = "#344054";
  ctx.font = "11px sans-serif";
  ctx.textAlign = "right";
  ctx.fillText("+limit", left - 4, y(1) + 4);
  ctx.fillText("-limit", left - 4, y(-1) + 4);
  ctx.textAlign = "left";
  ctx.fillText(label, left + 4, top + 12);
  ctx.lineWidth = 1.5;
  limits.forEach((lim, j) => {
    ctx.strokeStyle = COLORS[j % COLORS.length];
    ctx.beginPath();
    rows.forEach((row, k) => { const p = [x(t[k]), y(row[j] / lim)]; if (k) ctx.lineTo(...p); else ctx.moveTo(...p); });
    ctx.stroke();
  });
}

function drawChart() {
  const canvas = $("traj-chart");
  const ctx = canvas.getContext("2d");
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  const a = traj.answer;
  canvas.hidden = !a;
  if (!a) return;
  const left = 44, right = 8, gap = 22;
  const width = canvas.width - left - right;
  const height = (canvas.height - gap - 24) / 2;
  band(ctx, { top: 4, height, left, width }, a.t, a.qd, a.limits.velocity, "velocity / limit");
  band(ctx, { top: 4 + height + gap, height, left, width }, a.t, a.qdd, a.limits.acceleration, "acceleration / limit");
  const cx = left + (width * a.t[traj.sample]) / (a.duration || 1);
  ctx.strokeStyle = "#101828";
  ctx.lineWidth = 1;
  ctx.beginPath(); ctx.moveTo(cx, 4); ctx.lineTo(cx, 4 + 2 * height + gap); ctx.stroke();
  ctx.fillStyle = "#344054";
  ctx.textAlign = "center";
  ctx.fillText(`t = ${a.t[traj.sample].toFixed(2)} s of ${a.duration.toFixed(2)} s`, left + width / 2, canvas.height - 6);
  // the joints' colours, in joint order
  ctx.textAlign = "left";
  a.joint_names.forEach((name, j) => {
    ctx.fillStyle = COLORS[j % COLORS.length];
    ctx.fillText(`\u25a0 ${j + 1}`, left + j * 34, 4 + height + gap - 6);
  });
}

/** Show sample `k`: the arm at its FK poses, the sliders at its q (no request unless `sync`). */
function showSample(k, { sync = false } = {}) {
  const a = traj.answer;
  traj.sample = Math.min(Math.max(k, 0), a.t.length - 1);
  const q = a.q[traj.sample];
  const byName = Object.fromEntries(a.joint_names.map((name, j) => [name, q[j]]));
  const values = current.sliders.map((s) => (Number.isFinite(byName[s.name]) ? byName[s.name] : s.value));
  if (sync) {
    setAll(values, { fromIk: true });
  } else {
    current.sliders.forEach((s, j) => { s.value = values[j]; s.input.value = String(values[j]); showSliderValue(s); });
    state.lastQ = values;
    applyPoses(traj.poses[traj.sample]);
  }
  drawChart();
  updateState();
}

function stop() {
  if (traj.frame !== null) cancelAnimationFrame(traj.frame);
  traj.frame = null;
  traj.playing = false;
  $("traj-play").textContent = "Play in time";
}

function tick(now) {
  if (!traj.answer || !traj.playing) return;
  const a = traj.answer;
  const k = Math.floor(((now - traj.start) / 1000) * TRAJ_RATE);
  if (k >= a.t.length - 1) {
    stop();
    showSample(a.t.length - 1, { sync: true });
    return;
  }
  if (k !== traj.sample) showSample(k);
  traj.frame = requestAnimationFrame(tick);
}

export function playTrajectory() {
  const a = traj.answer;
  if (!a) return;
  if (!current.model || current.model.id !== traj.modelId) { setStatus("The model changed: time the path again.", "warn"); return; }
  if (traj.playing) { stop(); showSample(traj.sample, { sync: true }); return; }
  const from = traj.sample >= a.t.length - 1 ? 0 : traj.sample;
  traj.playing = true;
  traj.start = performance.now() - (1000 * from) / TRAJ_RATE;
  $("traj-play").textContent = "Pause";
  showSample(from);
  traj.frame = requestAnimationFrame(tick);
}

/** Time the planned path (state.path.q) under the limits typed in. */
export async function timePath() {
  const path = state.path;
  if (!current.model || !path || !path.q || path.q.length < 2) {
    setStatus("Plan a Cartesian path first: its joint values are the waypoints.", "warn");
    return;
  }
  const velocity = Number($("traj-velocity").value);
  const acceleration = Number($("traj-acceleration").value);
  stop();
  const token = current.loadToken;
  const mine = ++traj.token;
  const id = encodeURIComponent(current.model.id);
  setStatus("Timing…");
  state.trajectoryRequests += 1;
  try {
    const answer = await api(`/models/${id}/trajectory`, { method: "POST", body: {
      waypoints: path.q, limits: { velocity, acceleration }, rate: TRAJ_RATE } });
    const poses = (await api(`/models/${id}/fk`, { method: "POST", body: { q: answer.q, links: "all" } })).poses;
    if (token !== current.loadToken || mine !== traj.token) return;
    traj.answer = answer;
    traj.modelId = current.model.id;
    traj.poses = poses;
    traj.waypoints = path.q.length;
    traj.sample = 0;
    $("traj-play").disabled = false;
    setStatus(`${answer.duration.toFixed(3)} s through ${path.q.length} waypoints, ${answer.t.length} samples `
      + `(peaks: ${(100 * peakRatio(answer.qd, answer.limits.velocity)).toFixed(0)} % of the velocity limit, `
      + `${(100 * peakRatio(answer.qdd, answer.limits.acceleration)).toFixed(0)} % of the acceleration limit).`, "ok");
    showSample(0);
  } catch (err) {
    if (token !== current.loadToken || mine !== traj.token) return;
    setStatus("The trajectory request failed (see the message above).", "warn");
    showError(err);
  } finally {
    state.trajectoryResponses += 1;
  }
}

$("traj-time").addEventListener("click", () => timePath());
$("traj-play").addEventListener("click", () => playTrajectory());

// Test hook entries (merged into window.viewerTest, made by test-hook.js or here first).
window.viewerTest = Object.assign(window.viewerTest || {}, {
  async timePath() { await timePath(); return state.trajectory; },
  playTrajectory: () => playTrajectory(),
  trajectoryChartInk() {
    const c = $("traj-chart");
    const data = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
    let ink = 0;
    for (let i = 3; i < data.length; i += 4) if (data[i] > 0) ink += 1;
    return ink;
  },
});
