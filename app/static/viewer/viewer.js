// Model viewer: draws a model of the service as a kinematic skeleton and lets a person move
// its joints, or drag an IK target for a link. All kinematics comes from the service
// (POST /models/{id}/fk, /jacobian, /ik): this file does no robotics math, it only places what
// the service returns. The "Closed form" tab and the DH editor show the service's closed forms
// (POST /models/{id}/symbolic, /symbolic/dh, format latex), typeset by the vendored KaTeX
// (vendor/katex/, a classic script defining window.katex).
//
// Frames: the scene is the world frame of the model (the root link's frame), z up, metres.
// Every link pose comes from FK with links "all" as T_world_link (row-major 4x4). There is no
// conversion between the two: the camera's up vector is +z instead (no y-up rotation of the
// robot), so a scene object's position and quaternion are a pose in the model's world frame,
// which is what the IK target gizmo sends to POST /models/{id}/ik.
//
// The viewer is ES modules (no build step, relative imports): config.js, api.js, scene.js,
// robot.js, meshes.js (visuals and meshes), self-collision.js, ik.js (with ghosts.js, every IK
// solution, self-motion.js, a 7-joint arm's self-motion, and path.js, Cartesian paths), workspace.js, velocity.js, closed-forms.js, dh-editor.js,
// loader.js, calibration.js, trajectory.js (a planned path timed and played in time), state.js (the
// state they share: the model shown, and events), test-hook.js (window.viewerTest); this one, the
// entry point, wires the tabs and starts.

import { ApiError, showError } from "./api.js";
import "./calibration.js";
import { $, ROOT } from "./config.js";
import { DH_EXAMPLE, addDhRow } from "./dh-editor.js";
import { loadCatalogue, loadModel } from "./loader.js";
import { resize } from "./scene.js";
import "./test-hook.js";
import "./trajectory.js";

// ---------------------------------------------------------------------------- tabs
for (const button of document.querySelectorAll(".tabs button")) {
  button.addEventListener("click", () => {
    for (const b of document.querySelectorAll(".tabs button")) b.classList.toggle("active", b === button);
    for (const tab of document.querySelectorAll(".tab")) tab.hidden = tab.id !== `tab-${button.dataset.tab}`;
    $("left").classList.toggle("wide", button.dataset.tab === "closed" || button.dataset.tab === "calibration");
    resize();
  });
}

// ---------------------------------------------------------------------------- start
async function start() {
  if (!$("dh-table").tBodies[0].rows.length) DH_EXAMPLE.forEach((row) => addDhRow(row));
  resize();
  const fromPath = document.body.dataset.model || "";
  try {
    const list = await loadCatalogue(fromPath);
    const id = fromPath || (list.find((m) => m.id === "ur5") || list[0] || {}).id;
    if (!id) throw new ApiError("The catalogue is empty.");
    history.replaceState({ id }, "", `${ROOT}/viewer/${encodeURIComponent(id)}`);
    await loadModel(id, { push: false });
  } catch (err) {
    showError(err);
  }
}
start();
