// The page's entry: mounts each part. The parts are ES modules with one job each (no build step):
// dom.js, api.js (key, requests, the solve's event stream), messages.js (the one error message),
// photos.js (choose, drop anywhere, paste), gallery.js (examples), progress.js (stages, clock,
// upload), result.js, scene.js and viewer.js (the 3D view and its controls), and solve.js, the
// page's first mode, and route.js (a goal clicked on a photo, POST /v1/route, the path in 3D). A
// new mode is a module like these, mounted here.
import { $, element } from "/web/dom.js";
import { apiFetch, restoreApiKey } from "/web/api.js";
import { mountGallery } from "/web/gallery.js";
import { mountPhotos } from "/web/photos.js";
import { mountSceneControls } from "/web/scene.js";
import { mountRouteMode } from "/web/route.js";
import { mountSolveMode } from "/web/solve.js";

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

restoreApiKey(() => {
  loadBackbones();
  mountGallery();
});
mountPhotos();
mountSceneControls();
mountSolveMode();
mountRouteMode();
loadBackbones();
mountGallery();
