// Requests to the service and the error banner.
// (A module of the model viewer; viewer.js is the entry point.)

import { $, API_KEY_STORAGE, ROOT, state } from "./config.js";

// ---------------------------------------------------------------------------- API
export class ApiError extends Error {
  constructor(message, status = null, type = null) {
    super(message);
    this.status = status;   // HTTP status of a problem answer
    this.type = type;       // its problem type (urn:kinematics:problem:<slug>)
  }
}

/** `body`: sent as JSON; `raw` with `contentType`: sent as it is (e.g. a CSV text). */
export async function api(path, { method = "GET", body, raw, contentType = "text/plain", text = false, binary = null } = {}) {
  const init = { method, headers: {} };
  if (binary) init.headers.Accept = binary;
  const key = sessionStorage.getItem(API_KEY_STORAGE);
  if (key) init.headers["X-API-Key"] = key;
  if (body !== undefined) {
    init.headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(body);
  } else if (raw !== undefined) {
    init.headers["Content-Type"] = contentType;
    init.body = raw;
  }
  let response;
  try {
    response = await fetch(ROOT + path, init);
  } catch (err) {
    throw new ApiError(`${method} ${path}: the service cannot be reached (${err.message})`);
  }
  if (!response.ok) {
    let detail = `${response.status} ${response.statusText}`;
    let type = null;
    try {
      const problem = await response.json();
      if (problem && typeof problem.type === "string") type = problem.type;
      if (problem && problem.detail !== undefined) {
        detail = typeof problem.detail === "string" ? problem.detail : JSON.stringify(problem.detail);
      } else if (problem && problem.title) {
        detail = problem.title;
      }
    } catch (_) { /* not JSON: keep the status line */ }
    throw new ApiError(`${method} ${path}: ${detail}`, response.status, type);
  }
  if (binary) return response.arrayBuffer();
  return text ? response.text() : response.json();
}

export function showError(err) {
  const message = err instanceof Error ? err.message : String(err);
  state.lastError = message;
  $("error-text").textContent = message;
  $("error").hidden = false;
  console.warn(message);
}

export function clearError() {
  $("error").hidden = true;
  state.lastError = null;
}
