"""The pictures of docs/viewer.md: the page mid-game, the feature-layer panels, a grid.

    python scripts/viewer_screenshots.py --output=docs/figures

Needs Chromium and chromedriver (Debian: apt install chromium chromium-driver) and
selenium. Writes viewer_page.png (the page watching the scripted agent of
DefeatZerglingsAndBanelings, paused mid-episode), viewer_layers.png (the feature-layer
panels of that page) and viewer_grid.png (four episodes of the random policy on
CollectMineralShards side by side, as `evaluate --video` draws them).
"""

from __future__ import annotations

import argparse
import os
import shutil
import time

from PIL import Image
from selenium import webdriver
from selenium.webdriver.chrome.options import Options
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By

from sc2jax.environment import make
from sc2jax.environment.agents import required_format
from sc2jax.environment.engine.compiled import simulator
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.experiments.training import evaluation
from sc2jax.experiments.viewer import frames
from sc2jax.experiments.viewer.server import ViewerServer
from sc2jax.experiments.viewer.session import PlaySession


def _page(output: str) -> None:
    map_name = "DefeatZerglingsAndBanelings"
    sim = make(map_name, 64, 64, **required_format(map_name)).simulator
    agent = evaluation.host_policy(evaluation.make_policy("scripted", map_name, sim.fmt))
    session = PlaySession(sim, seed=1, layers=sim.fmt.screen_layers + sim.fmt.minimap_layers,
                          agent=agent, agent_name="scripted")
    for _ in range(12):
        session.step()
    server = ViewerServer(port=0, paused=True).start(session)
    options = Options()
    options.binary_location = shutil.which("chromium")
    for argument in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                     "--window-size=1500,980"):
        options.add_argument(argument)
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)
    try:
        driver.get(server.address)
        time.sleep(3)
        driver.save_screenshot(os.path.join(output, "viewer_page.png"))
        layers = driver.find_element(By.ID, "layers")
        layers.screenshot(os.path.join(output, "viewer_layers.png"))
    finally:
        driver.quit()
        server.close()


def _grid(output: str) -> None:
    map_name = "CollectMineralShards"
    fmt = ObservationFormat(screen_size=64, minimap_size=64)
    sim = simulator(map_name, fmt, 8, 0, 1.0, 1.0, False)
    core = evaluation.policy_core(evaluation.make_policy("random", map_name, fmt))
    episodes = evaluation.record_episodes(sim, core, None, 4, seed=0, agent="random")
    drawn = [frames.episode_pictures(e, 192) for e in episodes]
    Image.fromarray(frames.batch_frames(drawn)[120]).save(
        os.path.join(output, "viewer_grid.png"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="docs/figures")
    args = parser.parse_args()
    os.makedirs(args.output, exist_ok=True)
    _page(args.output)
    _grid(args.output)
    print(f"Wrote viewer_page.png, viewer_layers.png and viewer_grid.png to {args.output}")


if __name__ == "__main__":
    main()
