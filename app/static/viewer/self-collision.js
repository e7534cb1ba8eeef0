// Self-collision as the joints move: after every drawn configuration, POST /models/{id}/collision
// with its q (debounced, one request in flight, the latest configuration wins), the links of the
// colliding pairs drawn red and a status line "self-collision: none" / "links a–b, ...".
// (A module of the model viewer; viewer.js is the entry point.)

import { api } from "./api.js";
import { $, state } from "./config.js";

export const COLLISION_DEBOUNCE_MS = 60;

let timer = null;
let inFlight = false;
let queued = null;        // {id, q, token, paint} waiting to be sent
let seq = 0;              // answers to an older configuration than the latest asked are dropped

/** A fresh status for a newly loaded model. */
export function resetCollision() {
  clearTimeout(timer);
  timer = null;
  queued = null;
  seq += 1;
  state.collision = { requests: 0, responses: 0, q: null, pairs: [], links: [], status: "", unavailable: null };
  const el = $("collision-status");
  if (el) el.textContent = "";
}
resetCollision();

/** Check configuration `q` of model `id` soon; `paint(linkNames)` colours the colliding links,
 * `isCurrent()` false drops an answer for a model no longer shown. */
export function requestCollision(id, q, paint, isCurrent) {
  if (state.collision.unavailable) return;
  queued = { id, q: q.slice(), paint, isCurrent, seq: ++seq };
  clearTimeout(timer);
  timer = setTimeout(send, COLLISION_DEBOUNCE_MS);
}

async function send() {
  timer = null;
  if (inFlight || !queued) return;
  const job = queued;
  queued = null;
  inFlight = true;
  state.collision.requests += 1;
  if (!state.collision.status) status("self-collision: checking…");
  try {
    const answer = await api(`/models/${encodeURIComponent(job.id)}/collision`, { method: "POST", body: { q: job.q } });
    if (!job.isCurrent()) return;
    state.collision.responses += 1;
    if (job.seq !== seq) return;        // a newer configuration is on its way
    const pairs = answer.pairs || [];
    const links = [...new Set(pairs.flat())];
    Object.assign(state.collision, { q: job.q, pairs, links });
    job.paint(links);
    if (!(answer.links || []).length) status("self-collision: the model has no collision geometry");
    else status(pairs.length ? `self-collision: ${pairs.map(([a, b]) => `links ${a}–${b}`).join(", ")}` : "self-collision: none");
  } catch (err) {
    if (!job.isCurrent()) return;
    // e.g. the collision extra is not installed: say it once, and stop asking for this model
    state.collision.unavailable = err.message;
    job.paint([]);
    status(`self-collision: unavailable (${err.message})`);
  } finally {
    inFlight = false;
    if (queued) send();
  }
}

function status(text) {
  state.collision.status = text;
  const el = $("collision-status");
  if (el) {
    el.textContent = text;
    el.classList.toggle("warn", text.includes("links "));
  }
}
