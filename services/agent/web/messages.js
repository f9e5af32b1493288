// The page's one error message: in one place (#error, above the progress), in plain words, with
// what to do next. Every failure (a refused request, an error event, no connection) comes here.
import { $, element } from "/web/dom.js";
import { apiKey } from "/web/api.js";

const RETRY = (seconds) => (seconds ? `in ${seconds} s` : "in a moment");

// What to do next, by HTTP status (and by the stage that failed where it matters).
function nextStep({ status, stage, retryAfter }) {
  if (status === 0) return "Check that the agent service is running (pyspatial serve all), then press Solve again.";
  if (status === 400) return "Replace that file with a photo (JPEG, PNG or WebP) and press Solve again.";
  if (status === 401) return "Enter the agent's API key in the API key field, then press Solve again.";
  if (status === 404) return "Choose the photos again (the scene is no longer stored) and press Solve.";
  if (status === 413) return "Send fewer or smaller photos.";
  if (status === 422 && stage === "reconstruction") {
    return "Try photos that overlap more (or more of them), or another reconstruction backbone.";
  }
  if (status === 422) return "Change the question or the photos, then press Solve again.";
  if (status === 429) return `Too many requests with this key: press Solve again ${RETRY(retryAfter)}.`;
  if (status === 503) return `The service is busy or not ready: press Solve again ${RETRY(retryAfter)}.`;
  if (status === 504) return "Press Solve again, or send fewer photos: a service took too long.";
  return "Press Solve again; if it keeps failing, tell whoever runs this agent (its log has the details).";
}

// The problem in words: the service's own message (with file names), or what a person can act on.
function describe({ status, detail }, withFileNames) {
  if (status === 0) return "Cannot reach the agent service.";
  if (status === 401) {
    return apiKey() ? `The agent refused this API key (${detail.split(":")[0]}).` : "This agent needs an API key.";
  }
  if (status === 429) return "Too many requests with this key.";
  return withFileNames(detail).replace(/\s*$/, "").replace(/([^.!?])$/, "$1.");
}

export function showProblem(problem, withFileNames = (text) => text) {
  const box = $("error");
  box.replaceChildren(element("p", { className: "what", textContent: describe(problem, withFileNames) }),
    element("p", { className: "next" }, element("strong", { textContent: "What to do: " }), nextStep(problem)));
  box.hidden = false;
  box.scrollIntoView({ block: "nearest" });
}

// A check of the form itself (no photo, no question): the same box, the fix is the message.
export function showHint(message) {
  const box = $("error");
  box.replaceChildren(element("p", { className: "what", textContent: message }));
  box.hidden = false;
  box.scrollIntoView({ block: "nearest" });
}

export function clearProblem() {
  $("error").hidden = true;
  $("error").replaceChildren();
}
