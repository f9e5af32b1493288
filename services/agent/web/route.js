// The route mode: click a point on one of the chosen photos to set the goal, then POST /v1/route
// plans turns and forward moves from the floor below the start view's camera to it. The steps are
// listed, the path is drawn in a 3D view of its own (its stretches over floor no photo shows in
// amber), and the plan downloads as JSON. A camera height makes a photos-only plan metric.
import * as THREE from "three";
import { $, element } from "/web/dom.js";
import { apiFetch, problemOf } from "/web/api.js";
import { clearProblem, showHint, showProblem } from "/web/messages.js";
import { photos, withFileNames } from "/web/photos.js";
import { SceneViewer, webglAvailable } from "/web/viewer.js";

const PATH_COLOR = 0x1a7f37;
const UNSEEN_COLOR = 0xd97706; // amber: stretches over floor no photo shows (go slowly, look again)
const state = { goal: null, plan: null, viewer: null };

function goalPhotos() {
  state.goal = null;
  $("route-goal").textContent = photos.files.length ? "Click a point on a photo to set the goal." : "Choose photos first.";
  $("route-start").max = String(Math.max(photos.files.length, 1));
  $("route-photos").replaceChildren(...photos.urls.map((url, i) => element("li", {},
    element("button", { type: "button", className: "goal-photo", onclick: (event) => setGoal(event, i + 1) },
      element("img", { src: url, alt: `image ${i + 1}: click to set the goal here` })),
    element("div", { textContent: `image ${i + 1}` }))));
}

// The clicked pixel in the photo's own pixels (column, row), whatever size it is drawn at.
function setGoal(event, view) {
  const img = event.currentTarget.querySelector("img");
  const box = img.getBoundingClientRect();
  const u = Math.round(((event.clientX - box.left) * img.naturalWidth) / box.width);
  const v = Math.round(((event.clientY - box.top) * img.naturalHeight) / box.height);
  state.goal = { view, u, v };
  document.querySelectorAll("#route-photos button").forEach((button, i) => button.setAttribute("aria-pressed", String(i + 1 === view)));
  $("route-goal").textContent = `Goal: image ${view} at pixel (${u}, ${v}).`;
}

// Posed RGB-D (optional): depth maps sorted by name, as the photos are, and the cameras' JSON, the
// CLI's --cameras file. With them the route is in metres; without, photos alone (scale unknown).
async function posedInputs() {
  const depths = [...$("route-depths").files].sort((a, b) => a.name.localeCompare(b.name));
  const cameras = $("route-cameras").files[0];
  if (!depths.length && !cameras) return { depths: [] };
  if (!depths.length || !cameras) return { hint: "Depth maps and cameras go together: choose both, or neither." };
  let parsed;
  try {
    parsed = JSON.parse(await cameras.text());
  } catch {
    parsed = null;
  }
  if (!parsed || !Array.isArray(parsed.extrinsics) || !Array.isArray(parsed.intrinsics)) {
    return { hint: `${cameras.name} is not a cameras file: it needs {"extrinsics": [...], "intrinsics": [...]}.` };
  }
  return { depths, extrinsics: parsed.extrinsics, intrinsics: parsed.intrinsics };
}

function formOf(posed) {
  const form = new FormData();
  photos.files.forEach((file) => form.append("images", file, file.name));
  posed.depths.forEach((file) => form.append("depths", file, file.name));
  if (posed.extrinsics) {
    form.append("extrinsics", JSON.stringify(posed.extrinsics));
    form.append("intrinsics", JSON.stringify(posed.intrinsics));
  }
  form.append("start_view", $("route-start").value || "1");
  form.append("goal", JSON.stringify({ pixel: state.goal }));
  const robot = { radius: Number($("route-radius").value) || 0.25 };
  const height = Number($("route-camera-height").value);
  if (height > 0) robot.camera_height_m = height;
  form.append("robot", JSON.stringify(robot));
  if ($("backbone").value) form.append("backbone", $("backbone").value);
  return form;
}

function showPlan(plan) {
  const unit = plan.units === "metres" ? "m" : "scene units";
  $("route-summary").textContent = plan.reachable
    ? `${plan.steps.length} step(s), ${plan.length.toFixed(2)} ${unit} (straight line ${plan.straight_line.toFixed(2)}); turns are ${plan.turn_convention}.` +
      (plan.unseen_m > 0 ? ` ${plan.unseen_m.toFixed(2)} ${unit} cross floor no photo shows (amber).` : "")
    : `No route: ${plan.reason}` +
      (plan.look_next ? " To find the way, take a photo as the steps below say, then plan again from it." : "");
  $("route-scale").textContent = `Units: ${plan.units}, scale from ${plan.scale_from || "unknown"}` +
    (plan.floor_residual_m != null ? ` (floor fit residual ${plan.floor_residual_m.toFixed(3)} m)` : "") +
    (plan.scale_check != null ? `; reconstructed camera height / given: ${plan.scale_check.toFixed(2)}` : "") + ".";
  const sentences = plan.reachable || !plan.look_next ? plan.sentences : plan.look_next.sentences;
  $("route-steps").replaceChildren(...sentences.map((sentence) => element("li", { textContent: sentence })));
  $("route-warnings").replaceChildren(...plan.warnings.map((text) => element("li", { textContent: text })));
  $("route-result").hidden = false;
  $("route-result").dataset.sceneId = plan.scene_id; // the scene the plan is of (its download's name)
}

async function drawPath(plan) {
  const canvas = $("route-viewer");
  if (!webglAvailable()) {
    $("route-viewer-status").textContent = "This browser has no WebGL, so the 3D view is off.";
    return;
  }
  const query = new URLSearchParams({ max_points: "30000", backbone: plan.backbone });
  const response = await apiFetch(`/v1/scenes/${encodeURIComponent(plan.scene_id)}/points?${query}`);
  if (!response.ok) {
    $("route-viewer-status").textContent = `The 3D view could not be loaded: ${(await problemOf(response)).detail}`;
    return;
  }
  if (!state.viewer) state.viewer = new SceneViewer(canvas, () => {});
  state.viewer.show(await response.json(), []);
  const points = plan.path_world.map(([x, y, z]) => new THREE.Vector3(x, y, z));
  let drawn = 0;
  if (points.length > 1) {
    // On top of everything: the path runs at floor height, where the floor's own points would hide it.
    const material = new THREE.LineBasicMaterial({ color: PATH_COLOR, depthTest: false });
    const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints(points), material);
    line.name = "route-path";
    line.renderOrder = 5;
    state.viewer.content.add(line);
    drawn = line.geometry.attributes.position.count;
  }
  const unseen = drawUnseen(plan.unseen_stretches || []);
  state.viewer.draw();
  canvas.dataset.pathPoints = String(drawn); // the drawn line's vertex count, for tests and tools
  canvas.dataset.unseenStretches = String(unseen);
  $("route-viewer-status").textContent = points.length > 1
    ? "The route is drawn in green from the start to the goal" + (unseen ? ", its stretches over floor no photo shows in amber." : ".")
    : "No path to draw.";
}

// Each unseen stretch as its own amber line over the green path (drawn later, so on top of it).
function drawUnseen(stretches) {
  const material = new THREE.LineBasicMaterial({ color: UNSEEN_COLOR, depthTest: false });
  for (const stretch of stretches) {
    const ends = [stretch.start_world, stretch.end_world].map(([x, y, z]) => new THREE.Vector3(x, y, z));
    const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints(ends), material);
    line.name = "route-unseen";
    line.renderOrder = 6;
    state.viewer.content.add(line);
  }
  return stretches.length;
}

function downloadPlan() {
  const blob = new Blob([JSON.stringify(state.plan, null, 2)], { type: "application/json" });
  const url = URL.createObjectURL(blob);
  const link = element("a", { href: url, download: `route-${state.plan.scene_id}.json`, hidden: true });
  document.body.append(link);
  link.click();
  link.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
}

async function planRoute(event) {
  event.preventDefault();
  clearProblem();
  if (!photos.files.length) return showHint("Choose the photos first (drop or paste them, or load an example).");
  if (!state.goal) return showHint("Click a point on one of the photos to set the goal.");
  const posed = await posedInputs();
  if (posed.hint) return showHint(posed.hint);
  $("plan-route").disabled = true;
  $("route-status").textContent = "planning …";
  try {
    const response = await apiFetch("/v1/route", { method: "POST", body: formOf(posed) });
    if (!response.ok) {
      $("route-status").textContent = "";
      return showProblem(await problemOf(response), withFileNames);
    }
    state.plan = await response.json();
    $("route-status").textContent = "";
    showPlan(state.plan);
    await drawPath(state.plan);
  } finally {
    $("plan-route").disabled = false;
  }
}

export function mountRouteMode() {
  document.addEventListener("photos-changed", goalPhotos);
  $("route-form").addEventListener("submit", planRoute);
  $("download-plan").addEventListener("click", downloadPlan);
  goalPhotos();
}
