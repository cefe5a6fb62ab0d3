"""Benchmark of ``inkmotion studio`` as a newcomer uses it, in headless Chromium.

The studio starts in a subprocess with a fresh data directory; once its job processes are
warm (``/api/status``), a browser opens the page, picks the shipped sample tempt-1, fits it
at default settings, watches it animate, sends it to the plotter and downloads the G-code:
the page's readiness, the first progress after Fit, the animation's frame rate and the
whole flow's time are the figures. Then one word alone and three words in three tabs at
once: how much slower the slowest of the three ends than one alone.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Any

#: seconds the studio may take to start and warm up its job processes
READY_TIMEOUT_S = 180.0


def bench_studio() -> dict[str, float]:
    """{"studio_ready_s", "studio_page_ms", "studio_first_progress_ms", "studio_fit_shown_s",
    "studio_fps", "studio_gcode_s", "studio_three_over_alone"}."""
    from inkmotion.workers.local import HOST, free_port, stop_process

    with tempfile.TemporaryDirectory(prefix="inkmotion-bench-studio-") as tmp:
        root = Path(tmp)
        port = free_port()
        url = f"http://{HOST}:{port}"
        env = {**os.environ, "INKMOTION_DATA_DIR": str(root / "data"),
               "INKMOTION_DB_URL": f"sqlite:///{root}/jobs.db"}
        for name in ("INKMOTION_BROKER_URL", "INKMOTION_THREADS"):  # a user's defaults: one
            env.pop(name, None)  # thread a job, as many jobs at once as cores
        started = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "inkmotion", "studio", "--no-open",
                                 "--port", str(port)], env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            _wait(lambda: _ready(url), READY_TIMEOUT_S, "the studio to warm up")
            figures = {"studio_ready_s": time.perf_counter() - started}
            figures.update(_newcomer(url, root / "downloads"))
            return figures
        finally:
            stop_process(proc, grace=60, first=signal.SIGINT)  # Ctrl-C: it ends its jobs


def _ready(url: str) -> bool:
    import json

    try:
        with urllib.request.urlopen(url + "/api/status", timeout=2) as r:
            return bool(json.loads(r.read())["ready"])
    except OSError:
        return False


def _wait(predicate: Any, timeout: float, what: str) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.1)
    from inkmotion.errors import ServiceError

    raise ServiceError(f"Timed out after {timeout:.0f} s waiting for {what}.")


def _newcomer(url: str, downloads: Path) -> dict[str, float]:
    from selenium.webdriver.common.by import By

    from inkmotion.browser import chromium

    downloads.mkdir(parents=True)
    with chromium(1320, 1050) as d:
        d.execute_cdp_cmd("Page.setDownloadBehavior",
                          {"behavior": "allow", "downloadPath": str(downloads)})
        opened = time.perf_counter()
        d.get(url + "/")
        page_ms = d.execute_script("return performance.timing.domContentLoadedEventEnd - "
                                   "performance.timing.navigationStart")
        d.find_element(By.ID, "tab-sample").click()
        pressed = time.perf_counter()
        d.find_element(By.ID, "fit").click()
        _wait(lambda: d.execute_script("return window.studio.result"), 300, "the fit")
        shown = time.perf_counter() - pressed
        first_ms = d.execute_script("return window.studio.firstEventMs")
        _wait(lambda: not d.execute_script("return window.studio.playing"), 120,
              "the animation")
        fps = d.execute_script("return window.studio.fps()")
        d.find_element(By.ID, "send-plot").click()
        link = "#sent-plot a[href$='plot.gcode']"
        _wait(lambda: d.execute_script(f"return document.querySelector(\"{link}\")"), 120,
              "the plot")
        d.find_element(By.CSS_SELECTOR, link).click()
        _wait(lambda: list(downloads.glob("*plot.gcode")), 60, "the G-code download")
        gcode_s = time.perf_counter() - opened
        alone, together = _three_tabs(d, url)
    return {"studio_page_ms": float(page_ms), "studio_first_progress_ms": float(first_ms),
            "studio_fit_shown_s": shown, "studio_fps": float(fps), "studio_gcode_s": gcode_s,
            "studio_three_over_alone": together / alone}


def _three_tabs(d: Any, url: str) -> tuple[float, float]:
    """(one word fitted alone, the slowest of three fitted at once in three tabs), s."""
    from selenium.webdriver.common.by import By

    def fit(word: str) -> float:
        d.get(url + "/")
        d.find_element(By.ID, "tab-word").click()
        box = d.find_element(By.ID, "word")
        box.clear()
        box.send_keys(word)
        d.find_element(By.ID, "fit").click()
        return time.perf_counter()

    def shown() -> bool:
        return bool(d.execute_script("return window.studio.result"))

    start = fit("one")
    _wait(shown, 300, "the fit")
    alone = time.perf_counter() - start
    tabs, start = [], None
    for i, word in enumerate(("one", "two", "six")):
        if i:
            d.switch_to.new_window("tab")
        pressed = fit(word)
        start = start or pressed
        tabs.append(d.current_window_handle)
    for handle in tabs:
        d.switch_to.window(handle)
        _wait(shown, 300, "three fits")
    return alone, time.perf_counter() - start
