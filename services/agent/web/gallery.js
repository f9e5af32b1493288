// The bundled examples (GET /v1/examples): synthetic rooms and real photos, each with questions.
// One click on a question loads its photos and puts the question in the form.
import { $, element } from "/web/dom.js";
import { apiFetch, problemOf } from "/web/api.js";
import { clearProblem, showProblem } from "/web/messages.js";
import { setFiles } from "/web/photos.js";

async function filesOf(example) {
  return Promise.all(example.images.map(async (url) => {
    const response = await apiFetch(url);
    if (!response.ok) throw await problemOf(response);
    const blob = await response.blob();
    return new File([blob], url.split("/").pop(), { type: blob.type });
  }));
}

async function load(example, question) {
  clearProblem();
  const status = $("gallery-status");
  status.textContent = `loading ${example.title} …`;
  try {
    setFiles(await filesOf(example));
    $("question").value = question.text;
    status.textContent = `Loaded ${example.title}: ${example.images.length} photos and the question. Press Solve.`;
    $("question").focus();
  } catch (problem) {
    status.textContent = "";
    showProblem(problem.status ? problem : { status: 0, detail: String(problem) });
  }
}

function card(example) {
  const questions = element("ul", { className: "example-questions" }, ...example.questions.map((question) =>
    element("li", {}, element("button", {
      type: "button", className: "secondary small question-button", textContent: question.text,
      onclick: () => load(example, question),
    }), question.free_form ? element("span", { className: "badge", textContent: "free-form" }) : null)));
  return element("li", { className: "example", dataset: { example: example.name } },
    element("img", { src: example.thumbnail, alt: "", width: 96, height: 72 }),
    element("div", {},
      element("h3", { textContent: example.title }),
      element("p", { className: "muted", textContent: example.description }),
      example.citation ? element("p", { className: "muted citation", textContent: example.citation }) : null,
      questions));
}

export async function mountGallery() {
  const list = $("gallery");
  try {
    const response = await apiFetch("/v1/examples");
    if (!response.ok) {
      const problem = await problemOf(response);
      $("gallery-status").textContent = response.status === 401 ? "Enter the API key to see the examples."
        : `No examples: ${problem.detail}`;
      return;
    }
    const { examples } = await response.json();
    list.replaceChildren(...examples.map(card));
    $("gallery-status").textContent = examples.length ? "" : "This installation has no bundled examples.";
  } catch {
    $("gallery-status").textContent = "The examples could not be loaded.";
  }
}
