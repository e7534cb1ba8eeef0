// The Calibration tab: measurements (CSV or JSON) sent to POST /models/{id}/calibrate, and every
// measurement's residual before and after drawn as an SVG bar chart on a log scale.
// (A module of the model viewer; viewer.js is the entry point.)
//
// The answer's `residuals.before` / `residuals.after` are the Euclidean position residuals of every
// measurement (metres, the input's order): before is the nominal model (with its best device frame),
// after the calibrated one. Held-out measurements (`holdout`) are drawn orange (the fit never saw
// them: their bars are the honest ones), outliers (`outliers`, huber) outlined red. Nothing is
// computed here but the chart's scale.

import { api, showError } from "./api.js";
import { $, state } from "./config.js";
import { fillLinkOptions } from "./link-options.js";
import { loadModel } from "./loader.js";
import { current } from "./state.js";

// the SVG namespace, as the HTML parser gives it to an <svg> element (no URL in our files)
const SVG = (() => { const t = document.createElement("template"); t.innerHTML = "<svg></svg>"; return t.content.firstChild.namespaceURI; })();
const CHART = { width: 560, height: 250, left: 52, right: 10, top: 26, bottom: 30 };
const FLOOR = 1e-7;        // residuals below 0.1 um are drawn at 0.1 um (a log scale has no zero)
let lastAnswer = null;

function setCalStatus(text, kind = "") {
  const el = $("cal-status");
  el.textContent = text;
  el.className = kind;
}

/** The link picker follows the model shown (filled when the tab opens or a calibration starts). */
function ensureLinks() {
  const select = $("cal-link");
  if (!current.model || select.dataset.model === current.model.id) return;
  fillLinkOptions(select, current.model);
  select.dataset.model = current.model.id;
}

/** A length in metres as um or mm, for the axis and the summary. */
export function fmtLength(v) {
  if (v === null || v === undefined || !Number.isFinite(v)) return "-";
  if (Math.abs(v) >= 1e-3) return `${+(v * 1e3).toPrecision(3)} mm`;
  return `${+(v * 1e6).toPrecision(3)} µm`;
}

function el(name, attrs = {}, text = null) {
  const node = document.createElementNS(SVG, name);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, String(v));
  if (text !== null) node.textContent = text;
  return node;
}

/** The residual chart: per measurement i a grey bar (before) and a blue or orange one (after),
 * heights on a log scale of metres; dashed lines at the RMS before and after. */
export function residualChart(answer) {
  const before = answer.residuals.before;
  const after = answer.residuals.after;
  const n = before.length;
  const held = new Set(answer.holdout || []);
  const outliers = new Set(answer.outliers || []);
  const { width: W, height: H, left, right, top, bottom } = CHART;
  const values = [...before, ...after].filter((v) => Number.isFinite(v)).map((v) => Math.max(v, FLOOR));
  const lo = Math.pow(10, Math.floor(Math.log10(Math.min(...values))));
  let hi = Math.pow(10, Math.ceil(Math.log10(Math.max(...values))));
  if (hi <= lo) hi = lo * 10;
  const y = (v) => top + (H - top - bottom) * (1 - (Math.log10(Math.max(v, FLOOR)) - Math.log10(lo)) / (Math.log10(hi) - Math.log10(lo)));
  const svg = el("svg", { viewBox: `0 0 ${W} ${H}`, role: "img", "aria-label": "residual per measurement, before and after" });
  for (let e = Math.log10(lo); e <= Math.log10(hi) + 1e-9; e += 1) {
    const v = Math.pow(10, e);
    svg.appendChild(el("line", { class: "grid", x1: left, x2: W - right, y1: y(v), y2: y(v) }));
    svg.appendChild(el("text", { x: left - 4, y: y(v) + 3, "text-anchor": "end" }, fmtLength(v)));
  }
  const group = (W - left - right) / n;
  const bar = Math.max(group * 0.42, 0.6);
  const base = H - bottom;
  const bars = el("g", { class: "bars" });
  for (let i = 0; i < n; i += 1) {
    const x = left + i * group + group * 0.08;
    const tag = `measurement ${i}`;
    const b = el("rect", { class: "bar-before", x, y: y(before[i]), width: bar, height: base - y(before[i]), "data-index": i });
    b.appendChild(el("title", {}, `${tag}: before ${fmtLength(before[i])}`));
    const cls = ["bar-after", held.has(i) ? "held-out" : "", outliers.has(i) ? "outlier" : ""].filter(Boolean).join(" ");
    const a = el("rect", { class: cls, x: x + bar, y: y(after[i]), width: bar, height: base - y(after[i]), "data-index": i });
    a.appendChild(el("title", {}, `${tag}: after ${fmtLength(after[i])}${held.has(i) ? " (held out)" : ""}${outliers.has(i) ? " (outlier)" : ""}`));
    bars.append(b, a);
  }
  svg.appendChild(bars);
  for (const [cls, v, label] of [["rms-before", answer.rmse_before, "RMS before"], ["rms-after", answer.rmse_after, "RMS after"]]) {
    if (!Number.isFinite(v) || v <= 0) continue;
    svg.appendChild(el("line", { class: cls, x1: left, x2: W - right, y1: y(v), y2: y(v) }));
    svg.appendChild(el("text", { x: W - right - 2, y: y(v) - 3, "text-anchor": "end" }, `${label} ${fmtLength(v)}`));
  }
  const step = Math.max(1, Math.ceil(n / 12));
  for (let i = 0; i < n; i += step) {
    svg.appendChild(el("text", { x: left + (i + 0.5) * group, y: base + 12, "text-anchor": "middle" }, String(i)));
  }
  svg.appendChild(el("line", { class: "grid", x1: left, x2: W - right, y1: base, y2: base }));
  svg.appendChild(el("text", { x: (left + W - right) / 2, y: H - 4, "text-anchor": "middle" }, "measurement"));
  const legend = [["bar-before", "before (nominal)"], ["bar-after", "after (fitted)"], ["bar-after held-out", "after (held out)"]];
  let lx = left;
  for (const [cls, label] of legend) {
    svg.appendChild(el("rect", { class: cls, x: lx, y: 6, width: 10, height: 10 }));
    svg.appendChild(el("text", { x: lx + 13, y: 15 }, label));
    lx += 18 + label.length * 5.4;
  }
  if (outliers.size) {
    svg.appendChild(el("rect", { class: "bar-after outlier", x: lx, y: 6, width: 10, height: 10 }));
    svg.appendChild(el("text", { x: lx + 13, y: 15 }, "outlier"));
  }
  return svg;
}

function summaryRows(a) {
  const rows = [
    ["RMS before → after", `${fmtLength(a.rmse_before)} → ${fmtLength(a.rmse_after)}`],
    ["largest before → after", `${fmtLength(a.max_before)} → ${fmtLength(a.max_after)}`],
  ];
  if (a.holdout && a.holdout.length) rows.push([`held out (${a.holdout.length})`, `RMS ${fmtLength(a.holdout_rmse)}`]);
  if (a.rotation_rmse_after !== null && a.rotation_rmse_after !== undefined) {
    rows.push(["rotation RMS before → after", `${a.rotation_rmse_before.toExponential(2)} → ${a.rotation_rmse_after.toExponential(2)} rad`]);
  }
  rows.push(["identifiable", `${a.identifiable} combinations, condition number ${a.condition_number.toPrecision(3)}`]);
  rows.push(["outliers", a.outliers.length ? a.outliers.join(", ") : "none"]);
  rows.push(["calibrated model", a.model]);
  const table = $("cal-summary");
  table.replaceChildren();
  for (const [k, v] of rows) {
    const tr = table.insertRow();
    const th = document.createElement("th");
    th.textContent = k;
    tr.appendChild(th);
    tr.insertCell().textContent = v;
  }
}

/** The request from the text: JSON (a list of measurements, or a request object) or CSV. */
function requestOf(text) {
  const options = {
    link: $("cal-link").value, loss: $("cal-loss").value, parameters: $("cal-parameters").value,
    holdout: Number($("cal-holdout").value) || 0,
  };
  const t = text.trim();
  if (!t) throw new Error("Paste or load measurements first (CSV or JSON).");
  if (t[0] === "[" || t[0] === "{") {
    let parsed;
    try { parsed = JSON.parse(t); } catch (err) { throw new Error(`The measurements are not valid JSON: ${err.message}`); }
    const body = Array.isArray(parsed) ? { ...options, measurements: parsed } : { ...options, ...parsed };
    return { body, count: (body.measurements || []).length };
  }
  const query = new URLSearchParams(Object.entries(options).map(([k, v]) => [k, String(v)]));
  const count = Math.max(t.split(/\r?\n/).filter((line) => line.trim()).length - 1, 0);
  return { raw: t, query: query.toString(), count };
}

export async function runCalibration() {
  if (!current.model) return null;
  ensureLinks();
  const id = current.model.id;
  let req;
  try {
    req = requestOf($("cal-measurements").value);
  } catch (err) {
    setCalStatus(err.message, "warn");
    return null;
  }
  state.calRequests += 1;
  setCalStatus(`Calibrating from ${req.count} measurements…`);
  $("cal-run").disabled = true;
  try {
    const path = `/models/${encodeURIComponent(id)}/calibrate`;
    const answer = req.body
      ? await api(path, { method: "POST", body: req.body })
      : await api(`${path}?${req.query}`, { method: "POST", raw: req.raw, contentType: "text/csv" });
    lastAnswer = answer;
    $("cal-chart").replaceChildren(residualChart(answer));
    summaryRows(answer);
    $("cal-open").hidden = false;
    const gain = answer.rmse_after > 0 ? ` (${(answer.rmse_before / answer.rmse_after).toFixed(0)}× smaller)` : "";
    setCalStatus(`RMS ${fmtLength(answer.rmse_before)} → ${fmtLength(answer.rmse_after)}${gain}; calibrated model ${answer.model}.`, "ok");
    state.calibration = {
      model: answer.model, from: answer.from, measurements: answer.residuals.before.length,
      bars_before: $("cal-chart").querySelectorAll("rect.bar-before[data-index]").length,
      bars_after: $("cal-chart").querySelectorAll("rect.bar-after[data-index]").length,
      rmse_before: answer.rmse_before, rmse_after: answer.rmse_after, holdout: answer.holdout, outliers: answer.outliers,
      residuals: answer.residuals,
    };
    return state.calibration;
  } catch (err) {
    setCalStatus("The calibration was refused (see the message above).", "warn");
    showError(err);
    state.calibration = { error: err.message };
    return null;
  } finally {
    state.calResponses += 1;
    $("cal-run").disabled = false;
  }
}

/** The worked example of the API page (POST /models/{id}/calibrate, "ur5_positions"): UR5 only. */
export async function loadExample() {
  const spec = await api("/openapi.json");
  const op = spec.paths["/models/{model_id}/calibrate"].post;
  const example = op.requestBody.content["application/json"].examples.ur5_positions.value;
  $("cal-measurements").value = JSON.stringify(example.measurements, null, 0).replace(/\},\{/g, "},\n{");
  if (current.model && current.model.id !== "ur5") setCalStatus("The example measures a UR5: open ur5 to calibrate it.", "warn");
  else { ensureLinks(); $("cal-link").value = example.link; setCalStatus(`${example.measurements.length} measurements of a UR5 as built.`); }
}

$("cal-run").addEventListener("click", () => runCalibration());
$("cal-example").addEventListener("click", () => loadExample().catch(showError));
$("cal-file").addEventListener("change", () => {
  const file = $("cal-file").files[0];
  if (!file) return;
  const reader = new FileReader();                     // the user's own file, read in the page
  reader.onload = () => { $("cal-measurements").value = String(reader.result); setCalStatus(`${file.name} loaded.`); };
  reader.readAsText(file);
});
$("cal-open").addEventListener("click", () => { if (lastAnswer) loadModel(lastAnswer.model); });
document.querySelector('.tabs button[data-tab="calibration"]').addEventListener("click", ensureLinks);

// Test hook entries (merged into window.viewerTest, made by test-hook.js or here first).
window.viewerTest = Object.assign(window.viewerTest || {}, {
  calibrationExample: async () => { await loadExample(); return $("cal-measurements").value.length; },
  calibrate: () => runCalibration(),
});
