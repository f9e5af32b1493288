// The 3D view: coloured points, input cameras and rendered clue views as labelled frustums.
// World frame and poses are the service's: 3x4 camera-from-world [R|t], OpenCV axes.
// Points arrive sorted by confidence, most confident first (when the reconstruction has one), so
// hiding the least confident is a shorter draw range: no buffer is rebuilt when the slider moves.
// Frames are drawn on demand (a change of view or of a control), never in a loop. Where WebGL runs
// on the CPU (no GPU), a large cloud is drawn from an every-k-th-point copy while the view moves
// (dragging, wheel, keys) and in full as soon as it stops: bench/web_viewer.py measures both.
import * as THREE from "three";
import { OrbitControls } from "/web/vendor/three-0.187.0/OrbitControls.js";

const INPUT_COLOR = 0x0b5cad;
const RENDERED_COLOR = 0xb34000;
const KEY_ROTATE = Math.PI / 36; // 5 degrees per arrow key press
const MOVING_POINTS = 25000; // drawn while the view moves, in software WebGL
const KEYS_SETTLE_MS = 250; // after the last key press the view is at rest again

// Every `step`-th point of a cloud (positions, colours), in the cloud's confidence order.
function strided(geometry, step) {
  const out = new THREE.BufferGeometry();
  for (const name of ["position", "color"]) {
    const source = geometry.getAttribute(name);
    const count = Math.ceil(source.count / step);
    const values = new source.array.constructor(count * 3);
    for (let i = 0; i < count; i++) values.set(source.array.subarray(i * step * 3, i * step * 3 + 3), i * 3);
    out.setAttribute(name, new THREE.BufferAttribute(values, 3, source.normalized));
  }
  return out;
}

function decodeBase64(text) {
  const raw = atob(text);
  const bytes = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; i++) bytes[i] = raw.charCodeAt(i);
  return bytes;
}

// Camera centre and the world-frame rays through the four image corners of a pose.
function frustumGeometry(extrinsic, intrinsic, width, height) {
  const R = extrinsic.map((row) => row.slice(0, 3));
  const t = extrinsic.map((row) => row[3]);
  const center = [0, 1, 2].map((j) => -(R[0][j] * t[0] + R[1][j] * t[1] + R[2][j] * t[2]));
  const [fx, fy, cx, cy] = [intrinsic[0][0], intrinsic[1][1], intrinsic[0][2], intrinsic[1][2]];
  const corners = [[0, 0], [width, 0], [width, height], [0, height]].map(([u, v]) => {
    const cam = [(u - cx) / fx, (v - cy) / fy, 1];
    return [0, 1, 2].map((j) => R[0][j] * cam[0] + R[1][j] * cam[1] + R[2][j] * cam[2]);
  });
  return { center: new THREE.Vector3(...center), rays: corners.map((c) => new THREE.Vector3(...c)) };
}

function labelSprite(text, color) {
  const canvas = document.createElement("canvas");
  canvas.width = 128; canvas.height = 64;
  const g = canvas.getContext("2d");
  g.fillStyle = "#" + color.toString(16).padStart(6, "0");
  g.beginPath(); g.roundRect(4, 4, 120, 56, 12); g.fill();
  g.fillStyle = "#fff"; g.font = "bold 36px system-ui, sans-serif";
  g.textAlign = "center"; g.textBaseline = "middle"; g.fillText(text, 64, 34);
  const material = new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(canvas), depthTest: false });
  const sprite = new THREE.Sprite(material);
  sprite.renderOrder = 10;
  return sprite;
}

export class SceneViewer {
  constructor(canvas, onPick) {
    this.canvas = canvas;
    this.onPick = onPick;
    // Multisampling costs ~10x per frame in software WebGL (measured: bench/web_viewer.py).
    this.software = softwareWebGL();
    const antialias = !this.software;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xfbfbfd);
    this.camera = new THREE.PerspectiveCamera(50, 1, 0.01, 1000);
    this.controls = this.makeControls();
    this.pickables = [];
    this.content = new THREE.Group();
    this.groups = { input: new THREE.Group(), rendered: new THREE.Group() };
    this.scene.add(this.content);
    this.totalPoints = 0;
    this.drawnPoints = 0;
    this.confidence = null;
    canvas.addEventListener("keydown", (event) => this.onKey(event));
    canvas.addEventListener("pointerdown", (event) => { this.downAt = [event.clientX, event.clientY]; });
    canvas.addEventListener("pointerup", (event) => this.onPointerUp(event));
    new ResizeObserver(() => this.resize()).observe(canvas);
  }

  // preview: PointCloudPreview; clueViews: [{index, extrinsic, width, height}] of rendered clue views.
  show(preview, clueViews) {
    this.content.clear();
    this.groups.input.clear();
    this.groups.rendered.clear();
    this.content.add(this.groups.input, this.groups.rendered);
    this.pickables = [];
    const positions = new Float32Array(decodeBase64(preview.positions).buffer);
    const colors = decodeBase64(preview.colors);
    this.confidence = preview.confidence ? new Float32Array(decodeBase64(preview.confidence).buffer) : null;
    this.totalPoints = this.drawnPoints = preview.num_points;
    const cloud = new THREE.BufferGeometry();
    cloud.setAttribute("position", new THREE.BufferAttribute(positions, 3));
    cloud.setAttribute("color", new THREE.BufferAttribute(colors, 3, true));
    cloud.computeBoundingSphere();
    const registered = preview.cameras.filter((c) => c.registered);
    const centers = registered.map((c) => frustumGeometry(c.extrinsic, c.intrinsic, c.width, c.height).center);
    const box = new THREE.Box3().setFromPoints(centers);
    if (preview.num_points) box.union(new THREE.Box3().setFromBufferAttribute(cloud.getAttribute("position")));
    const size = Math.max(box.getSize(new THREE.Vector3()).length(), 1e-3);
    this.basePointSize = size / 120;
    const material = new THREE.PointsMaterial({ size: this.basePointSize, vertexColors: true });
    this.cloud = new THREE.Points(cloud, material);
    this.content.add(this.cloud);
    // The cloud drawn while the view moves: the same points, every `step`-th (null: always in full).
    this.step = this.software && preview.num_points > 1.5 * MOVING_POINTS ? Math.ceil(preview.num_points / MOVING_POINTS) : 1;
    this.moving = null;
    if (this.step > 1) {
      this.moving = new THREE.Points(strided(cloud, this.step), material);
      this.moving.visible = false;
      this.content.add(this.moving);
    }

    const frustumDepth = size * 0.06;
    preview.cameras.forEach((c) => {
      if (!c.registered) return;
      this.addFrustum(`${c.view}`, INPUT_COLOR, c.extrinsic, c.intrinsic, c.width, c.height,
        frustumDepth, { kind: "input", index: c.view - 1 });
    });
    const reference = registered[0];
    clueViews.forEach((view) => {
      if (!reference) return;
      // The renderer's intrinsics: the first placed view's focal scaled to the output, zoom_out 0.5
      // (shared/geometry/rendering.py novel_view_intrinsic), principal point at the centre.
      const scale = Math.min(view.width / reference.width, view.height / reference.height) * 0.5;
      const intrinsic = [[reference.intrinsic[0][0] * scale, 0, view.width / 2],
        [0, reference.intrinsic[1][1] * scale, view.height / 2], [0, 0, 1]];
      this.addFrustum(`v${view.index + 1}`, RENDERED_COLOR, view.extrinsic, intrinsic, view.width,
        view.height, frustumDepth, { kind: "rendered", index: view.index });
    });

    const up = new THREE.Vector3(...preview.up).normalize();
    this.camera.up.copy(up);
    this.camera.near = size / 1000; this.camera.far = size * 100;
    // Start behind and above the photographers, looking the way the photos look.
    const target = box.getCenter(new THREE.Vector3());
    const meanCenter = new THREE.Vector3();
    const forward = new THREE.Vector3();
    registered.forEach((c, i) => {
      meanCenter.add(centers[i]);
      forward.add(new THREE.Vector3(...c.extrinsic[2].slice(0, 3)));
    });
    if (registered.length) meanCenter.divideScalar(registered.length);
    if (forward.lengthSq() < 1e-12) forward.set(0, 0, 1);
    forward.normalize();
    const eye = (registered.length ? meanCenter : target).clone()
      .addScaledVector(forward, -size * 0.32).addScaledVector(up, size * 0.28);
    this.home = { target, size, up, eye };
    this.controls.dispose();
    this.controls = this.makeControls(); // its orbit axis is the camera's up at creation
    this.resetView();
  }

  makeControls() {
    const controls = new OrbitControls(this.camera, this.canvas);
    controls.addEventListener("start", () => this.setMoving(true));
    controls.addEventListener("end", () => this.setMoving(false));
    controls.addEventListener("change", () => this.draw());
    return controls;
  }

  // While the view moves, draw the thinned copy (where there is one); at rest, every point.
  setMoving(moving) {
    if (!this.moving || this.moving.visible === moving) return;
    this.moving.visible = moving;
    this.cloud.visible = !moving;
    if (!moving) this.draw();
  }

  addFrustum(label, color, extrinsic, intrinsic, width, height, depth, pick) {
    const { center, rays } = frustumGeometry(extrinsic, intrinsic, width, height);
    const corners = rays.map((ray) => center.clone().addScaledVector(ray, depth));
    const edges = [center, corners[0], center, corners[1], center, corners[2], center, corners[3],
      corners[0], corners[1], corners[1], corners[2], corners[2], corners[3], corners[3], corners[0]];
    const lines = new THREE.LineSegments(new THREE.BufferGeometry().setFromPoints(edges),
      new THREE.LineBasicMaterial({ color }));
    const faces = new THREE.BufferGeometry().setFromPoints([center, ...corners]);
    faces.setIndex([0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1, 1, 2, 3, 1, 3, 4]);
    const mesh = new THREE.Mesh(faces, new THREE.MeshBasicMaterial({
      color, transparent: true, opacity: 0.15, side: THREE.DoubleSide, depthWrite: false,
    }));
    mesh.userData.pick = pick;
    const sprite = labelSprite(label, color);
    sprite.position.copy(corners[0].clone().add(corners[1]).multiplyScalar(0.5));
    sprite.scale.set(depth * 0.8, depth * 0.4, 1);
    sprite.userData.pick = pick;
    this.groups[pick.kind].add(lines, mesh, sprite);
    this.pickables.push(mesh, sprite);
  }

  get hasConfidence() {
    return this.confidence !== null && this.totalPoints > 0;
  }

  // Hide the least confident `fraction` of the points; returns the confidence at the cut.
  setHiddenFraction(fraction) {
    if (!this.cloud) return null;
    const keep = this.hasConfidence ? Math.max(1, Math.ceil(this.totalPoints * (1 - fraction))) : this.totalPoints;
    this.drawnPoints = keep;
    this.cloud.geometry.setDrawRange(0, keep);
    if (this.moving) this.moving.geometry.setDrawRange(0, Math.ceil(keep / this.step));
    this.draw();
    return this.hasConfidence ? this.confidence[keep - 1] : null;
  }

  setPointScale(scale) {
    if (!this.cloud) return;
    this.cloud.material.size = this.basePointSize * scale;
    this.draw();
  }

  // kind: "input" (the photos' cameras) or "rendered" (the clue's views).
  setVisible(kind, visible) {
    this.groups[kind].visible = visible;
    this.draw();
  }

  resetView() {
    if (!this.home) return;
    const { target, eye } = this.home;
    this.camera.position.copy(eye);
    this.controls.target.copy(target);
    this.controls.update();
    this.draw();
  }

  onKey(event) {
    const c = this.controls;
    const pan = 20; // pixels per key press
    const actions = {
      ArrowLeft: () => (event.shiftKey ? c.pan(pan, 0) : c.rotateLeft(KEY_ROTATE)),
      ArrowRight: () => (event.shiftKey ? c.pan(-pan, 0) : c.rotateLeft(-KEY_ROTATE)),
      ArrowUp: () => (event.shiftKey ? c.pan(0, pan) : c.rotateUp(KEY_ROTATE)),
      ArrowDown: () => (event.shiftKey ? c.pan(0, -pan) : c.rotateUp(-KEY_ROTATE)),
      "+": () => c.dollyIn(1.1), "=": () => c.dollyIn(1.1), "-": () => c.dollyOut(1.1),
      Home: () => this.resetView(),
    };
    const action = actions[event.key];
    if (!action) return;
    event.preventDefault();
    this.setMoving(true);
    action();
    clearTimeout(this.settle);
    this.settle = setTimeout(() => this.setMoving(false), KEYS_SETTLE_MS);
  }

  onPointerUp(event) {
    if (!this.downAt) return;
    const moved = Math.hypot(event.clientX - this.downAt[0], event.clientY - this.downAt[1]);
    this.downAt = null;
    if (moved > 4) return; // a drag, not a click
    const rect = this.canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(((event.clientX - rect.left) / rect.width) * 2 - 1,
      -((event.clientY - rect.top) / rect.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(ndc, this.camera);
    const visible = this.pickables.filter((object) => object.parent && object.parent.visible);
    const hit = ray.intersectObjects(visible, false)[0];
    if (hit) this.onPick(hit.object.userData.pick);
  }

  resize() {
    const { clientWidth: w, clientHeight: h } = this.canvas;
    if (!w || !h) return;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.draw();
  }

  draw() {
    this.renderer.render(this.scene, this.camera);
  }
}

export function webglAvailable() {
  const probe = document.createElement("canvas");
  return Boolean(probe.getContext("webgl2") || probe.getContext("webgl"));
}

// True when WebGL runs on the CPU (SwiftShader, llvmpipe): no GPU to multisample cheaply.
function softwareWebGL() {
  const gl = document.createElement("canvas").getContext("webgl2");
  const info = gl && gl.getExtension("WEBGL_debug_renderer_info");
  const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : "";
  return /swiftshader|llvmpipe|software/i.test(name);
}
