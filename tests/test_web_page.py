"""The web page in a real headless Chromium against real services (recon + agent + Redis).

The code model is the scripted local server (the only stand-in); its second program renders a
view, so the page has a repair to show, a text clue, a rendered clue image and a clue camera.
Screenshots go to $PYSPATIAL_WEB_SCREENSHOTS (default: a pytest temporary folder).
"""

from __future__ import annotations

import io
import json
import os
import shutil
import tempfile
import uuid
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from selenium import webdriver
from selenium.common.exceptions import TimeoutException
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from selenium.webdriver.support.ui import WebDriverWait

from shared.local.services import REPO_ROOT, running_service

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
EXAMPLE = REPO_ROOT / "examples" / "living_room"
PAGE_KEY = "page-test-key"

BROKEN_PROGRAM = "```python\nimport os\ndef program(input_scene):\n    return os.listdir('/')\n```"
RENDERING_PROGRAM = """```python
def program(input_scene):
    recon = pySpatial.reconstruct(input_scene)
    motion = pySpatial.describe_camera_motion(recon)
    turned = pySpatial.rotate_right(recon.extrinsics[0], 25)
    view = pySpatial.synthesize_novel_view(recon, turned, width=240, height=180)
    return [motion, view]
```"""


@pytest.fixture(scope="module")
def recon(tmp_path_factory, redis_url):
    recon_env = {
        "PYSPATIAL_DATA_DIR": str(tmp_path_factory.mktemp("recon")),
        "REDIS_URL": redis_url,
        "PYSPATIAL_CACHE_NAMESPACE": f"test-web-{uuid.uuid4().hex[:8]}",
        "PYSPATIAL_BACKBONE": "classical",
    }
    with running_service("services.recon.app:create_app", recon_env) as service:
        yield service


def agent_env(recon_url: str, llm, code_model: str) -> dict[str, str]:
    return {
        "PYSPATIAL_RECON_URL": recon_url,
        "PYSPATIAL_CODE_MODEL": code_model,
        "PYSPATIAL_CODE_MODEL_BASE_URL": llm.base_url,
        "PYSPATIAL_ANSWER_MODEL": "",  # the offline answerer reads the motion sentence
        "PYSPATIAL_MODEL_TIMEOUT_S": "5",
        "PYSPATIAL_MODEL_MAX_RETRIES": "1",
    }


@pytest.fixture(scope="module")
def stack(recon, llm):
    with running_service("services.agent.app:create_app", agent_env(recon.url, llm, "coder")) as agent:
        yield agent


@pytest.fixture(scope="module")
def keyed_agent(recon, llm):
    """An agent that demands an API key; its code model fails, so the planner writes the program."""
    env = {**agent_env(recon.url, llm, "failing-coder"), "PYSPATIAL_API_KEYS": PAGE_KEY}
    with running_service("services.agent.app:create_app", env) as agent:
        yield agent


@pytest.fixture(scope="module")
def browser():
    if not (CHROMIUM.exists() and CHROMEDRIVER.exists()):
        pytest.fail("Debian chromium and chromium-driver are required (scripts/setup.sh installs them)")
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
    driver = webdriver.Chrome(options=options, service=Service(str(CHROMEDRIVER)))
    driver.set_window_size(1280, 800)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


@pytest.fixture(scope="module")
def shots(tmp_path_factory) -> Path:
    folder = os.environ.get("PYSPATIAL_WEB_SCREENSHOTS")
    path = Path(folder) if folder else tmp_path_factory.mktemp("screenshots")
    path.mkdir(parents=True, exist_ok=True)
    return path


def _viewport(driver, width: int, height: int) -> None:
    """Make the page's viewport exactly width x height (the window frame differs per platform)."""
    driver.set_window_size(width, height)
    inner = driver.execute_script("return [window.innerWidth, window.innerHeight]")
    driver.set_window_size(2 * width - inner[0], 2 * height - inner[1])


def _canvas_pixels(driver) -> np.ndarray:
    png = driver.find_element(By.ID, "viewer").screenshot_as_png
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(np.int16)


def test_solve_the_example_and_inspect_it(stack, llm, browser, shots):
    spec = json.loads((EXAMPLE / "example.json").read_text())
    llm.reset()
    llm.script([BROKEN_PROGRAM, RENDERING_PROGRAM], model="coder")
    _viewport(browser, 1280, 800)
    browser.get(stack.url + "/")
    files = browser.find_element(By.ID, "images")
    files.send_keys("\n".join(str(EXAMPLE / name) for name in spec["images"]))
    assert [e.text for e in browser.find_elements(By.CSS_SELECTOR, "#thumbs li div")] == [
        "image 1",
        "image 2",
        "image 3",
    ]
    browser.find_element(By.ID, "question").send_keys(spec["question"])
    # The backbone menu offers only what recon can run: no learned backbone without its weights.
    WebDriverWait(browser, 30).until(lambda d: len(d.find_elements(By.CSS_SELECTOR, "#backbone option")) > 1)
    offered = [e.text for e in browser.find_elements(By.CSS_SELECTOR, "#backbone option")]
    assert offered[1:] == ["auto (classical)", "classical", "posed-rgbd"], offered
    browser.find_element(By.ID, "solve").click()
    try:
        WebDriverWait(browser, 240).until(lambda d: d.find_element(By.ID, "answer").text)
    except TimeoutException:
        browser.save_screenshot(str(shots / "timeout.png"))
        raise AssertionError(
            f"no answer; page error: {browser.find_element(By.ID, 'error').text!r}"
        ) from None

    stages = {
        e.get_attribute("data-stage"): e.get_attribute("data-state")
        for e in browser.find_elements(By.CSS_SELECTOR, "#progress li")
    }
    assert stages == dict.fromkeys(["upload", "reconstruction", "program", "execution", "answer"], "done")
    assert browser.find_element(By.ID, "answer").text == f"Answer: {spec['expected_answer']}"
    assert "view 1 to view 2" in browser.find_element(By.ID, "reasoning").text
    program = browser.find_element(By.ID, "program")
    assert "synthesize_novel_view" in program.text
    assert program.find_elements(By.CSS_SELECTOR, "span.hljs-keyword")  # highlighted
    attempts = browser.find_elements(By.CSS_SELECTOR, "#attempts details")
    assert len(attempts) == 2 and "import" in attempts[0].get_attribute("textContent")
    clue = browser.find_elements(By.CSS_SELECTOR, "#clue-images li")
    assert len(clue) == 1 and "rendered view v1" in clue[0].text and "camera-from-world" in clue[0].text
    assert browser.execute_script("return document.querySelector('#clue-images img').naturalWidth") == 240
    assert "view 1 to view 2" in browser.find_element(By.ID, "clue-text").text
    inputs = [e.text for e in browser.find_elements(By.CSS_SELECTOR, "#inputs li div")]
    assert [text.split(" —")[0] for text in inputs] == ["image 1", "image 2", "image 3"]
    assert "total" in browser.find_element(By.ID, "timings").text

    # The 3D view: points loaded, one camera per placed photo and one per rendered view.
    WebDriverWait(browser, 60).until(lambda d: "points" in d.find_element(By.ID, "viewer-status").text)
    buttons = [e.text for e in browser.find_elements(By.CSS_SELECTOR, "#camera-buttons button")]
    assert buttons == ["image 1", "image 2", "image 3", "view v1"], buttons
    browser.execute_script("window.scrollTo(0, 0)")
    browser.save_screenshot(str(shots / "desktop-top.png"))
    viewer = browser.find_element(By.ID, "viewer")
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", viewer)
    before = _canvas_pixels(browser)
    assert np.ptp(before) > 50  # something is drawn
    browser.save_screenshot(str(shots / "desktop-1280x800.png"))
    viewer.send_keys(*([Keys.ARROW_LEFT] * 6))  # keyboard orbit, 30 degrees
    after = _canvas_pixels(browser)
    changed = np.mean(np.any(np.abs(after - before) > 30, axis=2))
    assert changed > 0.01, f"the 3D view did not change when rotated ({changed:.2%} of pixels)"
    browser.save_screenshot(str(shots / "desktop-rotated.png"))

    # Clicking a camera in the 3D view shows its photo or render: probe a grid of clicks.
    viewer.send_keys(Keys.HOME)
    size = viewer.size
    picked = None
    for fy in np.linspace(0.95, 0.05, 13):  # the cameras sit low in the reset view
        for fx in np.linspace(0.05, 0.95, 13):
            x, y = int((fx - 0.5) * size["width"]), int((fy - 0.5) * size["height"])
            ActionChains(browser).move_to_element_with_offset(viewer, x, y).click().perform()
            if browser.find_element(By.ID, "picked").is_displayed():
                picked = browser.find_element(By.ID, "picked-caption").text
                break
        if picked:
            break
    assert picked and (picked.startswith("image ") or picked.startswith("rendered view")), picked
    browser.execute_script("document.getElementById('program').scrollIntoView()")
    browser.save_screenshot(str(shots / "desktop-program-and-clue.png"))
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", viewer)
    browser.find_element(By.XPATH, "//div[@id='camera-buttons']/button[text()='view v1']").click()
    assert "rendered view v1" in browser.find_element(By.ID, "picked-caption").text
    browser.find_element(By.XPATH, "//div[@id='camera-buttons']/button[text()='image 2']").click()
    assert browser.find_element(By.ID, "picked-caption").text.startswith("image 2")

    # Everything is reachable with the keyboard alone: walk the page with Tab.
    browser.execute_script("document.activeElement.blur(); window.scrollTo(0, 0)")
    reached = set()
    for _ in range(40):
        ActionChains(browser).send_keys(Keys.TAB).perform()
        focused = browser.switch_to.active_element
        reached.add(focused.get_attribute("id") or focused.text)
    expected = {"images", "use-example", "question", "backbone", "solve", "viewer", "reset-view", "view v1"}
    assert expected <= reached, expected - reached

    _viewport(browser, 390, 844)
    overflow = browser.execute_script("return document.documentElement.scrollWidth - window.innerWidth")
    assert overflow <= 0, f"the page is {overflow} px wider than a phone screen"
    browser.execute_script("window.scrollTo(0, 0)")
    browser.save_screenshot(str(shots / "phone-390x844.png"))
    browser.execute_script("document.getElementById('result').scrollIntoView()")
    browser.save_screenshot(str(shots / "phone-result.png"))
    _viewport(browser, 1280, 800)


def test_a_file_that_is_no_image_gets_a_readable_message(stack, browser, shots, tmp_path):
    browser.get(stack.url + "/")
    browser.find_element(By.ID, "use-example").click()  # fills the question, then we swap the photos
    WebDriverWait(browser, 30).until(lambda d: d.find_element(By.ID, "question").get_attribute("value"))
    assert len(browser.find_elements(By.CSS_SELECTOR, "#thumbs li")) == 3
    note = tmp_path / "zz_notes.png"  # sorted after view_1.png: image 2
    note.write_text("shopping list: milk, eggs")
    browser.find_element(By.ID, "images").send_keys(f"{EXAMPLE / 'view_1.png'}\n{note}")
    browser.find_element(By.ID, "solve").click()
    WebDriverWait(browser, 60).until(lambda d: d.find_element(By.ID, "error").text)
    message = browser.find_element(By.ID, "error").text
    assert "image 2 (zz_notes.png) is not an image file" in message, message
    assert (
        browser.find_element(By.CSS_SELECTOR, "#progress li[data-stage='upload']").get_attribute("data-state")
        == "failed"
    )
    browser.save_screenshot(str(shots / "error-not-an-image.png"))


def test_a_keyed_agent_asks_for_the_key_then_answers_and_shows_the_fallback(keyed_agent, llm, browser, shots):
    spec = json.loads((EXAMPLE / "example.json").read_text())
    llm.reset()
    llm.script([{"status": 500, "error_message": "upstream down"}] * 4, model="failing-coder")
    browser.get(keyed_agent.url + "/")
    browser.find_element(By.ID, "images").send_keys("\n".join(str(EXAMPLE / name) for name in spec["images"]))
    browser.find_element(By.ID, "question").send_keys(spec["question"])
    browser.find_element(By.ID, "solve").click()
    WebDriverWait(browser, 60).until(lambda d: d.find_element(By.ID, "error").text)
    assert browser.find_element(By.ID, "error").text == "This agent needs an API key: enter it above."
    browser.save_screenshot(str(shots / "error-api-key-needed.png"))

    browser.find_element(By.ID, "api-key").send_keys(PAGE_KEY)
    browser.find_element(By.ID, "solve").click()
    try:
        WebDriverWait(browser, 240).until(lambda d: d.find_element(By.ID, "answer").text)
    except TimeoutException:
        browser.save_screenshot(str(shots / "timeout-keyed.png"))
        error = browser.find_element(By.ID, "error").text
        raise AssertionError(f"no answer; page error: {error!r}") from None
    assert not browser.find_element(By.ID, "error").is_displayed()
    assert browser.find_element(By.ID, "answer").text == f"Answer: {spec['expected_answer']}"
    assert browser.execute_script("return sessionStorage.getItem('pyspatial-api-key')") == PAGE_KEY
    warnings = browser.find_element(By.ID, "warnings").text
    assert "The code model failed, so the offline planner wrote the program" in warnings, warnings
    models = browser.find_element(By.ID, "models").text
    assert "program by offline-planner (fallback: failing-coder" in models, models
    assert "answer by offline-answerer (offline_text)" in models, models
    # The points request carries the key too: the 3D view loads.
    WebDriverWait(browser, 60).until(lambda d: "points" in d.find_element(By.ID, "viewer-status").text)
    browser.save_screenshot(str(shots / "keyed-answer.png"))
