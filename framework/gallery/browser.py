"""Headless Chromium for the gallery's browser checks and its documentation screenshots.

The system's Chromium and ChromeDriver (Debian packages ``chromium`` and
``chromium-driver``), driven through Selenium (the ``browser`` or ``test`` extra); never a
browser downloaded by a tool: the driver's path is given, so Selenium Manager is not used.
Chromium starts headless with its background networking off (this machine has no
network) and a fresh profile.

``python -m inkmotion.gallery.browser SITE OUT`` saves ``OUT/index.png`` and
``OUT/detail.png`` of a built gallery (``make gallery`` does).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from inkmotion.errors import ServiceError

CHROMIUM_FLAGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                  "--disable-quic", "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--disable-extensions",
                  "--hide-scrollbars", "--force-device-scale-factor=1")


def find_browser() -> tuple[str, str] | None:
    """(chromium, chromedriver) paths, or None when either is missing."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    return (chromium, driver) if chromium and driver else None


@contextmanager
def chromium(width: int = 1280, height: int = 900) -> Iterator[Any]:
    """A headless Chromium WebDriver with a fresh profile, quit on exit."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        raise ServiceError("Selenium is not installed; install it with "
                           "`pip install 'inkmotion[browser]'`.") from None
    found = find_browser()
    if found is None:
        raise ServiceError("Chromium and ChromeDriver are not installed; install the Debian "
                           "packages: `apt-get install chromium chromium-driver`.")
    binary, driver_path = found
    with tempfile.TemporaryDirectory(prefix="inkmotion-chromium-") as profile:
        options = webdriver.ChromeOptions()
        options.binary_location = binary
        for flag in (*CHROMIUM_FLAGS, f"--user-data-dir={profile}",
                     f"--window-size={width},{height}"):
            options.add_argument(flag)
        driver = webdriver.Chrome(service=Service(executable_path=driver_path),
                                  options=options)
        try:
            yield driver
        finally:
            driver.quit()


def full_page_screenshot(driver: Any, path: Path, max_height: int = 2400) -> None:
    """A PNG of the whole page (up to ``max_height`` px tall) at the window's width."""
    width = driver.get_window_size()["width"]
    height = driver.execute_script("return document.documentElement.scrollHeight")
    driver.set_window_size(width, min(max_height, int(height) + 120))
    path.parent.mkdir(parents=True, exist_ok=True)
    driver.save_screenshot(str(path))


def screenshots(site: Path, out: Path, job: str | None = None) -> list[Path]:
    """Screenshots of the gallery's index and of one job's page (the first card whose id
    starts with ``job``; default the first card), opened from ``file://``; returns their
    paths."""
    index = (site / "index.html").resolve()
    with chromium() as driver:
        driver.get(index.as_uri())
        full_page_screenshot(driver, out / "index.png")
        ids = driver.execute_script(
            "return Array.from(document.querySelectorAll('#cards .card')).map(c => c.dataset.id)")
        if not ids:
            return [out / "index.png"]
        driver.set_window_size(1280, 900)
        chosen = next((i for i in ids if i.startswith(job or "")), ids[0])
        driver.get((site / "jobs" / chosen / "index.html").resolve().as_uri())
        full_page_screenshot(driver, out / "detail.png", max_height=3200)
    return [out / "index.png", out / "detail.png"]


if __name__ == "__main__":  # pragma: no cover - used by `make gallery`
    if len(sys.argv) not in (3, 4):
        sys.exit("usage: python -m inkmotion.gallery.browser SITE OUT [JOB_ID]")
    for p in screenshots(Path(sys.argv[1]), Path(sys.argv[2]),
                         sys.argv[3] if len(sys.argv) == 4 else None):
        print(p)
