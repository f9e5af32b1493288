// Talking to the agent: the API key on every /v1/ request, error bodies, and the solve itself
// (POST /v1/solve as an event stream, sent with XMLHttpRequest: fetch cannot report upload progress).
import { $ } from "/web/dom.js";

// Kept in sessionStorage (this tab only, gone when it closes) and sent on every /v1/ request.
const KEY_STORAGE = "pyspatial-api-key";

export function apiKey() {
  return $("api-key").value.trim();
}

export function restoreApiKey(onChange) {
  const input = $("api-key");
  input.value = sessionStorage.getItem(KEY_STORAGE) || "";
  input.addEventListener("input", () => {
    if (apiKey()) sessionStorage.setItem(KEY_STORAGE, apiKey());
    else sessionStorage.removeItem(KEY_STORAGE);
  });
  input.addEventListener("change", onChange); // e.g. the backbone menu, refused without the key
}

export function apiFetch(url, options = {}) {
  const headers = new Headers(options.headers || {});
  if (apiKey()) headers.set("Authorization", `Bearer ${apiKey()}`);
  return fetch(url, { ...options, headers });
}

// The service's {"detail": "..."} body, or the text, or the status.
export function detailOf(text, status) {
  try {
    const detail = JSON.parse(text).detail;
    return typeof detail === "string" ? detail : JSON.stringify(detail);
  } catch {
    return text || `HTTP ${status}`;
  }
}

// A failed response as {status, detail, retryAfter} (what messages.js explains).
export async function problemOf(response) {
  return { status: response.status, detail: detailOf(await response.text(), response.status),
    retryAfter: response.headers.get("Retry-After") };
}

// Server-Sent Events out of a growing text: complete events, and what is left over.
function splitEvents(buffer) {
  const events = [];
  let end;
  while ((end = buffer.indexOf("\n\n")) >= 0) {
    const block = buffer.slice(0, end);
    buffer = buffer.slice(end + 2);
    const data = block.split("\n").filter((l) => l.startsWith("data:")).map((l) => l.slice(5).trim()).join("\n");
    if (data) events.push(JSON.parse(data));
  }
  return { events, rest: buffer };
}

// POST the form to /v1/solve as an event stream. Calls onUpload(sent, total) while the photos go
// up and onEvent(event) for each stage/result/error event. Resolves with {outcome}: "ended" (the
// stream finished), "refused" (a plain error response: {problem}), "aborted", or "unreachable".
export function postSolve(form, { onUpload, onEvent }) {
  const xhr = new XMLHttpRequest();
  const done = new Promise((resolve) => {
    let seen = 0;
    let buffer = "";
    const readMore = () => {
      if (xhr.status !== 200) return;
      buffer += xhr.responseText.slice(seen).replace(/\r\n/g, "\n");
      seen = xhr.responseText.length;
      const { events, rest } = splitEvents(buffer);
      buffer = rest;
      events.forEach(onEvent);
    };
    let total = 0;
    xhr.upload.addEventListener("progress", (e) => {
      total = e.lengthComputable ? e.total : 0;
      onUpload(e.loaded, total);
    });
    xhr.upload.addEventListener("load", () => onUpload(total, total));
    xhr.addEventListener("progress", readMore);
    xhr.addEventListener("load", () => {
      if (xhr.status === 200) {
        readMore();
        resolve({ outcome: "ended" });
      } else {
        resolve({ outcome: "refused", problem: { status: xhr.status,
          detail: detailOf(xhr.responseText, xhr.status), retryAfter: xhr.getResponseHeader("Retry-After") } });
      }
    });
    xhr.addEventListener("abort", () => resolve({ outcome: "aborted" }));
    xhr.addEventListener("error", () => resolve({ outcome: "unreachable" }));
  });
  xhr.open("POST", "/v1/solve");
  xhr.setRequestHeader("Accept", "text/event-stream");
  if (apiKey()) xhr.setRequestHeader("Authorization", `Bearer ${apiKey()}`);
  xhr.send(form);
  return { done, abort: () => xhr.abort() };
}
