// What the viewer opens a model on, as a person would choose it: the tool link selected, and a
// pose free of self-collision. Pure functions of the model's description (GET /models/{id}),
// with no page and no three.js, so that the tests run them with node as the page does.

export const CONTINUOUS_RANGE = Math.PI;         // slider range of a joint without limits (rad)
export const UNLIMITED_PRISMATIC_RANGE = 1.0;    // slider range of an unlimited prismatic joint (m)
/** Names of tool links, most telling first, matched as whole words of a link's name (`panda_hand_tcp`). */
export const TOOL_NAMES = ["tcp", "tool0", "tool", "flange", "ee_link", "end_effector", "ee", "gripper", "hand"];

export function sliderRange(joint) {
  const lim = joint.limits;
  const finite = lim && Number.isFinite(lim.lower) && Number.isFinite(lim.upper) && lim.upper > lim.lower;
  if (finite) return [lim.lower, lim.upper];
  if (joint.type === "prismatic") return [-UNLIMITED_PRISMATIC_RANGE, UNLIMITED_PRISMATIC_RANGE];
  return [-CONTINUOUS_RANGE, CONTINUOUS_RANGE];
}

/** q = 0 clamped into the joint's range. */
export function initialValue(joint) {
  const [lower, upper] = sliderRange(joint);
  return Math.min(Math.max(0, lower), upper);
}

/** How many moving joints lie between the root and each link. */
function depths(info) {
  const parentJoint = Object.fromEntries(info.joints.map((j) => [j.child, j]));
  const out = {};
  for (const link of info.links) {
    let depth = 0;
    for (let j = parentJoint[link]; j; j = parentJoint[j.parent]) if (j.type !== "fixed") depth += 1;
    out[link] = depth;
  }
  return out;
}

/** The link a person would look at first: a link named as tools are (`TOOL_NAMES`, the most
 * telling name first, then the farthest from the root), else the leaf link farthest (in moving
 * joints) from the root. */
export function defaultLink(info) {
  const depth = depths(info);
  for (const name of TOOL_NAMES) {
    const word = new RegExp(`(^|[_\\-/])${name}($|[_\\-/])`, "i");
    const named = info.links.filter((link) => word.test(link));
    if (named.length) return named.reduce((a, b) => (depth[b] > depth[a] ? b : a));
  }
  const hasChild = new Set(info.joints.map((j) => j.parent));
  let best = info.root;
  for (const link of info.links) {
    if (!hasChild.has(link) && (best === info.root || depth[link] > depth[best])) best = link;
  }
  return best;
}

/** The poses to open on, in order of preference (q in the order of `joint_names`): q = 0 clamped
 * into the limits; then 0 where it lies inside the limits and the middle of the limits where it
 * does not (an elbow whose range excludes 0); then the middle of every joint's limits. */
export function openingCandidates(info) {
  const byName = Object.fromEntries(info.joints.map((j) => [j.name, j]));
  const joints = info.joint_names.map((name) => byName[name]);
  const middle = (joint) => { const [lower, upper] = sliderRange(joint); return (lower + upper) / 2; };
  const inside = (joint) => { const [lower, upper] = sliderRange(joint); return lower < 0 && 0 < upper; };
  return [
    joints.map(initialValue),
    joints.map((joint) => (inside(joint) ? 0 : middle(joint))),
    joints.map(middle),
  ];
}

/** The first candidate not colliding (`colliding[k]` of candidate k, as POST .../collision answers
 * a batch), else the first. */
export function openingPose(candidates, colliding) {
  const k = colliding ? colliding.findIndex((c) => !c) : -1;
  return candidates[k >= 0 ? k : 0];
}
