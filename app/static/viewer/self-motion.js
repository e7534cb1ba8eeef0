// The self-motion of a redundant (7-joint) chain: POST /models/{id}/ik with solutions "all" and a
// `redundancy` field. A slider runs the parameter (the family answer's default_parameter, a joint:
// q7 on the Panda) over its range; under it a bar draws, per branch, the ranges of the parameter over
// which that branch stays within the joint limits (`intervals`); the solutions at the slider's value
// (`values`) are drawn by ghosts.js, the robot on the branch it was on (followed slice by slice from
// its own value of the parameter, in the same request), the other branches as ghosts.
// (A module of the model viewer; viewer.js is the entry point.)
//
// ghosts.js asks for the self-motion (event "self-motion") when the target rests on a redundant
// chain with no joint locked: one request for the intervals and the solutions at the robot's own
// value of the parameter. A slider move waits SELF_MOTION_DEBOUNCE_MS for the slider to rest; one
// request is in flight at a time and the value asked next is the latest (no request storm).

import { api, showError } from "./api.js";
import { $, SELF_MOTION_DEBOUNCE_MS, SELF_MOTION_MAX_SLICES, SELF_MOTION_TRACK_STEP, state } from "./config.js";
import { chooseGhost, showSolutions } from "./ghosts.js";
import { currentQ } from "./robot.js";
import { current, on } from "./state.js";

// branch colours of the bar (a branch keeps its colour; the palette repeats past ten branches)
const BRANCH_COLORS = ["#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2", "#bcbd22",
                       "#7f7f7f", "#d62728"];

const sm = {
  seq: 0,             // the latest target: answers about an older one are dropped
  request: null,      // {link, target, seed, limits, family} of the target shown
  joint: null,        // the parameter joint
  index: -1,          // its index in joint_names
  lower: 0,
  upper: 0,
  intervals: [],      // the answer's in-limit ranges, each with its branch pieces
  timer: null,
  inFlight: 0,        // requests in flight (a new target may ask while an older answer is awaited)
  wanted: null,       // the value the slider rests on
  shown: null,        // the value whose solutions are drawn (or asked for)
};

/** A self-motion request in flight, or a slider move waiting for its debounce. */
export function selfMotionBusy() {
  return sm.inFlight > 0 || sm.timer !== null;
}

function updateBusy() { state.selfMotionBusy = selfMotionBusy(); }

function setStatus(text, kind = "") {
  const el = $("sm-status");
  el.textContent = text;
  el.className = kind;
}

function fmtValue(v) { return Number.isFinite(v) ? v.toFixed(3) : "-"; }

/** Drop the self-motion: hide the panel and forget any answer still to come. */
function hide() {
  sm.seq += 1;
  sm.request = null;
  clearTimeout(sm.timer);
  sm.timer = null;
  $("sm-panel").hidden = true;
  $("sm-bar").replaceChildren();
  state.selfMotion = null;
  updateBusy();
}

/** The target moved: what is drawn is about the old target until ghosts.js asks again (the slider
 * waits for it). */
function invalidate() {
  if (!sm.request) return;
  sm.request = null;
  sm.seq += 1;
  clearTimeout(sm.timer);
  sm.timer = null;
  updateBusy();
}

// ---------------------------------------------------------------------------- the bar
/** Where `v` lies on the parameter's range, 0 to 1. */
function fraction(v) {
  return (v - sm.lower) / (sm.upper - sm.lower);
}

function position(v) {
  return `${(100 * fraction(v)).toFixed(3)}%`;
}

function barRow(label, title, pieces) {
  const row = document.createElement("div");
  row.className = "sm-row";
  const name = document.createElement("span");
  name.className = "sm-label";
  name.textContent = label;
  name.title = title;
  const track = document.createElement("div");
  track.className = "sm-track";
  for (const { from, to, color, tip } of pieces) {
    const piece = document.createElement("span");
    piece.className = "sm-piece";
    piece.style.left = position(from);
    piece.style.width = `calc(${position(to)} - ${position(from)})`;
    piece.style.minWidth = "1px";
    piece.style.background = color;
    piece.title = tip;
    piece.dataset.from = String(from);
    piece.dataset.to = String(to);
    track.appendChild(piece);
  }
  row.append(name, track);
  return row;
}

function endText(end) {
  return end.reason === "joint_limit" ? `${end.joint} at its limit` : end.reason.replace("_", " ");
}

/** One row for the union of the in-limit ranges, then one per branch with its in-limit pieces. */
function drawBar() {
  const bar = $("sm-bar");
  bar.replaceChildren();
  const branches = new Map();
  for (const range of sm.intervals) {
    for (const piece of range.branches) {
      if (!branches.has(piece.branch)) branches.set(piece.branch, []);
      branches.get(piece.branch).push(piece);
    }
  }
  bar.appendChild(barRow("any", "some solution within the limits", sm.intervals.map((r) => ({
    from: r.from, to: r.to, color: "#16a34a", tip: `[${fmtValue(r.from)}, ${fmtValue(r.to)}]`,
  }))));
  [...branches.keys()].sort((a, b) => a - b).forEach((branch, k) => {
    const color = BRANCH_COLORS[k % BRANCH_COLORS.length];
    bar.appendChild(barRow(`b${branch}`, `branch ${branch}: within the limits where coloured`,
      branches.get(branch).map((p) => ({
        from: p.from, to: p.to, color,
        tip: `branch ${branch}: [${fmtValue(p.from)}, ${fmtValue(p.to)}], ends: ${p.ends.map(endText).join(" / ")}`,
      }))));
  });
  const marker = document.createElement("div");
  marker.id = "sm-marker";
  bar.appendChild(marker);
  showMarker();
}

/** The bar's tracks start after the label column and its gap (30 + 4 px) and a margin of 8 px each
 * side (where a range input's thumb centre runs): the marker sits at the slider's value on them. */
function showMarker() {
  const marker = $("sm-marker");
  if (marker && sm.wanted !== null) marker.style.left = `calc(42px + (100% - 50px) * ${fraction(sm.wanted).toFixed(5)})`;
  $("sm-value").textContent = `${sm.joint} = ${fmtValue(sm.wanted)}`;
}

// ---------------------------------------------------------------------------- requests
/** The parameter values the robot is followed through from `from` to `to` (ending on `to`): one
 * slice per SELF_MOTION_TRACK_STEP at most, SELF_MOTION_MAX_SLICES at most, all in one request. */
function trackValues(from, to) {
  const n = Math.min(SELF_MOTION_MAX_SLICES, Math.max(1, Math.ceil(Math.abs(to - from) / SELF_MOTION_TRACK_STEP)));
  return Array.from({ length: n }, (_, k) => (k === n - 1 ? to : from + (to - from) * (k + 1) / n));
}

/** The answer's solutions per value asked (each solution carries its `parameter`). */
function slices(answer, values) {
  const out = values.map(() => []);
  for (const s of answer.solutions) {
    let k = 0;
    for (let j = 1; j < values.length; j++) if (Math.abs(s.parameter - values[j]) < Math.abs(s.parameter - values[k])) k = j;
    out[k].push(s);
  }
  return out;
}

/** The index in `solutions` of the one nearest `q` (model joint order) and its q in that order. */
function nearest(solutions, jointNames, q) {
  const at = jointNames.map((name) => current.model.joint_names.indexOf(name));
  let best = -1;
  let bestDistance = Infinity;
  solutions.forEach((s, i) => {
    const d = s.q.reduce((sum, v, k) => sum + (at[k] >= 0 ? (v - q[at[k]]) ** 2 : 0), 0);
    if (d < bestDistance) { best = i; bestDistance = d; }
  });
  const next = [...q];
  if (best >= 0) at.forEach((m, k) => { if (m >= 0) next[m] = solutions[best].q[k]; });
  return [best, next];
}

/** Ask for the solutions at `value` (with the intervals when the target is new), and at the values
 * between the robot's and it, through which the robot follows its branch (the nearest solution of
 * each slice to the one before); draw the slice at `value` with the robot on the branch followed. */
async function send(value, { intervals = false } = {}) {
  const seq = sm.seq;
  const token = current.loadToken;
  const id = current.model.id;
  const stale = () => seq !== sm.seq || token !== current.loadToken;
  const { link, target, seed, limits } = sm.request;
  const start = currentQ();
  const values = trackValues(start[sm.index], value);
  const redundancy = { parameter: { joint: sm.joint }, values };
  if (intervals) redundancy.intervals = true;
  const body = { link, target, seed, solutions: "all", limits, redundancy };
  sm.inFlight += 1;
  sm.shown = value;
  state.selfMotionRequests += 1;
  updateBusy();
  try {
    const answer = await api(`/models/${encodeURIComponent(id)}/ik`, { method: "POST", body });
    if (stale()) return;
    if (intervals) { sm.intervals = answer.intervals || []; drawBar(); }
    const perValue = slices(answer, values);
    let q = start;
    let maxStep = 0;
    for (const slice of perValue.slice(0, -1)) {
      const [i, next] = nearest(slice, answer.joint_names, q);
      if (i < 0) continue;                  // no solution there (limits respected): skip the slice
      maxStep = Math.max(maxStep, ...next.map((v, k) => Math.abs(v - q[k])));
      q = next;
    }
    const last = perValue[perValue.length - 1];
    const [robot, end] = nearest(last, answer.joint_names, q);
    if (robot >= 0) maxStep = Math.max(maxStep, ...end.map((v, k) => Math.abs(v - q[k])));
    const drawn = await showSolutions({ ...answer, solutions: last, count: last.length }, {
      limits, link, seed, label: `at ${sm.joint} = ${fmtValue(value)}`, parameter: { joint: sm.joint, value },
    });
    if (stale() || !drawn) return;
    if (robot >= 0) chooseGhost(robot);
    const pieces = sm.intervals.reduce((n, r) => n + r.branches.length, 0);
    setStatus(sm.intervals.length
      ? `${sm.joint} within the limits on ${sm.intervals.map((r) => `[${fmtValue(r.from)}, ${fmtValue(r.to)}]`).join(" ∪ ")}`
        + ` (${pieces} branch piece${pieces === 1 ? "" : "s"})`
      : `No value of ${sm.joint} puts a solution within the limits.`, sm.intervals.length ? "" : "warn");
    state.selfMotion = {
      link, joint: sm.joint, lower: sm.lower, upper: sm.upper, value, count: last.length, chosen: robot,
      intervals: sm.intervals, target, q: robot >= 0 ? last[robot].q : null,
      track: { values, maxStep },         // the slices the robot was followed through, its largest joint step
    };
  } catch (err) {
    if (stale()) return;
    setStatus("The self-motion request failed (see the message above).", "warn");
    showError(err);
  } finally {
    sm.inFlight -= 1;
    state.selfMotionResponses += 1;
    pump();
  }
}

/** Send the value the slider rests on, once nothing is in flight. */
function pump() {
  if (!sm.request || sm.inFlight > 0 || sm.timer !== null || sm.wanted === sm.shown) { updateBusy(); return; }
  send(sm.wanted);
}

/** A new target on a redundant chain (from ghosts.js): its intervals and its solutions at the
 * robot's own value of the parameter. */
function start(request) {
  sm.seq += 1;
  clearTimeout(sm.timer);
  sm.timer = null;
  sm.request = request;
  const joint = request.family.default_parameter && request.family.default_parameter.joint;
  const slider = current.sliders.find((s) => s.name === joint);
  if (!slider) { hide(); return; }
  sm.joint = joint;
  sm.index = current.sliders.indexOf(slider);
  sm.lower = slider.lower;
  sm.upper = slider.upper;
  sm.wanted = Math.min(Math.max(slider.value, sm.lower), sm.upper);
  const input = $("sm-slider");
  input.min = String(sm.lower);
  input.max = String(sm.upper);
  input.step = String((sm.upper - sm.lower) / 1000);
  input.value = String(sm.wanted);
  $("sm-panel").hidden = false;
  setStatus("Self-motion: solving…");
  send(sm.wanted, { intervals: true });
}

on("self-motion", (request) => (request ? start(request) : hide()));   // ghosts.js (null: no self-motion)
on("target-moved", () => invalidate());

$("sm-slider").addEventListener("input", () => {
  if (!sm.request) return;
  sm.wanted = Number($("sm-slider").value);
  showMarker();
  clearTimeout(sm.timer);
  sm.timer = setTimeout(() => { sm.timer = null; pump(); }, SELF_MOTION_DEBOUNCE_MS);
  updateBusy();
});

// Test hook entries (merged into window.viewerTest by test-hook.js).
export const selfMotionTest = {
  selfMotion: () => state.selfMotion,
  /** The bar as drawn: per row its label and the [from, to] of its pieces (parameter units). */
  selfMotionBar() {
    return [...$("sm-bar").querySelectorAll(".sm-row")].map((row) => ({
      label: row.querySelector(".sm-label").textContent,
      pieces: [...row.querySelectorAll(".sm-piece")].map((p) => [Number(p.dataset.from), Number(p.dataset.to)]),
    }));
  },
};
