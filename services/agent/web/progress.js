// The solve's progress as people watch it: the five stages ticking off, a clock that ticks every
// second with the stage that is running beside it, and the upload's percentage.
import { $, duration, megabytes } from "/web/dom.js";

export const STAGES = ["upload", "reconstruction", "program", "execution", "answer"];
const NAMES = { upload: "Upload", reconstruction: "Reconstruction", program: "Program", execution: "Execution",
  answer: "Answer" };

let timer = null;
let startedAt = 0;
let running = "upload";

export function setStage(stage, state, detail = "") {
  const item = document.querySelector(`#progress li[data-stage="${stage}"]`);
  if (!item) return;
  item.dataset.state = state;
  item.querySelector(".detail").textContent = detail ? `— ${detail}` : "";
  if (state === "started") {
    running = stage;
    $("clock-stage").textContent = `${NAMES[stage]}: ${detail}`;
  }
}

export function runningStage() {
  return running;
}

function tick() {
  $("clock-time").textContent = duration((performance.now() - startedAt) / 1000);
}

export function startProgress(photoCount) {
  STAGES.forEach((stage) => setStage(stage, "pending"));
  $("progress-block").hidden = false;
  $("clock").dataset.state = "running";
  startedAt = performance.now();
  tick();
  clearInterval(timer);
  timer = setInterval(tick, 1000);
  showUpload(0, 0);
  setStage("upload", "started", `sending ${photoCount} photo${photoCount === 1 ? "" : "s"}`);
}

// `how`: "done", "failed" or "cancelled": the clock stops and says so.
export function stopProgress(how) {
  clearInterval(timer);
  timer = null;
  tick();
  $("clock").dataset.state = how;
  const words = { done: "Finished", failed: "Stopped by an error", cancelled: "Cancelled" }[how];
  $("clock-stage").textContent = how === "done" ? words : `${words} during ${NAMES[running].toLowerCase()}`;
}

export function showUpload(sent, total) {
  const percent = total ? Math.min(100, Math.round((100 * sent) / total)) : 0;
  $("upload-bar").value = percent;
  $("upload-percent").textContent = total ? `${percent}% of ${megabytes(total)}` : "0%";
  $("upload-progress").dataset.percent = String(percent);
}
