"""Debian's headless Chromium for the page's tests (selenium; it never downloads a browser), with
what the tests watch: CSP violations, downloads, network throttling, and axe-core.

axe-core is the exact file the npm registry publishes (tests/support/vendor/axe-core-<version>/,
with its licence and SHA256SUMS; scripts/vendor_web.sh): it is injected by the driver, so the page's
CSP (which allows no inline script) does not apply to it, and nothing is fetched at test time.
"""

from __future__ import annotations

import hashlib
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from selenium import webdriver
from selenium.webdriver.chrome.service import Service

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
AXE_DIR = Path(__file__).resolve().parent / "vendor" / "axe-core-4.14.1"

# Runs before any page script (CDP scripts are not subject to the page's CSP): every violation
# the browser reports is kept for the test to read.
_RECORD_CSP = """
window.__cspViolations = [];
document.addEventListener('securitypolicyviolation', (e) => window.__cspViolations.push(
  `${e.violatedDirective} blocked ${e.blockedURI || '(inline)'} at ${e.sourceFile}:${e.lineNumber}`));
"""

_RUN_AXE = """
const done = arguments[arguments.length - 1];
axe.run(document, { resultTypes: ['violations'] })
  .then((results) => done(results.violations.map((v) => ({ id: v.id, impact: v.impact, help: v.help,
    nodes: v.nodes.slice(0, 5).map((n) => n.target.join(' ')) }))))
  .catch((error) => done([{ id: 'axe-failed', impact: 'critical', help: String(error), nodes: [] }]));
"""


def axe_source() -> str:
    """axe.min.js, checked against the SHA256SUMS it was vendored with."""
    sums = dict(
        reversed(line.split()) for line in (AXE_DIR.parent / "SHA256SUMS").read_text().splitlines() if line
    )
    data = (AXE_DIR / "axe.min.js").read_bytes()
    if hashlib.sha256(data).hexdigest() != sums[f"{AXE_DIR.name}/axe.min.js"]:
        raise RuntimeError("tests/support/vendor: axe.min.js does not match SHA256SUMS")
    return data.decode()


@contextmanager
def chromium(download_dir: Path | None = None) -> Iterator[webdriver.Chrome]:
    if not (CHROMIUM.exists() and CHROMEDRIVER.exists()):
        raise RuntimeError(
            "Debian chromium and chromium-driver are required (scripts/setup.sh installs them)"
        )
    profile = tempfile.mkdtemp(prefix="pyspatial-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for flag in (
        "--headless",
        "--no-sandbox",  # root in containers
        "--disable-gpu",
        "--enable-unsafe-swiftshader",  # WebGL on the CPU (SwiftShader)
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--window-size=1280,800",
        f"--user-data-dir={profile}",
    ):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(str(CHROMEDRIVER)))
    driver.set_window_size(1280, 800)
    driver.set_script_timeout(120)
    driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": _RECORD_CSP})
    if download_dir is not None:
        driver.execute_cdp_cmd(
            "Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(download_dir)}
        )
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


def csp_violations(driver: webdriver.Chrome) -> list[str]:
    """What the page reported, and what the browser logged about the Content-Security-Policy."""
    reported = driver.execute_script("return window.__cspViolations || []")
    logged = [
        entry["message"]
        for entry in driver.get_log("browser")
        if "Content Security Policy" in entry["message"]
    ]
    return list(reported) + logged


def axe_problems(driver: webdriver.Chrome, impacts: tuple[str, ...] = ("critical", "serious")) -> list[dict]:
    """axe-core's violations of these impacts on the page as it is now."""
    if not driver.execute_script("return typeof window.axe !== 'undefined'"):
        driver.execute_script(axe_source())
    violations = driver.execute_async_script(_RUN_AXE)
    return [v for v in violations if v["impact"] in impacts]


def throttle_upload(driver: webdriver.Chrome, bytes_per_second: int | None) -> None:
    """Slow the browser's uploads (None: back to full speed), so an upload's progress can be seen."""
    driver.execute_cdp_cmd("Network.enable", {})
    driver.execute_cdp_cmd(
        "Network.emulateNetworkConditions",
        {
            "offline": False,
            "latency": 0,
            "downloadThroughput": -1,
            "uploadThroughput": bytes_per_second if bytes_per_second else -1,
        },
    )
