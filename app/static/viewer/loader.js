// Loading a model (GET /models/{id}, FK of all links), the catalogue picker and the links panel.
// (A module of the model viewer; viewer.js is the entry point.)

import { api, clearError, showError } from "./api.js";
import { fillClosedFormTips } from "./closed-forms.js";
import { $, API_KEY_STORAGE, FIT_DIRECTION, FK_LINKS_ALL, ROOT, state } from "./config.js";
import { ik, resetIkTarget } from "./ik.js";
import { clearPath } from "./path.js";
import { applyPoses, buildRobot, checkCollision, buildSliders, fitCamera, highlightSelected, nextLoadToken, setAll, setModel, showOutOfLimits, showSelectedPose } from "./robot.js";
import { requestRender, resize } from "./scene.js";
import { buildQdotInputs } from "./velocity.js";
import { clearWorkspace } from "./workspace.js";
import { defaultLink, openingCandidates, openingPose } from "./defaults.js";
import { fillLinkOptions } from "./link-options.js";
import { current } from "./state.js";

// ---------------------------------------------------------------------------- links panel
export function buildLinkList(info) {
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
export async function loadCatalogue(selected) {
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

/** The opening pose (defaults.js): the first candidate POST /collision says is free; the first
 * one when none is, or when collision checking is unavailable. */
async function freeOpeningPose(id, info) {
  const candidates = openingCandidates(info);
  try {
    const answer = await api(`/models/${encodeURIComponent(id)}/collision`, { method: "POST", body: { q: candidates } });
    return openingPose(candidates, answer.colliding);
  } catch (err) {
    return candidates[0];
  }
}

export async function loadModel(id, { push = true } = {}) {
  const token = nextLoadToken();
  state.ready = false;
  clearError();
  try {
    const info = await api(`/models/${encodeURIComponent(id)}`);
    let visuals = {};
    try {
      visuals = (await api(`/models/${encodeURIComponent(id)}/visual`)).links || {};
    } catch (err) {
      showError(err);                    // the skeleton is still worth showing
    }
    // Start at q = 0 clamped into the limits, or the next candidate where that is in self-collision.
    const q = await freeOpeningPose(id, info);
    state.fkRequests += 1;
    const fk = await api(`/models/${encodeURIComponent(id)}/fk`, { method: "POST", body: { q, links: FK_LINKS_ALL } });
    state.fkResponses += 1;
    if (token !== current.loadToken) return;
    state.lastQ = q;
    setModel(info);
    buildSliders(info, q);
    if (current.model.id === undefined) current.model.id = id;
    state.modelId = current.model.id;
    buildLinkList(info);
    fillClosedFormTips(info);
    buildRobot(info, visuals, fk.poses);
    applyPoses(fk.poses);
    checkCollision(q);
    resize();
    fitCamera(FIT_DIRECTION);
    clearWorkspace();
    clearPath();
    buildQdotInputs(info);
    showOutOfLimits(fk.out_of_limits || []);
    $("model-picker").value = current.model.id;
    $("model-summary").textContent = `${info.name || current.model.id}: ${info.dof} dof, ${info.links.length} links, root ${info.root}`;
    const meshCount = Object.values(visuals).flat().filter((v) => v.kind === "mesh" && !v.url).length;
    const notes = [...(info.warnings || [])];
    if (meshCount) notes.push(`${meshCount} mesh visual(s) not drawn (the service serves them not).`);
    $("model-warnings").hidden = notes.length === 0;
    $("model-warnings").textContent = notes.join(" ");
    $("download-urdf").disabled = false;
    $("dh-edit-current").hidden = !info.dh_table;
    document.title = `${current.model.id} - model viewer`;
    if (push) history.pushState({ id: current.model.id }, "", `${ROOT}/viewer/${encodeURIComponent(current.model.id)}`);
    if (ik.enabled) resetIkTarget();
    await showSelectedPose(q);
    requestRender();
    await new Promise((resolve) => requestAnimationFrame(() => requestAnimationFrame(resolve)));
    if (token === current.loadToken) state.ready = true;
  } catch (err) {
    showError(err);
  }
}

$("model-picker").addEventListener("change", () => loadModel($("model-picker").value));
window.addEventListener("popstate", (e) => { if (e.state && e.state.id) loadModel(e.state.id, { push: false }); });
$("btn-zero").addEventListener("click", () => setAll(current.sliders.map((s) => Math.min(Math.max(0, s.lower), s.upper))));
$("btn-random").addEventListener("click", () => setAll(current.sliders.map((s) => s.lower + Math.random() * (s.upper - s.lower))));
$("error-close").addEventListener("click", clearError);
$("api-key").addEventListener("click", () => {
  const key = window.prompt("API key of the service (sent as X-API-Key; kept for this tab only). Empty to forget it.",
    sessionStorage.getItem(API_KEY_STORAGE) || "");
  if (key === null) return;
  if (key) sessionStorage.setItem(API_KEY_STORAGE, key); else sessionStorage.removeItem(API_KEY_STORAGE);
  if (current.model) loadModel(current.model.id, { push: false }); else start();
});

export async function downloadUrdf(id) {
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
$("download-urdf").addEventListener("click", () => current.model && downloadUrdf(current.model.id));
