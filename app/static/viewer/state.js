// The viewer's shared state: the model shown and what the modules draw of it, in one object
// (`current`), and the events by which a module tells the others what happened without
// importing them (robot.js: "fk-drawn", "link-moved"; ik.js: "target-moved", "ik-disabled").
// (A module of the model viewer; viewer.js is the entry point.) It imports no other module:
// every module may import it, and no circle runs through it.

export const current = {
  model: null,        // GET /models/{id} of the model shown
  loadToken: 0,       // the latest load: answers for an older one are dropped
  sliders: [],        // one per entry of joint_names: {name, joint, input, div, value, lower, upper}
  linkGroups: {},     // link name -> THREE.Group (matrix = T_world_link)
  lastPoses: null,    // link -> pose object of the last FK answer drawn
  modelSize: 1,       // the model's extent at its first pose (m): sizes triads, arrows, points
  framed: [],         // (box: THREE.Box3) => void: what a camera fit frames besides the robot
};

const listeners = new Map();

/** Call `fn(detail)` on every `emit(event, detail)`. */
export function on(event, fn) {
  if (!listeners.has(event)) listeners.set(event, []);
  listeners.get(event).push(fn);
}

export function emit(event, detail) {
  for (const fn of listeners.get(event) || []) fn(detail);
}
