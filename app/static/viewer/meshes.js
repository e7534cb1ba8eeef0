// The robot as it looks: each link's URDF visuals (GET /models/{id}/visual), primitives as three.js
// geometry and meshes (STL, Collada, OBJ) parsed by three.js's vendored loaders from the bytes the
// service serves (GET /models/{id}/visual/meshes/{index}: catalogue packages, uploaded archives;
// a plain upload's meshes have no URL and are not drawn). Also the link colouring the
// self-collision status uses (collision.js).
// (A module of the model viewer; viewer.js is the entry point.)

import * as THREE from "three";
import { ColladaLoader } from "three/addons/loaders/ColladaLoader.js";
import { OBJLoader } from "three/addons/loaders/OBJLoader.js";
import { STLLoader } from "three/addons/loaders/STLLoader.js";
import { api } from "./api.js";
import { ROOT, VISUAL_OPACITY, state } from "./config.js";
import { matrixFromRows, requestRender, visualObject } from "./scene.js";

export const MESH_COLOR = 0xb8bec9;        // a mesh or primitive without a URDF colour (and no own material)
export const COLLIDING_COLOR = 0xe0202a;   // the visuals of a link in self-collision

/** A fresh count of this load's meshes (the test hook reads it as viewerState.meshes). */
export function resetMeshState() {
  state.meshes = { expected: 0, loaded: 0, failed: 0, errors: [] };
}
resetMeshState();

function material(color, solid) {
  const m = new THREE.MeshStandardMaterial({ color: MESH_COLOR, roughness: 0.55, metalness: 0.1, side: THREE.DoubleSide });
  if (color) {
    m.color.setRGB(color[0], color[1], color[2], THREE.SRGBColorSpace);
    if (color[3] < 1) { m.transparent = true; m.opacity = color[3]; }
  } else if (!solid) {
    m.transparent = true; m.opacity = VISUAL_OPACITY; m.depthWrite = false;
  }
  return m;
}

/** Whether the model is drawn as it looks (some mesh is served): then primitives are solid too. */
export function hasServedMeshes(visuals) {
  return Object.values(visuals || {}).some((vs) => vs.some((v) => v.kind === "mesh" && v.url));
}

/** The objects of one link's visuals (primitives at once; a mesh as an empty holder that its
 * loaded geometry fills later), each tagged `userData.visual`. `solid`: opaque primitives. */
export function linkVisuals(elements, solid) {
  const out = [];
  for (const v of elements || []) {
    if (v.kind === "mesh") {
      if (!v.url) continue;
      const holder = new THREE.Group();
      holder.matrixAutoUpdate = false;
      holder.matrix.copy(matrixFromRows(v.origin));   // T_link_visual
      holder.userData = { visual: true, mesh: v };
      out.push(holder);
    } else {
      const obj = visualObject(v, material(v.color, solid));
      if (obj) { obj.userData = { visual: true }; out.push(obj); }
    }
  }
  return out;
}

function parse(format, bytes, url) {
  if (format === "stl") return new THREE.Mesh(new STLLoader().parse(bytes));
  const text = new TextDecoder().decode(bytes);
  if (format === "obj") return new OBJLoader().parse(text);
  if (format === "dae") {
    const scene = new ColladaLoader().parse(text, url.slice(0, url.lastIndexOf("/") + 1)).scene;
    // URDF meshes are in their link's frame as written: undo the loader's Z-up to Y-up turn.
    scene.rotation.set(0, 0, 0);
    return scene;
  }
  throw new Error(`mesh format ${format} is not drawn`);
}

/** Fill every mesh holder under `robot` with its mesh; `isCurrent()` false drops a stale load. */
export async function loadMeshes(robot, isCurrent) {
  const holders = [];
  robot.traverse((o) => { if (o.userData && o.userData.mesh) holders.push(o); });
  state.meshes.expected = holders.length;
  await Promise.all(holders.map(async (holder) => {
    const v = holder.userData.mesh;
    try {
      const path = v.url.startsWith(ROOT) ? v.url.slice(ROOT.length) : v.url;
      const bytes = await api(path, { binary: "*/*" });
      if (!isCurrent()) return;
      const object = parse(v.format, bytes, v.url);
      object.traverse((o) => {
        if (!o.isMesh) return;
        // a URDF colour wins; else the mesh's own materials (Collada), else the default grey
        if (v.color || v.format === "stl" || v.format === "obj") {
          o.material = material(v.color, true);
        }
        o.userData.visual = true;
      });
      object.scale.set(...v.scale);
      holder.add(object);
      state.meshes.loaded += 1;
      if (lastPaint) colourLinks(...lastPaint);   // a mesh that arrives after the answer is painted too
    } catch (err) {
      if (!isCurrent()) return;
      state.meshes.failed += 1;
      state.meshes.errors.push(`${v.source}: ${err.message}`);
      console.warn(`mesh ${v.source} not drawn: ${err.message}`);
    }
    requestRender();
  }));
}

// ---------------------------------------------------------------------------- colliding links
let lastPaint = null;   // the arguments of the last colourLinks call
const collidingMaterial = new THREE.MeshStandardMaterial({ color: COLLIDING_COLOR, roughness: 0.5, side: THREE.DoubleSide });

/** The drawn meshes of one link group: its visuals (primitives and loaded meshes). */
function visualMeshes(group) {
  const out = [];
  group.traverse((o) => { if (o.isMesh && o.userData.visual) out.push(o); });
  return out;
}

/** Draw the links in `names` red and every other link as it is: `linkGroups` link -> group,
 * `extra` link -> meshes standing for a link without visuals (the rod into it). */
export function colourLinks(linkGroups, names, extra = {}) {
  lastPaint = [linkGroups, names, extra];
  const red = new Set(names);
  for (const [link, group] of Object.entries(linkGroups)) {
    const visuals = visualMeshes(group);
    const painted = visuals.length ? visuals : (extra[link] || []);
    const others = visuals.length ? (extra[link] || []) : [];   // the rod, once the link's mesh is drawn
    for (const m of [...painted, ...others]) {
      if (red.has(link) && painted.includes(m)) {
        if (m.userData.ownMaterial === undefined) m.userData.ownMaterial = m.material;
        m.material = collidingMaterial;
      } else if (m.userData.ownMaterial !== undefined) {
        m.material = m.userData.ownMaterial;
        delete m.userData.ownMaterial;
      }
    }
  }
  requestRender();
}

/** The colours (hex) the visuals of `link` are drawn in now: the test hook. */
export function linkColours(linkGroups, link, extra = {}) {
  const group = linkGroups[link];
  if (!group) return [];
  let meshes = visualMeshes(group);
  if (!meshes.length && extra[link]) meshes = extra[link];
  const colours = [];
  for (const m of meshes) for (const mat of Array.isArray(m.material) ? m.material : [m.material]) {
    if (mat && mat.color) colours.push(mat.color.getHex());
  }
  return colours;
}
