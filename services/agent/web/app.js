// The page: pick photos, ask, follow the solve's stages (POST /v1/solve as an event stream),
// then show the answer, the program, the clue and the 3D scene.
import { SceneViewer, webglAvailable } from "/web/viewer.js";

const $ = (id) => document.getElementById(id);
const STAGES = ["upload", "reconstruction", "program", "execution", "answer"];
const state = { files: [], urls: [], clueUrls: [], viewer: null, views: [] };

function element(tag, props = {}, ...children) {
  const node = Object.assign(document.createElement(tag), props);
  node.append(...children.filter((c) => c !== null && c !== undefined));
  return node;
}

// "image 2 is not ..." from the service becomes "image 2 (name.jpg) is not ...".
function withFileNames(message) {
  return message.replace(/\bimage (\d+)\b/g, (text, n) => {
    const file = state.files[Number(n) - 1];
    return file ? `${text} (${file.name})` : text;
  });
}

// ---- the API key ----------------------------------------------------------------------------
// Kept in sessionStorage (this tab only, gone when it closes) and sent on every /v1/ request.
const KEY_STORAGE = "pyspatial-api-key";

function apiKey() {
  return $("api-key").value.trim();
}

function apiFetch(url, options = {}) {
  const headers = new Headers(options.headers || {});
  if (apiKey()) headers.set("Authorization", `Bearer ${apiKey()}`);
  return fetch(url, { ...options, headers });
}

// A refused or rate-limited request as a person can act on it; other errors keep the service's words.
async function responseProblem(response) {
  const detail = await errorDetail(response);
  if (response.status === 401) {
    return apiKey() ? `The agent refused this API key (${detail.split(":")[0]}): enter the right one above.`
      : "This agent needs an API key: enter it above.";
  }
  if (response.status === 429) {
    const wait = response.headers.get("Retry-After");
    return `Too many requests with this key: retry in ${wait ? `${wait} s` : "a moment"}.`;
  }
  return withFileNames(detail);
}

function showError(message) {
  const box = $("error");
  box.textContent = message;
  box.hidden = !message;
  if (message) box.scrollIntoView({ block: "nearest" });
}

// ---- choosing photos ------------------------------------------------------------------------

function setFiles(files) {
  state.urls.forEach((url) => URL.revokeObjectURL(url));
  state.files = files;
  state.urls = files.map((file) => URL.createObjectURL(file));
  $("thumbs").replaceChildren(...files.map((file, i) => element("li", {},
    element("img", { src: state.urls[i], alt: `image ${i + 1}: ${file.name}` }),
    element("div", { textContent: `image ${i + 1}` }))));
}

function sortedByName(files) {
  return [...files].sort((a, b) => a.name.localeCompare(b.name, undefined, { numeric: true }));
}

async function useExample() {
  showError("");
  try {
    const response = await apiFetch("/v1/example");
    if (!response.ok) throw new Error(await responseProblem(response));
    const example = await response.json();
    const files = await Promise.all(example.images.map(async (url) => {
      const image = await apiFetch(url);
      if (!image.ok) throw new Error(await responseProblem(image));
      const blob = await image.blob();
      return new File([blob], url.split("/").pop(), { type: blob.type });
    }));
    setFiles(files);
    $("question").value = example.question;
  } catch (error) {
    showError(`Could not load the bundled example: ${error.message}`);
  }
}

async function loadBackbones() {
  try {
    const response = await apiFetch("/v1/backbones");
    if (!response.ok) return;
    // Only what the service can run now: `available` leaves out backbones whose weights are absent.
    const { available, default: fallback, auto } = await response.json();
    const label = (name) => (name === "auto" && auto ? `auto (${auto})` : name);
    const select = $("backbone");
    select.replaceChildren(element("option", { value: "", textContent: `service default (${label(fallback)})` }),
      ...available.map((name) => element("option", { value: name, textContent: label(name) })));
  } catch { /* the default stays selectable */ }
}

// ---- solving --------------------------------------------------------------------------------

async function errorDetail(response) {
  const text = await response.text();
  try {
    const detail = JSON.parse(text).detail;
    return typeof detail === "string" ? detail : JSON.stringify(detail);
  } catch {
    return text || `HTTP ${response.status}`;
  }
}

function setStage(stage, stateName, detail) {
  const item = document.querySelector(`#progress li[data-stage="${stage}"]`);
  if (!item) return;
  item.dataset.state = stateName;
  item.querySelector(".detail").textContent = detail ? `— ${detail}` : "";
}

// Server-Sent Events over a POST body: read the stream, split events on blank lines.
async function* readEvents(response) {
  const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
  let buffer = "";
  for (;;) {
    const { value, done } = await reader.read();
    if (done) return;
    buffer += value.replace(/\r\n/g, "\n");
    let end;
    while ((end = buffer.indexOf("\n\n")) >= 0) {
      const block = buffer.slice(0, end);
      buffer = buffer.slice(end + 2);
      const data = block.split("\n").filter((l) => l.startsWith("data:")).map((l) => l.slice(5).trim()).join("\n");
      if (data) yield JSON.parse(data);
    }
  }
}

async function solve(event) {
  event.preventDefault();
  showError("");
  const question = $("question").value.trim();
  if (!state.files.length) return showError("Choose at least one photo (or use the bundled example).");
  if (!question) return showError("Type the question, with its options (A. … B. …).");
  const form = new FormData();
  state.files.forEach((file) => form.append("images", file, file.name));
  form.append("question", question);
  if ($("backbone").value) form.append("backbone", $("backbone").value);
  STAGES.forEach((stage) => setStage(stage, "pending", ""));
  $("empty").hidden = true;
  $("progress-block").hidden = false;
  $("progress-block").scrollIntoView({ block: "nearest" });
  setStage("upload", "started", `sending ${state.files.length} photos`);
  $("solve").disabled = true;
  $("result").hidden = true;
  let running = "upload";
  try {
    const response = await apiFetch("/v1/solve", { method: "POST", body: form, headers: { Accept: "text/event-stream" } });
    if (!response.ok) {
      setStage(running, "failed", "");
      return showError(await responseProblem(response));
    }
    for await (const item of readEvents(response)) {
      if (item.type === "stage") {
        setStage(item.stage, item.state, `${item.detail} (${(item.elapsed_ms / 1000).toFixed(1)} s)`);
        running = item.stage;
      } else if (item.type === "error") {
        setStage(item.stage || running, "failed", "");
        return showError(`${withFileNames(item.detail)} (HTTP ${item.status_code})`);
      } else if (item.type === "result") {
        return await showResult(item.result);
      }
    }
    showError("The service closed the connection before the answer came. Is it still running?");
  } catch (error) {
    setStage(running, "failed", "");
    showError(`Cannot reach the agent service: ${error.message}`);
  } finally {
    $("solve").disabled = false;
  }
}

// ---- the result -----------------------------------------------------------------------------

// What did not go as planned, in words: the images-only answer, the planner standing in for the model.
function fallbackNotes(result) {
  const notes = [];
  if (result.fallback === "images_only") {
    notes.push(`No program ran, so the answer model answered from the photos alone: ${result.fallback_reason || "no reason given"}.`);
  }
  if (result.code_model_fallback) {
    notes.push(`The code model failed, so the offline planner wrote the program: ${result.code_model_fallback}.`);
  } else if (result.code_model.includes("fallback")) {
    notes.push(`The code model could not be reached, so the offline planner wrote the program (${result.code_model}).`);
  }
  return notes;
}

function poseText(extrinsic) {
  if (!extrinsic) return "pose unknown";
  const rows = extrinsic.map((row) => row.map((v) => v.toFixed(3).padStart(7)).join(" "));
  const centre = [0, 1, 2].map((j) => -extrinsic.reduce((sum, row) => sum + row[j] * row[3], 0));
  return `camera centre (${centre.map((v) => v.toFixed(2)).join(", ")})\ncamera-from-world [R|t]:\n${rows.join("\n")}`;
}

function imageSrc(base64) {
  return `data:image/png;base64,${base64}`;
}

async function showResult(result) {
  $("result").hidden = false;
  const answer = $("answer");
  answer.className = result.answer ? "answer" : "answer none";
  answer.textContent = result.answer ? `Answer: ${result.answer}` : `No answer: ${result.answer_reason || "unknown reason"}`;
  $("reasoning").textContent = result.reasoning || "";

  $("inputs").replaceChildren(...state.files.map((file, i) => element("li", {},
    element("img", { src: state.urls[i], alt: `image ${i + 1}` }), element("div", { textContent: `image ${i + 1} — ${file.name}` }))));

  const code = $("program");
  code.textContent = result.program || "# no program ran successfully";
  delete code.dataset.highlighted;
  if (window.hljs) window.hljs.highlightElement(code);
  const attempts = result.attempts.length > 1 || result.attempts.some((a) => a.error) ? result.attempts : [];
  $("attempts").replaceChildren(...attempts.map((attempt, i) => {
    const pre = element("pre", {}, element("code", { className: "language-python", textContent: attempt.program || "(no program in the reply)" }));
    if (window.hljs) window.hljs.highlightElement(pre.firstChild);
    return element("details", { className: "attempt", open: Boolean(attempt.error) && i === attempts.length - 1 },
      element("summary", { textContent: `Attempt ${i + 1}: ${attempt.error ? "failed" : "ran"}` }),
      attempt.error ? element("p", { className: "attempt-error", textContent: attempt.error }) : null, pre);
  }));

  $("clue-text").textContent = result.clue.text || "";
  state.views = result.clue.images.map((png, i) => ({ png, ...(result.clue.views[i] || {}), index: i }));
  let rendered = 0;
  $("clue-images").replaceChildren(...state.views.map((view) => {
    const label = view.source === "input" ? `clue image ${view.index + 1}: input image ${view.input_index + 1}`
      : `clue image ${view.index + 1}: rendered view v${view.index + 1}`;
    if (view.source === "rendered") rendered += 1;
    return element("li", {}, element("img", { src: imageSrc(view.png), alt: label }),
      element("div", { textContent: label }), element("div", { className: "pose", textContent: poseText(view.extrinsic) }));
  }));
  $("notes").replaceChildren(...result.clue.notes.map((note) => element("li", { textContent: note })));
  $("warnings").replaceChildren(...fallbackNotes(result).map((text) => element("li", { className: "fallback", textContent: text })));

  const t = result.timings;
  const rows = [["reconstruction", t.reconstruction_ms], ["program writing", t.codegen_ms],
    ["execution", t.execution_ms], ["answering", t.answering_ms], ["total", t.total_ms]];
  $("timings").tBodies[0].replaceChildren(...rows.map(([name, ms]) => element("tr", {},
    element("td", { textContent: name }), element("td", { textContent: `${(ms / 1000).toFixed(2)} s` }))));
  const method = result.answer_method ? ` (${result.answer_method})` : "";
  $("models").textContent = `scene ${result.scene_id} · backbone ${result.backbone} · program by ${result.code_model} · answer by ${result.answer_model}${method} · ${rendered} rendered views`;
  $("result").focus();
  await showScene(result);
}

async function showScene(result) {
  const status = $("viewer-status");
  const warnings = $("warnings");
  if (!webglAvailable()) {
    status.textContent = "This browser has no WebGL, so the 3D view is off; everything else is shown.";
    return;
  }
  status.textContent = "loading the points …";
  const query = new URLSearchParams({ max_points: "30000", backbone: result.backbone });
  const response = await apiFetch(`/v1/scenes/${encodeURIComponent(result.scene_id)}/points?${query}`);
  if (!response.ok) {
    status.textContent = `The 3D view could not be loaded: ${await responseProblem(response)}`;
    return;
  }
  const preview = await response.json();
  const unplaced = preview.cameras.filter((c) => !c.registered).map((c) => c.index + 1);
  warnings.append(...unplaced.map((n) => element("li", {
    textContent: `${withFileNames(`image ${n}`)} could not be placed in the reconstruction, so it has no camera in the 3D view.`,
  })));
  if (!state.viewer) state.viewer = new SceneViewer($("viewer"), pick);
  const renderedViews = state.views.filter((v) => v.source === "rendered" && v.extrinsic);
  state.viewer.show(preview, renderedViews);
  status.textContent = `${preview.num_points} of ${preview.num_points_total} points · drag to orbit, right-drag to pan, wheel to zoom; keys: arrows, shift+arrows, + / -, Home.`;
  const buttons = [
    ...preview.cameras.filter((c) => c.registered).map((c) => ({ kind: "input", index: c.index, label: `image ${c.index + 1}` })),
    ...renderedViews.map((v) => ({ kind: "rendered", index: v.index, label: `view v${v.index + 1}` })),
  ];
  $("camera-buttons").replaceChildren(...buttons.map((b) => element("button", {
    type: "button", className: b.kind, textContent: b.label, onclick: () => pick(b),
  })));
  $("picked").hidden = true;
}

function pick({ kind, index }) {
  const figure = $("picked");
  const img = $("picked-img");
  if (kind === "input") {
    img.src = state.urls[index];
    img.alt = `image ${index + 1}`;
    $("picked-caption").textContent = `image ${index + 1}: ${state.files[index].name}`;
  } else {
    const view = state.views[index];
    img.src = imageSrc(view.png);
    img.alt = `rendered view v${index + 1}`;
    $("picked-caption").textContent = `rendered view v${index + 1} (clue image ${index + 1})\n${poseText(view.extrinsic)}`;
  }
  figure.hidden = false;
  document.querySelectorAll("#camera-buttons button").forEach((button) => {
    button.setAttribute("aria-pressed", String(button.className === kind && button.textContent.endsWith(`${index + 1}`)));
  });
}

// ---- wiring ---------------------------------------------------------------------------------

$("images").addEventListener("change", (event) => setFiles(sortedByName(event.target.files)));
const drop = $("drop");
drop.addEventListener("dragover", (event) => { event.preventDefault(); drop.classList.add("over"); });
drop.addEventListener("dragleave", () => drop.classList.remove("over"));
drop.addEventListener("drop", (event) => {
  event.preventDefault();
  drop.classList.remove("over");
  setFiles(sortedByName(event.dataTransfer.files));
});
$("use-example").addEventListener("click", useExample);
$("solve-form").addEventListener("submit", solve);
$("reset-view").addEventListener("click", () => state.viewer && state.viewer.resetView());
const keyInput = $("api-key");
keyInput.value = sessionStorage.getItem(KEY_STORAGE) || "";
keyInput.addEventListener("input", () => {
  if (apiKey()) sessionStorage.setItem(KEY_STORAGE, apiKey());
  else sessionStorage.removeItem(KEY_STORAGE);
});
keyInput.addEventListener("change", loadBackbones);  // the menu may have been refused without the key
loadBackbones();
