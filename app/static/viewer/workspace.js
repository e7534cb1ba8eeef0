// The workspace cloud of the selected link (POST /models/{id}/workspace, .npy).
// (A module of the model viewer; viewer.js is the entry point.)

import * as THREE from "three";
import { api, showError } from "./api.js";
import { $, CLOUD_COLOR_QUANTILE, CLOUD_POINT_FRACTION, state } from "./config.js";
import { fitCamera, fmt } from "./robot.js";
import { requestRender, scene } from "./scene.js";
import { current } from "./state.js";

// ---------------------------------------------------------------------------- workspace cloud
// POST /models/{id}/workspace with Accept: application/x-npy answers an (N, 4) float64 array of
// rows x, y, z, manipulability (world frame): drawn as points coloured by manipulability / max.
let cloud = null;                         // THREE.Points: the sampled workspace of the selected link
let wsSeq = 0;
current.framed.push((box) => {           // a camera fit frames the cloud shown too
  if (!cloud || !cloud.visible) return;
  cloud.geometry.computeBoundingBox();
  box.union(cloud.geometry.boundingBox);
});

/** The float64 array of a NumPy .npy file (format 1.x/2.x, little-endian '<f8', C order) and its shape. */
export function parseNpy(buffer) {
  const bytes = new Uint8Array(buffer);
  if (bytes[0] !== 0x93 || String.fromCharCode(...bytes.slice(1, 6)) !== "NUMPY") throw new Error("not a .npy answer");
  const major = bytes[6];
  const view = new DataView(buffer);
  const headerLength = major === 1 ? view.getUint16(8, true) : view.getUint32(8, true);
  const start = (major === 1 ? 10 : 12) + headerLength;
  const header = new TextDecoder().decode(bytes.slice(major === 1 ? 10 : 12, start));
  if (!header.includes("'<f8'") || header.includes("'fortran_order': True")) throw new Error(`unexpected .npy header ${header}`);
  const shape = (header.match(/'shape': \(([^)]*)\)/)[1]).split(",").filter((x) => x.trim()).map(Number);
  return { data: new Float64Array(buffer, start), shape };
}

/** Viridis at t in [0, 1] (five stops, linear between them). */
export const VIRIDIS = [[0x44, 0x01, 0x54], [0x3b, 0x52, 0x8b], [0x21, 0x91, 0x8c], [0x5e, 0xc9, 0x62], [0xfd, 0xe7, 0x25]];
export function viridis(t, out, k) {
  const x = Math.min(Math.max(t, 0), 1) * (VIRIDIS.length - 1);
  const i = Math.min(Math.floor(x), VIRIDIS.length - 2);
  const f = x - i;
  for (let c = 0; c < 3; c++) out[k + c] = (VIRIDIS[i][c] + f * (VIRIDIS[i + 1][c] - VIRIDIS[i][c])) / 255;
}

export function clearWorkspace() {
  wsSeq += 1;
  if (cloud) {
    scene.remove(cloud);
    cloud.geometry.dispose();
    cloud.material.dispose();
    cloud = null;
  }
  state.workspace = null;
  $("ws-show").disabled = true;
  $("ws-clear").disabled = true;
  $("ws-colorbar").hidden = true;
  $("ws-status").textContent = "";
  requestRender();
}

export function setWsStatus(text, kind = "") {
  $("ws-status").textContent = text;
  $("ws-status").className = kind;
}

export async function sampleWorkspace() {
  if (!current.model) return;
  const id = current.model.id;
  const link = state.selectedLink;
  const samples = Math.round(Number($("ws-samples").value) || 20000);
  const seed = Math.round(Number($("ws-seed").value) || 0);
  const seq = ++wsSeq;
  state.wsRequests += 1;
  setWsStatus(`Sampling ${samples} configurations for ${link}...`);
  try {
    const body = { link, samples, random_seed: seed };
    const [buffer, summary] = await Promise.all([
      api(`/models/${encodeURIComponent(id)}/workspace`, { method: "POST", body, binary: "application/x-npy" }),
      api(`/models/${encodeURIComponent(id)}/workspace`, { method: "POST", body }),
    ]);
    state.wsResponses += 1;
    if (seq !== wsSeq || !current.model || current.model.id !== id) return;
    const { data, shape } = parseNpy(buffer);
    const n = shape[0];
    const positions = new Float32Array(3 * n);
    const colors = new Float32Array(3 * n);
    let best = 0;
    const values = new Float64Array(n);
    for (let i = 0; i < n; i++) { values[i] = data[4 * i + 3]; best = Math.max(best, values[i]); }
    values.sort();
    const top = n ? values[Math.min(n - 1, Math.floor(CLOUD_COLOR_QUANTILE * n))] || best : 0;
    for (let i = 0; i < n; i++) {
      positions[3 * i] = data[4 * i];
      positions[3 * i + 1] = data[4 * i + 1];
      positions[3 * i + 2] = data[4 * i + 2];
      viridis(top > 0 ? data[4 * i + 3] / top : 0, colors, 3 * i);
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute("position", new THREE.BufferAttribute(positions, 3));
    geometry.setAttribute("color", new THREE.BufferAttribute(colors, 3));
    const material = new THREE.PointsMaterial({ size: current.modelSize * CLOUD_POINT_FRACTION, vertexColors: true,
                                                 transparent: true, opacity: 0.7, depthWrite: false });
    if (cloud) { scene.remove(cloud); cloud.geometry.dispose(); cloud.material.dispose(); }
    cloud = new THREE.Points(geometry, material);
    cloud.name = "workspace-cloud";
    cloud.visible = $("ws-show").checked;
    scene.add(cloud);
    state.workspace = { link, samples: n, maxManipulability: best, colorTop: top, volume: summary.volume,
                        area: summary.area ?? null, reach: summary.reach };
    $("ws-show").disabled = false;
    $("ws-clear").disabled = false;
    $("ws-colorbar").hidden = false;
    $("ws-max").textContent = `${fmt(top, 4)} (95th percentile; max ${fmt(best, 4)})`;
    const size = summary.dimension === 3 ? `volume ${fmt(summary.volume, 3)} m³` : `area ${fmt(summary.area, 3)} m²`;
    setWsStatus(`${link}: ${n} samples, reach ${fmt(summary.reach, 3)} m, ${size}.`);
    if (cloud.visible) fitCamera();        // frame the cloud around the model
    requestRender();
  } catch (err) {
    state.wsResponses += 1;
    if (seq !== wsSeq) return;
    setWsStatus("Sampling failed (see the message above).", "warn");
    showError(err);
  }
}

$("ws-sample").addEventListener("click", () => sampleWorkspace());
$("ws-clear").addEventListener("click", () => clearWorkspace());
$("ws-show").addEventListener("change", () => { if (cloud) { cloud.visible = $("ws-show").checked; requestRender(); } });
