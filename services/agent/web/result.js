// The result of a solve: the answer (a letter, or words for a free-form question, marked as such),
// what did not go as planned, the photos, the program and its attempts, the clue, the timings.
import { $, element } from "/web/dom.js";
import { photos } from "/web/photos.js";

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

export function poseText(extrinsic) {
  if (!extrinsic) return "pose unknown";
  const rows = extrinsic.map((row) => row.map((v) => v.toFixed(3).padStart(7)).join(" "));
  const centre = [0, 1, 2].map((j) => -extrinsic.reduce((sum, row) => sum + row[j] * row[3], 0));
  return `camera centre (${centre.map((v) => v.toFixed(2)).join(", ")})\ncamera-from-world [R|t]:\n${rows.join("\n")}`;
}

export function imageSrc(base64) {
  return `data:image/png;base64,${base64}`;
}

// How the question was read (views, quantity, frame), and why that reading allows no answer, if so.
function readingText(reading) {
  if (!reading || !reading.summary) return "";
  return reading.abstain_reason ? `${reading.summary}. In doubt: ${reading.abstain_reason}` : reading.summary;
}

function showAnswer(result) {
  const answer = $("answer");
  const freeForm = result.answer_format === "free_form";
  answer.className = result.answer ? "answer" : "answer none";
  answer.dataset.format = result.answer_format || "choice";
  if (!result.answer) {
    answer.replaceChildren(`No answer: ${result.answer_reason || "unknown reason"}`);
  } else if (freeForm) {
    answer.replaceChildren(`Answer: ${result.answer}`, " ",
      element("span", { className: "badge", textContent: "free-form answer",
        title: "The question has no lettered options, so it was answered in words." }));
  } else {
    answer.replaceChildren(`Answer: ${result.answer}`);
  }
  $("question-reading").textContent = readingText(result.reading);
  $("reasoning").textContent = result.reasoning || "";
  $("warnings").replaceChildren(...fallbackNotes(result).map((text) => element("li", { className: "fallback", textContent: text })));
}

function highlighted(code) {
  delete code.dataset.highlighted;
  if (window.hljs) window.hljs.highlightElement(code);
  return code;
}

function showProgram(result) {
  const code = $("program");
  code.textContent = result.program || "# no program ran successfully";
  highlighted(code);
  const attempts = result.attempts.length > 1 || result.attempts.some((a) => a.error) ? result.attempts : [];
  $("attempts").replaceChildren(...attempts.map((attempt, i) => {
    // Focusable: a scrolling block must be reachable with the keyboard.
    const pre = element("pre", { tabIndex: 0, ariaLabel: `Attempt ${i + 1}'s program` }, highlighted(element("code", { className: "language-python",
      textContent: attempt.program || "(no program in the reply)" })));
    return element("details", { className: "attempt", open: Boolean(attempt.error) && i === attempts.length - 1 },
      element("summary", { textContent: `Attempt ${i + 1}: ${attempt.error ? "failed" : "ran"}` }),
      attempt.error ? element("p", { className: "attempt-error", textContent: attempt.error }) : null, pre);
  }));
}

// The clue's views, each {png, source, input_view (1-based), extrinsic, width, height, index}.
function showClue(result) {
  $("clue-text").textContent = result.clue.text || "";
  const views = result.clue.images.map((png, i) => ({ png, ...(result.clue.views[i] || {}), index: i }));
  $("clue-images").replaceChildren(...views.map((view) => {
    const label = view.source === "input" ? `clue image ${view.index + 1}: input image ${view.input_view}`
      : `clue image ${view.index + 1}: rendered view v${view.index + 1}`;
    return element("li", {}, element("img", { src: imageSrc(view.png), alt: label }),
      element("div", { textContent: label }),
      element("div", { className: "pose", tabIndex: 0, ariaLabel: `${label}: pose`, textContent: poseText(view.extrinsic) }));
  }));
  $("notes").replaceChildren(...result.clue.notes.map((note) => element("li", { textContent: note })));
  return views;
}

function showTimings(result, renderedCount) {
  const t = result.timings;
  const rows = [["reconstruction", t.reconstruction_ms], ["program writing", t.codegen_ms],
    ["execution", t.execution_ms], ["answering", t.answering_ms], ["total", t.total_ms]];
  $("timings").tBodies[0].replaceChildren(...rows.map(([name, ms]) => element("tr", {},
    element("th", { scope: "row", textContent: name }), element("td", { textContent: `${(ms / 1000).toFixed(2)} s` }))));
  const method = result.answer_method ? ` (${result.answer_method})` : "";
  $("models").textContent = `scene ${result.scene_id} · backbone ${result.backbone} · program by ${result.code_model} · answer by ${result.answer_model}${method} · ${renderedCount} rendered views`;
}

// Shows everything but the 3D view; returns the clue's views (scene.js draws the rendered ones).
export function showResult(result) {
  $("result").hidden = false;
  showAnswer(result);
  $("inputs").replaceChildren(...photos.files.map((file, i) => element("li", {},
    element("img", { src: photos.urls[i], alt: `image ${i + 1}` }), element("div", { textContent: `image ${i + 1} — ${file.name}` }))));
  showProgram(result);
  const views = showClue(result);
  showTimings(result, views.filter((v) => v.source === "rendered").length);
  $("result").focus();
  return views;
}
