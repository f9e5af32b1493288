"""The web page's 3D view: a WebGL frame in the browser vs a view rendered by the recon service.

    python -m bench.web_viewer [--repeats 30] [--points 30000]

Starts the recon and agent services (in-process cache, classical backbone) on the bundled example
and Debian's headless Chromium (software WebGL: SwiftShader, as on a machine without a GPU). It
times, for a 512x512 view of the same scene:
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

from shared.local.services import REPO_ROOT, running_service
from shared.wire.client import ReconClient

EXAMPLE = REPO_ROOT / "examples" / "living_room"
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
  const times = [];
  for (let i = 0; i < repeats + 3; i++) {
    const started = performance.now();
    viewer.controls.rotateLeft(0.05);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
    times.push(performance.now() - started);
  }
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const renderer = gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER);
  done({ times: times.slice(3), renderer, points: preview.num_points });
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
                scene = client.upload_scene([Path(p) for p in images]).scene_id
                summary = client.reconstruct(scene)
                pose = summary.cameras[0].extrinsic
                png_ms = _median_ms(lambda: client.render(scene, pose, width=512, height=512), args.repeats)
                jpeg_ms = _median_ms(
                    lambda: client.render(scene, pose, width=512, height=512, fmt="jpeg"), args.repeats
                )
                png_bytes = len(client.render(scene, pose, width=512, height=512))
                points_ms = _median_ms(lambda: client.points(scene, max_points=args.points), 5)
                payload = len(client.points(scene, max_points=args.points).model_dump_json())
                driver = _browser()
                try:
                    driver.set_script_timeout(300)
                    driver.get(agent.url + "/")
                    url = f"/v1/scenes/{scene}/points?max_points={args.points}"
                    measured = driver.execute_async_script(TIME_ORBIT, url, args.repeats)
                finally:
                    driver.quit()
    if "error" in measured:
        raise SystemExit(f"the browser failed: {measured['error']}")
    webgl_ms = statistics.median(measured["times"])
    print(f"scene: bundled example, classical, {summary.num_points} points")
    print(f"the viewer draws {measured['points']} of them")
    print(f"browser WebGL renderer: {measured['renderer']}")
    print("| 512x512 view of the scene | median ms per frame |")
    print("| --- | ---: |")
    print(f"| three.js orbit step in headless Chromium (software WebGL) | {webgl_ms:.1f} |")
    print(f"| `POST /v1/render` PNG round trip ({png_bytes / 1024:.0f} KiB) | {png_ms:.1f} |")
    print(f"| `POST /v1/render` JPEG round trip | {jpeg_ms:.1f} |")
    print(f"one-off: points preview ({payload / 1024:.0f} KiB JSON) fetched in {points_ms:.0f} ms")


if __name__ == "__main__":
    main()
