// Constants of the viewer, its test hook `state` (window.viewerState) and `$`.
// (A module of the model viewer; viewer.js is the entry point.)




export const ROOT = document.body.dataset.root || "";
export const FK_LINKS_ALL = "all";
export const JACOBIAN_REFERENCE = "local_world_aligned";
export const SLIDER_STEPS = 10000;
export const VISUAL_OPACITY = 0.35;
export const TRIAD_FRACTION = 0.05;              // link triad length / model size
export const SELECTED_TRIAD_SCALE = 2.2;         // the selected link's triad is drawn this much larger
export const AXIS_ARROW_FRACTION = 0.1;          // joint axis arrow length / model size
export const DIGITS = 4;
export const API_KEY_STORAGE = "kinematics-api-key";  // sessionStorage: forgotten when the tab closes
export const IK_THROTTLE_MS = 100;               // while dragging: at most one IK request per this, one in flight
export const IK_DRAG_RESTARTS = 0;               // while dragging: follow from the current q only (smooth, fast)
export const IK_TARGET_OPACITY = 0.45;           // the target's ghost triad
export const GHOST_DEBOUNCE_MS = 150;           // every-solution request: this long after the target's last move (latest wins)
export const GHOST_MAX_DRAWN = 64;               // ghosts drawn at most (the list holds every solution)
export const GHOST_OPACITY = 0.3;                // a ghost arm; the one the robot is in is fainter
export const GHOST_COLORS = { free: 0x3b82f6, colliding: 0xd62728, unknown: 0x7c8aa5 };
export const SELF_MOTION_DEBOUNCE_MS = 120;      // a self-motion slider move: asked this long after it rests (one in flight)
export const SELF_MOTION_TRACK_STEP = 0.02;      // the robot follows its branch through slices this far apart (rad, m)
export const SELF_MOTION_MAX_SLICES = 64;        // ... and at most this many in one request
export const PATH_FRAME_MS = 40;                 // path playback: one row per this
export const FIT_DIRECTION = [1.0, -1.3, 0.8];   // the view direction (from the model) of a freshly loaded model
export const FIT_MARGIN = 1.15;                  // the bounding sphere fills 1 / FIT_MARGIN of the narrower field of view
export const CLOUD_POINT_FRACTION = 0.02;        // workspace point size / model size
export const CLOUD_COLOR_QUANTILE = 0.95;        // the colour scale tops out at this quantile of the manipulability
export const VELOCITY_ARROW_FRACTION = 0.33;     // the longest velocity arrow / model size

// Test hook (tests/app/test_viewer.py reads it); also handy from the browser console.
export const state = {
  ready: false,
  modelId: null,
  fkRequests: 0,
  fkResponses: 0,
  jacobianRequests: 0,
  selectedLink: null,
  lastQ: null,        // q (joint_names order) of the poses drawn
  lastPose: null,
  lastError: null,
  dhBuilt: null,
  dhBuilds: 0,
  renders: 0,
  fits: 0,
  workspace: null,    // {link, samples, points, maxManipulability}
  wsRequests: 0,
  wsResponses: 0,
  velocityRequests: 0,
  velocityResponses: 0,
  velocityArrows: 0,  // arrows drawn (links whose origin moves)
  lastVelocity: null, // {q, qdot, linear: {link: [vx, vy, vz]}}
  ikEnabled: false,
  ikRequests: 0,
  ikResponses: 0,
  ikBusy: false,      // a request in flight, or a target change not sent yet
  ikLast: null,       // {link, mode, target, seed, q, success, position_error, rotation_error, iterations}
  ikStatus: "",
  ghosts: null,       // {count, drawn, family, limits, solutions: [{q, within_limits, singular, colliding}], chosen}
  ghostRequests: 0,
  ghostResponses: 0,
  ghostBusy: false,
  selfMotion: null,   // {link, joint, lower, upper, value, count, chosen, intervals, target, q, track}
  selfMotionRequests: 0,
  selfMotionResponses: 0,
  selfMotionBusy: false,
  path: null,         // {rows, targets, row, playing, complete, fraction, stopped, waypoints}
  pathRequests: 0,
  pathResponses: 0,
  trajectory: null,   // {duration, method, samples, sample, t, playing, waypoints, limits, velocityRatio, accelerationRatio}
  trajectoryRequests: 0,
  trajectoryResponses: 0,
  calibration: null,  // {model, measurements, bars, rmse_before, rmse_after, holdout, outliers}
  calRequests: 0,
  calResponses: 0,
  cfRequests: 0,
  cfResponses: 0,
  closedForm: null,   // {tip, ok, katex (elements typeset), items, status}
  dhClosed: null,     // {ok, parameters, katex, status}
};
window.viewerState = state;

export const $ = (id) => document.getElementById(id);
