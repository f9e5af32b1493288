"""A first visit to the web page: bytes on the wire without compression (as before) and with it.

    python -m bench.web_bytes

Starts the recon and agent services and Debian's headless Chromium with an empty cache, opens the
page twice: once asking for `Accept-Encoding: identity` (what the page cost before the agent
compressed anything), once with the browser's own Accept-Encoding. Sums the transfer sizes the
browser reports for the page and everything it loaded (Resource Timing: headers included), and,
per encoding the agent offers, the bytes of the same files fetched with httpx.
"""

from __future__ import annotations

import argparse
import re
import tempfile

import httpx

from shared.local.services import running_service

MEASURE = """
const done = arguments[arguments.length - 1];
const settle = () => {
  const entries = ['navigation', 'resource'].flatMap((type) => performance.getEntriesByType(type));
  done(entries.map((e) => ({ name: e.name, transfer: e.transferSize, body: e.decodedBodySize })));
};
if (document.readyState === 'complete') setTimeout(settle, 1500);
else addEventListener('load', () => setTimeout(settle, 1500));
"""


def _browser(profile: str):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for flag in (
        "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--disable-quic",
        "--no-first-run", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--window-size=1280,800", f"--user-data-dir={profile}",
    ):  # fmt: skip
        options.add_argument(flag)
    return webdriver.Chrome(options=options, service=Service("/usr/bin/chromedriver"))


def browser_visit(url: str, identity: bool) -> tuple[int, int, list[dict]]:
    """(bytes on the wire, bytes decoded, entries) of one first visit with an empty cache."""
    with tempfile.TemporaryDirectory() as profile:
        driver = _browser(profile)
        try:
            driver.execute_cdp_cmd("Network.enable", {})
            driver.execute_cdp_cmd("Network.setCacheDisabled", {"cacheDisabled": True})
            if identity:
                driver.execute_cdp_cmd(
                    "Network.setExtraHTTPHeaders", {"headers": {"Accept-Encoding": "identity"}}
                )
            driver.set_script_timeout(60)
            driver.get(url + "/")
            entries = driver.execute_async_script(MEASURE)
        finally:
            driver.quit()
    return sum(e["transfer"] for e in entries), sum(e["body"] for e in entries), entries


def page_files(url: str) -> list[str]:
    html = httpx.get(url + "/").text
    files = ["/", *re.findall(r'(?:src|href)="(/web/[^"]+)"', html)]
    files += re.findall(r'"(/web/[^"]+\.js)": "sha384-', html)  # the import map's modules
    return sorted(set(files))


def wire_bytes(url: str, files: list[str], encoding: str) -> int:
    total = 0
    for path in files:
        with httpx.stream("GET", url + path, headers={"Accept-Encoding": encoding}) as response:
            total += sum(len(chunk) for chunk in response.iter_raw())
    return total


def main(argv: list[str] | None = None) -> None:
    argparse.ArgumentParser(prog="bench.web_bytes", description=__doc__.splitlines()[0]).parse_args(argv)
    env = {"REDIS_URL": "", "PYSPATIAL_REDIS_URL": "", "PYSPATIAL_BACKBONE": "classical"}
    with tempfile.TemporaryDirectory() as data_dir:
        env["PYSPATIAL_DATA_DIR"] = data_dir
        with running_service("services.recon.app:create_app", env) as recon:
            with running_service(
                "services.agent.app:create_app", {**env, "PYSPATIAL_RECON_URL": recon.url}
            ) as agent:
                plain, plain_body, plain_entries = browser_visit(agent.url, identity=True)
                packed, packed_body, packed_entries = browser_visit(agent.url, identity=False)
                files = page_files(agent.url)
                per_encoding = {
                    enc: wire_bytes(agent.url, files, enc) for enc in ("identity", "gzip", "br", "zstd")
                }
    used = {e["name"].split("/", 3)[-1] for e in packed_entries}
    print(f"the browser loaded {len(packed_entries)} files ({len(plain_entries)} without compression)")
    print("| first visit, empty cache | bytes on the wire | decoded | vs. uncompressed |")
    print("| --- | ---: | ---: | ---: |")
    print(f"| headless Chromium, `Accept-Encoding: identity` (before) | {plain:,} | {plain_body:,} | 1.0x |")
    print(
        f"| headless Chromium, its own Accept-Encoding (after) | {packed:,} | {packed_body:,} "
        f"| {plain / packed:.1f}x |"
    )
    print(f"\nthe page's {len(files)} files (page, scripts, styles, modules), fetched with httpx:")
    print("| Accept-Encoding | bytes | vs. identity |")
    print("| --- | ---: | ---: |")
    for encoding, size in per_encoding.items():
        print(f"| {encoding} | {size:,} | {per_encoding['identity'] / size:.1f}x |")
    missing = [f for f in files if f.lstrip("/") not in used and f != "/"]
    if missing:
        print(f"(not loaded by the browser on a first visit: {', '.join(missing)})")


if __name__ == "__main__":
    main()
