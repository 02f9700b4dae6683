"""The viewer as a person uses it: a headless Chromium plays MoveToBeacon in the page.

Needs Chromium and its driver (Debian: `apt install chromium chromium-driver`) and the
`selenium` package; skipped with a message where they are missing.
"""

import io
import json
import shutil
import time
import urllib.request

import numpy as np
import pytest
from PIL import Image

from sc2jax.environment.engine import human_view as hv
from sc2jax.environment.engine.rules.units import UnitType
from sc2jax.experiments.viewer.server import ViewerServer
from sc2jax.experiments.viewer.session import PlaySession
from tests.environment.helpers import small_sim

webdriver = pytest.importorskip("selenium.webdriver", reason="needs selenium "
                                "(pip install selenium)")

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not (CHROMIUM and DRIVER), reason="needs Chromium and chromedriver "
                       "(Debian: apt install chromium chromium-driver)")]


def _status(address):
    with urllib.request.urlopen(address + "api/status", timeout=10) as reply:
        return json.load(reply)


def _wait(condition, seconds=60, what="the condition"):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"timed out waiting for {what}")


def _centre(image: np.ndarray, rgb) -> tuple[float, float]:
    ys, xs = np.nonzero((image[..., :3] == np.asarray(rgb)).all(axis=-1))
    assert len(xs), f"no pixel of colour {rgb} on the page's view"
    return float(xs.mean()), float(ys.mean())


@pytest.fixture()
def browser():
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = CHROMIUM
    for argument in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                     "--disable-gpu", "--window-size=1400,900"):
        options.add_argument(argument)
    driver = webdriver.Chrome(service=Service(DRIVER), options=options)
    yield driver
    driver.quit()


def test_a_person_selects_the_marine_and_moves_it_to_the_beacon(browser, tmp_path):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    sim = small_sim("MoveToBeacon")
    session = PlaySession(sim, seed=5, layers=sim.fmt.screen_layers + sim.fmt.minimap_layers,
                          width=384)
    server = ViewerServer(port=0, speed=8.0).start(session)
    try:
        browser.get(server.address)
        view = browser.find_element(By.ID, "view")
        _wait(lambda: browser.execute_script(
            "return arguments[0].complete && arguments[0].naturalWidth > 0", view),
            what="the view to load")
        picture = np.asarray(Image.open(io.BytesIO(view.screenshot_as_png)))
        scale = picture.shape[1] / view.size["width"]  # Device pixels per CSS pixel.
        marine = _centre(picture, hv.SELF_COLOUR)
        beacon = _centre(picture, hv._TYPE_COLOUR[UnitType.BEACON])

        def click(point, right=False):
            x = point[0] / scale - view.size["width"] / 2
            y = point[1] / scale - view.size["height"] / 2
            chain = ActionChains(browser).move_to_element_with_offset(view, int(x), int(y))
            (chain.context_click() if right else chain.click()).perform()

        click(marine)
        # The first action compiles the session's step: over a minute on a loaded 2-core
        # machine inside the suite (15 s for the whole test alone).
        _wait(lambda: _status(server.address)["last_call"].startswith("select_point"),
              seconds=300, what="the click to select the marine")
        assert "Smart_screen" in [f["name"] for f in _status(server.address)["available"]]
        click(beacon, right=True)
        _wait(lambda: browser.find_element(By.ID, "message").text.startswith(
            "queued FunctionCall(function=451"), what="Smart_screen to be queued")
        _wait(lambda: _status(server.address)["score"] >= 1, seconds=60,
              what="the marine to reach the beacon")
        # The page shows what the server says.
        _wait(lambda: "score 1" in browser.find_element(By.ID, "numbers").text
              or "score 2" in browser.find_element(By.ID, "numbers").text,
              what="the page to show the score")
        layers = browser.find_elements(By.CSS_SELECTOR, "#layers img")
        assert len(layers) == 4  # The default layers.
        browser.save_screenshot(str(tmp_path / "page.png"))
        assert Image.open(tmp_path / "page.png").size[0] > 1000
    finally:
        server.close()
