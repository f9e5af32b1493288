"""The web page's 3D view: a WebGL frame in the browser vs a view rendered by the recon service.

    python -m bench.web_viewer [--repeats 30] [--points 30000] [--scene example|dense]

Starts the recon and agent services (in-process cache) on a scene, and Debian's headless Chromium
(software WebGL: SwiftShader, as on a machine without a GPU). The scene is the bundled example
(classical backbone, ~25,000 points) or, with `--scene dense`, two 480x360 synthetic views with
their exact depth (posed-rgbd, ~300,000 points: enough for `--points 200000`). It times, for a
512x512 view of the same scene:
- one orbit step drawn by the page's three.js viewer (rotate, draw, read a pixel back to wait for
  the GPU work), median over --repeats steps;
- one `POST /v1/render` PNG and JPEG round trip (what a server-rendered viewer pays per frame);
- the one-off cost of the viewer: fetching the point subsample it draws.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from shared.local.services import REPO_ROOT, running_service
from shared.wire.client import ReconClient

EXAMPLE = REPO_ROOT / "examples" / "living_room"


def _dense_scene(client: ReconClient) -> str:
    """Two synthetic views with exact depth and cameras: every pixel becomes a point (posed-rgbd)."""
    from shared.synthetic import default_intrinsic, generate_scene, look_at, render_view
    from shared.synthetic.photo import photo_bytes

    scene = generate_scene(4)
    centre = scene.room_centre.copy()
    centre[2] = 0.6
    intrinsic = default_intrinsic(480, 360, 60.0)
    views = []
    for angle in (-90.0, -70.0):
        eye = centre + 1.6 * np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle)), 0.0])
        eye[2] = 1.4
        views.append(render_view(scene, look_at(eye, centre), intrinsic, 480, 360))
    return client.upload_scene(
        [photo_bytes(v.rgb, intrinsic) for v in views],
        depths=[v.depth for v in views],
        extrinsics=np.stack([v.extrinsic for v in views]),
        intrinsics=np.stack([intrinsic, intrinsic]),
    ).scene_id


TIME_ORBIT = """
const [url, repeats, done] = arguments;
(async () => {
  const { SceneViewer } = await import('/web/viewer.js');
  const canvas = document.createElement('canvas');
  canvas.style.cssText = 'width:512px;height:512px;display:block';
  document.body.prepend(canvas);
  const preview = await (await fetch(url)).json();
  const viewer = new SceneViewer(canvas, () => {});
  viewer.show(preview, []);
  viewer.renderer.setPixelRatio(1);
  viewer.resize();
  const gl = viewer.renderer.getContext();
  const pixel = new Uint8Array(4);
  const orbit = () => {
    const times = [];
    for (let i = 0; i < repeats + 3; i++) {
      const started = performance.now();
      viewer.controls.rotateLeft(0.05);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
      times.push(performance.now() - started);
    }
    return times.slice(3);
  };
  const times = orbit();  // every point: the view at rest
  viewer.setMoving(true);  // while a drag moves the view (the thinned copy, where there is one)
  const moving = orbit();
  viewer.setMoving(false);
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const renderer = gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER);
  done({ times, moving, step: viewer.step, renderer, points: preview.num_points });
})().catch((error) => done({ error: String(error) }));
"""


def _browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for flag in (
        "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--disable-quic",
        "--no-first-run", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--window-size=1280,800", f"--user-data-dir={tempfile.mkdtemp()}",
    ):  # fmt: skip
        options.add_argument(flag)
    return webdriver.Chrome(options=options, service=Service("/usr/bin/chromedriver"))


def _median_ms(run, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        run()
        times.append((time.perf_counter() - started) * 1e3)
    return statistics.median(times)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="bench.web_viewer", description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("--points", type=int, default=30_000)
    parser.add_argument("--scene", choices=("example", "dense"), default="example")
    args = parser.parse_args(argv)
    images = [EXAMPLE / name for name in ("view_1.png", "view_2.png", "view_3.png")]
    env = {"REDIS_URL": "", "PYSPATIAL_REDIS_URL": "", "PYSPATIAL_BACKBONE": "classical"}
    with tempfile.TemporaryDirectory() as data_dir:
        env["PYSPATIAL_DATA_DIR"] = data_dir
        with running_service("services.recon.app:create_app", env) as recon:
            agent_env = {**env, "PYSPATIAL_RECON_URL": recon.url}
            with (
                running_service("services.agent.app:create_app", agent_env) as agent,
                ReconClient(recon.url) as client,
            ):
                backbone = "posed-rgbd" if args.scene == "dense" else None
                if args.scene == "dense":
                    scene = _dense_scene(client)
                else:
                    scene = client.upload_scene([Path(p) for p in images]).scene_id
                summary = client.reconstruct(scene, backbone)
                pose = summary.cameras[0].extrinsic
                size = {"width": 512, "height": 512, "backbone": backbone}
                png_ms = _median_ms(lambda: client.render(scene, pose, **size), args.repeats)
                jpeg_ms = _median_ms(lambda: client.render(scene, pose, fmt="jpeg", **size), args.repeats)
                png_bytes = len(client.render(scene, pose, **size))
                points_ms = _median_ms(lambda: client.points(scene, backbone, max_points=args.points), 5)
                payload = len(client.points(scene, backbone, max_points=args.points).model_dump_json())
                driver = _browser()
                try:
                    driver.set_script_timeout(300)
                    driver.get(agent.url + "/")
                    url = f"/v1/scenes/{scene}/points?max_points={args.points}"
                    if backbone:
                        url += f"&backbone={backbone}"
                    measured = driver.execute_async_script(TIME_ORBIT, url, args.repeats)
                finally:
                    driver.quit()
    if "error" in measured:
        raise SystemExit(f"the browser failed: {measured['error']}")
    webgl_ms = statistics.median(measured["times"])
    moving_ms = statistics.median(measured["moving"])
    name = (
        "two synthetic views with depth, posed-rgbd"
        if args.scene == "dense"
        else "bundled example, classical"
    )
    print(f"scene: {name}, {summary.num_points} points")
    print(f"the viewer draws {measured['points']} of them")
    print(f"browser WebGL renderer: {measured['renderer']}")
    print("| 512x512 view of the scene | median ms per frame |")
    print("| --- | ---: |")
    print(f"| three.js orbit step in headless Chromium (software WebGL), every point | {webgl_ms:.1f} |")
    if measured["step"] > 1:
        thinned = -(-measured["points"] // measured["step"])
        label = f"the same while the view moves (every {measured['step']}th point: {thinned})"
        print(f"| {label} | {moving_ms:.1f} |")
    print(f"| `POST /v1/render` PNG round trip ({png_bytes / 1024:.0f} KiB) | {png_ms:.1f} |")
    print(f"| `POST /v1/render` JPEG round trip | {jpeg_ms:.1f} |")
    print(f"one-off: points preview ({payload / 1024:.0f} KiB JSON) fetched in {points_ms:.0f} ms")


if __name__ == "__main__":
    main()
