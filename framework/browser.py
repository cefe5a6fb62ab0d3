"""Headless Chromium for the browser checks: the gallery's tests and screenshots, the
studio's tests and its benchmark.

The system's Chromium and ChromeDriver (Debian packages ``chromium`` and
``chromium-driver``), driven through Selenium (the ``browser`` or ``test`` extra); never a
browser downloaded by a tool: the driver's path is given, so Selenium Manager is not used.
Chromium starts headless with its background networking off (this machine has no
network) and a fresh profile.
"""

from __future__ import annotations

import shutil
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
