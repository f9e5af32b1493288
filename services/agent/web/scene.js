// The 3D view of a result and its controls: hide the least confident points, point size, show or
// hide the cameras and the rendered clue views, reset, fullscreen, and the reconstruction's download.
import { $, element, megabytes } from "/web/dom.js";
import { apiFetch, problemOf } from "/web/api.js";
import { poseText, imageSrc } from "/web/result.js";
import { photos, withFileNames } from "/web/photos.js";
import { SceneViewer, webglAvailable } from "/web/viewer.js";

export const PREVIEW_POINTS = 30000;
const shown = { viewer: null, views: [], result: null };

function pick({ kind, index }) {
  const img = $("picked-img");
  if (kind === "input") {
    img.src = photos.urls[index];
    img.alt = `image ${index + 1}`;
    $("picked-caption").textContent = `image ${index + 1}: ${photos.files[index].name}`;
  } else {
    const view = shown.views[index];
    img.src = imageSrc(view.png);
    img.alt = `rendered view v${index + 1}`;
    $("picked-caption").textContent = `rendered view v${index + 1} (clue image ${index + 1})\n${poseText(view.extrinsic)}`;
  }
  $("picked").hidden = false;
  document.querySelectorAll("#camera-buttons button").forEach((button) => {
    button.setAttribute("aria-pressed", String(button.dataset.kind === kind && button.dataset.index === String(index)));
  });
}

function confidenceLabel(cut, hidden) {
  if (!shown.viewer?.hasConfidence) return "no per-point confidence in this reconstruction";
  if (!hidden) return "all points shown";
  return `${hidden}% hidden (confidence below ${cut.toPrecision(3)})`;
}

function applyControls() {
  const viewer = shown.viewer;
  if (!viewer) return;
  const hidden = Number($("confidence").value);
  const cut = viewer.setHiddenFraction(hidden / 100);
  $("confidence-value").textContent = confidenceLabel(cut, hidden);
  const scale = Number($("point-size").value);
  viewer.setPointScale(scale);
  $("point-size-value").textContent = `${scale}×`;
  viewer.setVisible("input", $("show-cameras").checked);
  viewer.setVisible("rendered", $("show-clue-views").checked);
  $("viewer-counts").textContent = `${viewer.drawnPoints} of ${viewer.totalPoints} points drawn`;
}

async function download(format) {
  const { result } = shown;
  const status = $("download-status");
  status.textContent = `preparing the ${format.toUpperCase()} …`;
  const query = new URLSearchParams({ format, backbone: result.backbone });
  const response = await apiFetch(`/v1/scenes/${encodeURIComponent(result.scene_id)}/reconstruction?${query}`);
  if (!response.ok) {
    status.textContent = `The download failed: ${(await problemOf(response)).detail}`;
    return;
  }
  // The file goes through a blob: a link cannot carry the API key's Authorization header.
  const blob = await response.blob();
  const url = URL.createObjectURL(blob);
  const link = element("a", { href: url, download: `${result.scene_id}.${format}`, hidden: true });
  document.body.append(link);
  link.click();
  link.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
  status.textContent = `Downloaded ${result.scene_id}.${format} (${megabytes(blob.size)}).`;
}

function toggleFullscreen() {
  if (document.fullscreenElement) document.exitFullscreen();
  else $("viewer-wrap").requestFullscreen().catch(() => {
    $("viewer-status").textContent = "This browser refused fullscreen.";
  });
}

export function mountSceneControls() {
  ["confidence", "point-size", "show-cameras", "show-clue-views"].forEach((id) => $(id).addEventListener("input", applyControls));
  $("reset-view").addEventListener("click", () => shown.viewer && shown.viewer.resetView());
  $("fullscreen").addEventListener("click", toggleFullscreen);
  document.addEventListener("fullscreenchange", () => {
    $("fullscreen").textContent = document.fullscreenElement ? "Exit fullscreen" : "Fullscreen";
    $("fullscreen").setAttribute("aria-pressed", String(Boolean(document.fullscreenElement)));
  });
  $("download-ply").addEventListener("click", () => download("ply"));
  $("download-glb").addEventListener("click", () => download("glb"));
}

export async function showScene(result, views) {
  Object.assign(shown, { result, views });
  const status = $("viewer-status");
  if (!webglAvailable()) {
    status.textContent = "This browser has no WebGL, so the 3D view is off; everything else is shown.";
    return;
  }
  status.textContent = "loading the points …";
  const query = new URLSearchParams({ max_points: String(PREVIEW_POINTS), backbone: result.backbone });
  const response = await apiFetch(`/v1/scenes/${encodeURIComponent(result.scene_id)}/points?${query}`);
  if (!response.ok) {
    status.textContent = `The 3D view could not be loaded: ${(await problemOf(response)).detail}`;
    return;
  }
  const preview = await response.json();
  const unplaced = preview.cameras.filter((c) => !c.registered).map((c) => c.view);
  $("warnings").append(...unplaced.map((n) => element("li", {
    textContent: `${withFileNames(`image ${n}`)} could not be placed in the reconstruction, so it has no camera in the 3D view.`,
  })));
  if (!shown.viewer) shown.viewer = new SceneViewer($("viewer"), pick);
  const renderedViews = views.filter((v) => v.source === "rendered" && v.extrinsic);
  shown.viewer.show(preview, renderedViews);
  $("confidence").disabled = !shown.viewer.hasConfidence;
  applyControls();
  status.textContent = `${preview.num_points} of ${preview.num_points_total} points · drag to orbit, right-drag to pan, wheel to zoom; keys: arrows, shift+arrows, + / -, Home.`;
  const buttons = [
    ...preview.cameras.filter((c) => c.registered).map((c) => ({ kind: "input", index: c.view - 1, label: `image ${c.view}` })),
    ...renderedViews.map((v) => ({ kind: "rendered", index: v.index, label: `view v${v.index + 1}` })),
  ];
  $("camera-buttons").replaceChildren(...buttons.map((b) => element("button", {
    type: "button", className: b.kind, textContent: b.label, dataset: { kind: b.kind, index: String(b.index) },
    onclick: () => pick(b),
  })));
  $("picked").hidden = true;
}
