// The photos of the next solve: chosen with the file input, dropped anywhere on the page, pasted,
// or loaded from an example; shown as numbered thumbnails ("image 1" is the first).
import { $, element } from "/web/dom.js";

export const photos = { files: [], urls: [] };
let pasted = 0;

export function setFiles(files) {
  photos.urls.forEach((url) => URL.revokeObjectURL(url));
  photos.files = files;
  photos.urls = files.map((file) => URL.createObjectURL(file));
  $("thumbs").replaceChildren(...files.map((file, i) => element("li", {},
    element("img", { src: photos.urls[i], alt: `image ${i + 1}: ${file.name}` }),
    element("div", { textContent: `image ${i + 1}` }))));
  $("photo-count").textContent = files.length ? `${files.length} photo${files.length === 1 ? "" : "s"} chosen` : "";
  document.dispatchEvent(new CustomEvent("photos-changed")); // the route mode's goal photos follow
}

function sortedByName(files) {
  return [...files].sort((a, b) => a.name.localeCompare(b.name, undefined, { numeric: true }));
}

// "image 2 is not ..." from the service becomes "image 2 (name.jpg) is not ...".
export function withFileNames(message) {
  return message.replace(/\bimage (\d+)\b/g, (text, n) => {
    const file = photos.files[Number(n) - 1];
    return file ? `${text} (${file.name})` : text;
  });
}

function hasFiles(event) {
  return Array.from(event.dataTransfer?.types || []).includes("Files");
}

// Files dropped anywhere on the page replace the photos; an overlay shows where they will go.
function acceptDropsAnywhere() {
  const overlay = $("drop-overlay");
  let depth = 0;
  document.addEventListener("dragenter", (event) => {
    if (!hasFiles(event)) return;
    depth += 1;
    overlay.hidden = false;
  });
  document.addEventListener("dragleave", () => {
    depth = Math.max(0, depth - 1);
    if (!depth) overlay.hidden = true;
  });
  document.addEventListener("dragover", (event) => {
    if (hasFiles(event)) event.preventDefault(); // allows the drop
  });
  document.addEventListener("drop", (event) => {
    depth = 0;
    overlay.hidden = true;
    if (!event.dataTransfer?.files.length) return;
    event.preventDefault(); // not opened by the browser
    setFiles(sortedByName(event.dataTransfer.files));
  });
}

// A pasted image (a screenshot, a copied photo) is added after the photos already chosen.
function acceptPastedImages() {
  document.addEventListener("paste", (event) => {
    const images = Array.from(event.clipboardData?.files || []).filter((file) => file.type.startsWith("image/"));
    if (!images.length) return; // pasted text goes where it was pasted
    event.preventDefault();
    const named = images.map((file) => {
      pasted += 1;
      const extension = (file.type.split("/")[1] || "png").replace("jpeg", "jpg");
      return new File([file], `pasted-${pasted}.${extension}`, { type: file.type });
    });
    setFiles([...photos.files, ...named]);
  });
}

export function mountPhotos() {
  $("images").addEventListener("change", (event) => setFiles(sortedByName(event.target.files)));
  acceptDropsAnywhere();
  acceptPastedImages();
}
