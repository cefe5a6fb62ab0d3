"""The gallery's documentation screenshots, in headless Chromium (:mod:`inkmotion.browser`).

``python -m inkmotion.gallery.browser SITE OUT`` saves ``OUT/index.png`` and
``OUT/detail.png`` of a built gallery (``make gallery`` does).
"""

from __future__ import annotations

import sys
from pathlib import Path

from inkmotion.browser import chromium, full_page_screenshot


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
