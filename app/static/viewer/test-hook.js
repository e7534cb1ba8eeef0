// The test hook window.viewerTest (tests/app/test_viewer*.py drive the page through it); also
// handy from the browser console. It reaches into the IK, ghost, path, velocity and workspace
// modules and none of them imports it: viewer.js does.
// (A module of the model viewer; viewer.js is the entry point.)

import * as THREE from "three";
import { $, state } from "./config.js";
import { chooseGhost, ghostPoints, ghostsBusy } from "./ghosts.js";
import { ik, ikBusy, ikTarget, ikTargetPose, requestIk, setIkEnabled } from "./ik.js";
import { pathBusy, pathTest } from "./path.js";
import { selfMotionBusy, selfMotionTest } from "./self-motion.js";
import { currentQ, fitCamera, fkBusy } from "./robot.js";
import { camera, controls, gizmo, renderer, requestRender } from "./scene.js";
import { current } from "./state.js";
import { setQdot, velocityBusy } from "./velocity.js";
import { sampleWorkspace } from "./workspace.js";

/** No IK, every-solution, self-motion, path or FK work pending or in flight. */
export function settled() {
  return !ikBusy() && !ghostsBusy() && !selfMotionBusy() && !pathBusy() && !fkBusy();
}

export async function whenSettled() {
  while (!settled()) await new Promise((resolve) => setTimeout(resolve, 10));
}

window.viewerTest = Object.assign(window.viewerTest || {}, {
  setIkEnabled(on) { setIkEnabled(on); return ik.enabled; },
  setGizmoMode(mode) { $("ik-gizmo-mode").value = mode; gizmo.setMode(mode); requestRender(); },
  /** Move the target to `position` [x, y, z] and `quaternion` {w, x, y, z} (world frame) and
   * run what a drag end runs; resolves when the answer is drawn. */
  async ikTo(position, quaternion) {
    if (!ik.enabled) throw new Error("the IK target is off");
    ikTarget.position.set(...position);
    ikTarget.quaternion.set(quaternion.x, quaternion.y, quaternion.z, quaternion.w).normalize();
    ikTarget.updateMatrixWorld(true);
    requestRender();
    requestIk({ final: true });
    await whenSettled();
    return { q: currentQ(), status: state.ikStatus, last: state.ikLast };
  },
  whenSettled: async () => { await whenSettled(); return true; },
  /** Every solution of the target (as drawn): window.viewerState.ghosts once settled. */
  ghosts: () => state.ghosts,
  /** Make solution `index` the configuration, as a click on its ghost does; resolves when drawn. */
  async chooseGhost(index) { chooseGhost(index); await whenSettled(); return currentQ(); },
  /** Client (CSS pixel) points on ghost `index` where a click hits it first. */
  ghostPoints: (index) => ghostPoints(index),
  ...pathTest,
  ...selfMotionTest,
  /** Canvas (CSS pixel) coordinates of every link origin as the camera sees it now, and the
   * canvas size: {width, height, points: {link: [x, y, depth]}} (depth in (-1, 1) when between
   * the near and far planes). */
  projectLinks() {
    camera.updateMatrixWorld();
    const rect = renderer.domElement.getBoundingClientRect();
    const points = {};
    for (const [link, pose] of Object.entries(current.lastPoses || {})) {
      const p = new THREE.Vector3(...pose.position).project(camera);
      points[link] = [(p.x + 1) / 2 * rect.width, (1 - p.y) / 2 * rect.height, p.z];
    }
    return { width: rect.width, height: rect.height, points };
  },
  fit: () => { fitCamera(); return state.fits; },
  /** Move the camera (a zoom or orbit by hand), e.g. to test the fit button. */
  moveCamera(position, target) {
    camera.position.set(...position);
    controls.target.set(...target);
    controls.update();
    requestRender();
  },
  async sampleWorkspace(samples = 5000) {
    $("ws-samples").value = String(samples);
    const before = state.wsResponses;
    sampleWorkspace();
    while (state.wsResponses === before) await new Promise((resolve) => setTimeout(resolve, 20));
    return state.workspace;
  },
  /** Set the joint velocities and wait for their arrows. */
  async setQdot(values) {
    const before = state.velocityResponses;
    setQdot(values);
    if (values.every((v) => v === 0)) return state.lastVelocity;
    while (state.velocityResponses === before || velocityBusy()) {
      await new Promise((resolve) => setTimeout(resolve, 20));
    }
    return state.lastVelocity;
  },
  /** The exact joint values (the thumbs of the range inputs are rounded to their step). */
  sliderValues: () => currentQ(),
  targetPose: () => ikTargetPose(),
  /** Client (CSS pixel) coordinates of a point on the translate gizmo's handle for `axis`
   * ("X", "Y" or "Z"), for a real mouse drag. Mirrors TransformControls' own handle scale:
   * its pickers run from 0 to 0.6 along the axis in units of factor * size / 4. */
  gizmoHandlePoint(axis = "X", along = 0.45) {
    camera.updateMatrixWorld();
    const factor = ikTarget.position.distanceTo(camera.position)
      * Math.min(1.9 * Math.tan(Math.PI * camera.fov / 360) / camera.zoom, 7);
    const unit = { X: [1, 0, 0], Y: [0, 1, 0], Z: [0, 0, 1] }[axis];
    const point = new THREE.Vector3(...unit).multiplyScalar(along * factor * gizmo.size / 4).add(ikTarget.position);
    point.project(camera);
    const rect = renderer.domElement.getBoundingClientRect();
    return { x: rect.left + (point.x + 1) / 2 * rect.width, y: rect.top + (1 - point.y) / 2 * rect.height };
  },
});
