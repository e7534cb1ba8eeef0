// Closed forms of the chain to a tip (POST /models/{id}/symbolic), typeset with KaTeX.
// (A module of the model viewer; viewer.js is the entry point.)

import { api } from "./api.js";
import { $, state } from "./config.js";
import { fillLinkOptions } from "./link-options.js";
import { current } from "./state.js";

// ---------------------------------------------------------------------------- closed forms (KaTeX)
export const PROBLEM_PREFIX = "urn:kinematics:problem:";
let cfSeq = 0;

/** Typeset `tex` into `element` with the vendored KaTeX (DOM nodes: no inline style attributes). */
export function typeset(tex, element) {
  if (!window.katex) throw new Error("KaTeX did not load (vendor/katex/katex.min.js)");
  window.katex.render(tex, element, { displayMode: true, throwOnError: false, strict: "ignore" });
}

/** Render a symbolic answer (format latex) into `container`: T, and on request the factors A_i
 * (with base and tool) and the Jacobians. Returns the number of typeset items. */
export function renderClosedForm(container, body, { factors = false, jacobian = false } = {}) {
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
export function closedFormProblem(err) {
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

export function fillClosedFormTips(info) {
  fillLinkOptions($("cf-tip"), info,
                  (link) => (info.leaf_links && info.leaf_links.includes(link) ? `${link} (leaf)` : link));
  $("cf-output").replaceChildren();
  $("cf-status").textContent = "";
  $("cf-status").className = "";
  state.closedForm = null;
}

export async function deriveClosedForm() {
  if (!current.model) return;
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
    const body = await api(`/models/${encodeURIComponent(current.model.id)}/symbolic`, {
      method: "POST", body: { tip, what, format: "latex", simplify: $("cf-simplify").checked },
    });
    if (seq !== cfSeq) return;
    const count = renderClosedForm($("cf-output"), body, { factors, jacobian });
    status.textContent = `${current.model.id}: ${body.root} to ${body.tip}, ${body.joint_variables.length} joint variable(s).`;
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
