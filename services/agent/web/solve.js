// The solve mode: the form's photos and question go to POST /v1/solve as an event stream; the
// progress follows its events; Cancel aborts the request (the agent then stops the solve's work);
// the result and its 3D view follow. Another mode of the page would be a module like this one,
// mounted by app.js, reusing api.js, messages.js, progress.js, result.js and scene.js.
import { $ } from "/web/dom.js";
import { postSolve } from "/web/api.js";
import { clearProblem, showHint, showProblem } from "/web/messages.js";
import { photos, withFileNames } from "/web/photos.js";
import { runningStage, setStage, showUpload, startProgress, stopProgress } from "/web/progress.js";
import { showResult } from "/web/result.js";
import { showScene } from "/web/scene.js";

let current = null; // the request in flight: {abort}

function formOf(question) {
  const form = new FormData();
  photos.files.forEach((file) => form.append("images", file, file.name));
  form.append("question", question);
  if ($("backbone").value) form.append("backbone", $("backbone").value);
  return form;
}

function setBusy(busy) {
  $("solve").disabled = busy;
  $("cancel").hidden = !busy;
  $("solve-form").setAttribute("aria-busy", String(busy));
}

// One event of the stream; returns the final outcome ("result" or "error") when it is the last one.
function onEvent(item, ending) {
  if (item.type === "stage") {
    // A failed stage that ends the solve is told once, in the error message (not here as well).
    setStage(item.stage, item.state, `${item.detail} (${(item.elapsed_ms / 1000).toFixed(1)} s)`);
  } else if (item.type === "error") {
    ending.outcome = "error";
    setStage(item.stage || runningStage(), "failed");
    showProblem({ status: item.status_code, detail: item.detail, stage: item.stage }, withFileNames);
  } else if (item.type === "result") {
    ending.outcome = "result";
    ending.result = item.result;
  }
}

async function solve(event) {
  event.preventDefault();
  clearProblem();
  const question = $("question").value.trim();
  if (!photos.files.length) return showHint("Choose at least one photo (drop or paste them, or load an example).");
  if (!question) return showHint("Type the question (with its options A. … B. … for a multiple-choice answer).");
  $("empty").hidden = true;
  $("result").hidden = true;
  startProgress(photos.files.length);
  $("progress-block").scrollIntoView({ block: "nearest" });
  setBusy(true);
  const ending = { outcome: null, result: null };
  current = postSolve(formOf(question), { onUpload: showUpload, onEvent: (item) => onEvent(item, ending) });
  const { outcome, problem } = await current.done;
  current = null;
  setBusy(false);
  if (outcome === "aborted") {
    setStage(runningStage(), "cancelled", "cancelled");
    return stopProgress("cancelled");
  }
  if (outcome === "unreachable" || outcome === "refused") {
    setStage(runningStage(), "failed");
    stopProgress("failed");
    return showProblem(problem || { status: 0, detail: "" }, withFileNames);
  }
  if (ending.outcome === "result") {
    stopProgress("done");
    const views = showResult(ending.result);
    return showScene(ending.result, views);
  }
  stopProgress("failed");
  if (ending.outcome !== "error") {
    showProblem({ status: 500, detail: "The connection closed before the answer came" });
  }
}

export function mountSolveMode() {
  $("solve-form").addEventListener("submit", solve);
  $("cancel").addEventListener("click", () => current && current.abort());
}
