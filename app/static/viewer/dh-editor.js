// The DH editor: a table built into a model (POST /models/dh) and its closed forms (POST /symbolic/dh).
// (A module of the model viewer; viewer.js is the entry point.)

import { api, clearError, showError } from "./api.js";
import { closedFormProblem, renderClosedForm } from "./closed-forms.js";
import { $, state } from "./config.js";
import { downloadUrdf, loadCatalogue, loadModel } from "./loader.js";
import { current } from "./state.js";

// ---------------------------------------------------------------------------- DH editor
export const DH_EXAMPLE = [   // a planar 2R arm with a prismatic wrist lift (standard, degrees)
  { type: "revolute", a: 0.4, alpha: 0, d: 0.3, theta: 0, lower: -170, upper: 170, name: "" },
  { type: "revolute", a: 0.3, alpha: 180, d: 0, theta: 0, lower: -150, upper: 150, name: "" },
  { type: "prismatic", a: 0, alpha: 0, d: 0.1, theta: 0, lower: 0, upper: 0.2, name: "" },
];
export const DH_FIELDS = ["a", "alpha", "d", "theta", "lower", "upper"];
export const DH_SYMBOLIC_FIELDS = ["a", "alpha", "d", "theta"];   // cells that may hold symbols (POST /symbolic/dh)

/** The cells of a table read with symbols that are not numbers. */
export function dhSymbolicCells(table) {
  return table.joints.flatMap((j) => DH_SYMBOLIC_FIELDS.filter((f) => typeof j[f] === "string").map((f) => j[f]));
}

/** POST /symbolic/dh of the editor's table (symbols allowed) and its closed form under the editor. */
export async function showDhClosedForm(table) {
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

export function addDhRow(row = { type: "revolute", a: 0, alpha: 0, d: 0, theta: 0, lower: "", upper: "", name: "" }) {
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

export function numberDhRows() {
  [...$("dh-table").tBodies[0].rows].forEach((tr, i) => { tr.querySelector(".idx").textContent = String(i + 1); });
}

/** The DH table as POST /models/dh takes it; throws naming the row and column of bad input.
 * With `symbols`, a, alpha, d and theta may also be symbols or expressions (`a1`, `-d4`, `pi/2`),
 * kept as strings for POST /symbolic/dh (which reads and checks them). */
export function readDhTable({ symbols = false } = {}) {
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

export const IDENTITY = JSON.stringify([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]);

/** Fill the editor from a DH table as the service returns it (model info's `dh_table`). */
export function fillDhEditor(table) {
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

// The editor's table (symbols allowed), or null after showing why it cannot be read.
function readDhTableOrShow() {
  try {
    return readDhTable({ symbols: true });
  } catch (err) {
    showError(err);
    return null;
  }
}

$("dh-add").addEventListener("click", () => addDhRow());
$("dh-edit-current").addEventListener("click", () => { if (current.model && current.model.dh_table) fillDhEditor(current.model.dh_table); });
$("dh-build").addEventListener("click", async () => {
  const result = $("dh-result");
  result.className = "";
  result.textContent = "";
  const table = readDhTableOrShow();
  if (!table) return;
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
  const table = readDhTableOrShow();
  if (!table) return;
  await showDhClosedForm(table);
});
