"""The built gallery in a real browser: headless Chromium (Debian's chromium and
chromium-driver, installed by ``make test``) through Selenium, from ``file://`` and from a
static server; it checks the cards, the filters, a detail page, its images and download
links, and saves screenshots."""

from __future__ import annotations

import functools
import http.server
import threading
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import unquote, urlparse

import cv2
import pytest

from inkmotion.browser import chromium, find_browser, full_page_screenshot
from inkmotion.gallery import build_gallery, collect

pytest.importorskip("selenium", reason="Selenium is not installed (the test extra)")
if find_browser() is None:
    pytest.skip("Chromium and ChromeDriver are not installed (apt-get install chromium "
                "chromium-driver; make test does)", allow_module_level=True)

from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import Select, WebDriverWait  # noqa: E402


@pytest.fixture(scope="module")
def site(gallery_jobs, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("browser") / "site"
    build_gallery(collect(folders=[gallery_jobs.results], db_url=gallery_jobs.db_url), out)
    return out


@pytest.fixture(scope="module")
def browser() -> Iterator[object]:
    with chromium() as driver:
        yield driver


@pytest.fixture(scope="module")
def server(site) -> Iterator[str]:
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(site))
    handler.log_message = lambda *a, **k: None  # type: ignore[attr-defined]
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}/"
    httpd.shutdown()
    httpd.server_close()


def visible_cards(driver) -> list[str]:
    return [c.get_attribute("data-id")
            for c in driver.find_elements(By.CSS_SELECTOR, "#cards .card") if c.is_displayed()]


def count_text(driver) -> str:
    return driver.find_element(By.ID, "shown-count").text


def wait_images_loaded(driver) -> list[dict]:
    """Every <img> of the page once loaded: its src and natural width (0: broken)."""
    script = ("return Array.from(document.images).map(i => "
              "({src: i.getAttribute('src'), complete: i.complete, width: i.naturalWidth}))")
    for img in driver.find_elements(By.TAG_NAME, "img"):  # lazy images load when in view
        driver.execute_script("arguments[0].scrollIntoView()", img)
    WebDriverWait(driver, 15).until(
        lambda d: all(i["complete"] for i in d.execute_script(script)))
    return driver.execute_script(script)


def test_cards_and_filters(browser, site):
    browser.get((site / "index.html").as_uri())
    assert len(visible_cards(browser)) == 8 and count_text(browser) == "8 of 8 jobs"
    assert all(i["width"] > 0 for i in wait_images_loaded(browser))

    kind = Select(browser.find_element(By.ID, "filter-kind"))
    status = Select(browser.find_element(By.ID, "filter-status"))
    text = browser.find_element(By.ID, "filter-text")
    assert [o.text for o in kind.options] == ["all kinds", "evaluate", "fit", "simulate"]

    kind.select_by_value("evaluate")
    shown = visible_cards(browser)
    assert len(shown) == 1 and count_text(browser) == "1 of 8 jobs"
    assert browser.find_element(By.CSS_SELECTOR, f'[data-id="{shown[0]}"] .kind').text == \
        "EVALUATE"
    assert "kind=evaluate" in browser.current_url

    kind.select_by_value("")
    status.select_by_value("failed")
    assert len(visible_cards(browser)) == 1
    status.select_by_value("")
    text.send_keys("running word")
    assert len(visible_cards(browser)) == 1 and count_text(browser) == "1 of 8 jobs"
    text.clear()
    text.send_keys("steps=8 hi")  # every word must match: the search covers parameters
    assert 1 <= len(visible_cards(browser)) < 8
    text.clear()
    text.send_keys("nothing-is-called-this")
    assert visible_cards(browser) == []
    assert browser.find_element(By.ID, "no-match").is_displayed()

    # a filtered view is an address: opened again, it shows the same cards
    browser.get((site / "index.html").as_uri() + "#kind=simulate&status=succeeded")
    assert Select(browser.find_element(By.ID, "filter-kind")).first_selected_option.text == \
        "simulate"
    assert len(visible_cards(browser)) == 1


def open_fit_page(driver, site: Path) -> None:
    driver.get((site / "index.html").as_uri())
    Select(driver.find_element(By.ID, "filter-kind")).select_by_value("fit")
    Select(driver.find_element(By.ID, "filter-status")).select_by_value("succeeded")
    card = next(c for c in driver.find_elements(By.CSS_SELECTOR, "#cards .card")
                if c.is_displayed() and c.get_attribute("data-id").startswith("run-"))
    card.find_element(By.CSS_SELECTOR, "h2 a").click()
    WebDriverWait(driver, 10).until(lambda d: d.find_elements(By.TAG_NAME, "h1"))


def test_detail_page_from_file_url(browser, site, gallery_jobs):
    open_fit_page(browser, site)
    assert browser.find_element(By.TAG_NAME, "h1").text == "text:hi"
    images = wait_images_loaded(browser)
    assert {"files/drawing.svg", "files/overlay.png", "files/speed.png",
            "files/spray.png"} <= {i["src"] for i in images}
    assert all(i["width"] > 0 for i in images), images
    links = browser.find_elements(By.CSS_SELECTOR, "#downloads a")
    names = [a.text for a in links]
    assert names[:4] == ["drawing.svg", "plan.json", "trajectory.csv", "recording.rrd"]
    for a in links:
        path = Path(unquote(urlparse(a.get_attribute("href")).path))
        assert path.read_bytes() == (gallery_jobs.fit / a.text).read_bytes()
    command = browser.find_element(By.ID, "command-reproduce").text
    assert command.startswith("inkmotion run --config ") and "job.json" in command
    browser.find_element(By.LINK_TEXT, "← all jobs").click()
    WebDriverWait(browser, 10).until(lambda d: d.find_elements(By.ID, "cards"))


def test_detail_page_behind_a_static_server(browser, server, site):
    browser.get(server + "index.html")
    assert len(visible_cards(browser)) == 8
    open_fit_page(browser, site)  # from file://: find the page, then open it over http
    page = browser.current_url.split("/jobs/", 1)[1]
    browser.get(server + "jobs/" + page)
    assert all(i["width"] > 0 for i in wait_images_loaded(browser))
    statuses = browser.execute_async_script("""
        const done = arguments[arguments.length - 1];
        const links = Array.from(document.querySelectorAll('#downloads a'));
        Promise.all(links.map(a => fetch(a.href).then(r => r.blob().then(b =>
            [a.textContent, r.status, b.size])))).then(done);
    """)
    folder = site / "jobs" / page.split("/")[0] / "files"
    assert len(statuses) >= 6
    for name, code, size in statuses:
        assert code == 200 and size == (folder / name).stat().st_size, name


def test_screenshots(browser, site, tmp_path):
    browser.set_window_size(1280, 900)
    browser.get((site / "index.html").as_uri())
    wait_images_loaded(browser)
    full_page_screenshot(browser, tmp_path / "index.png")
    open_fit_page(browser, site)
    wait_images_loaded(browser)
    full_page_screenshot(browser, tmp_path / "detail.png")
    for name in ("index.png", "detail.png"):
        shot = cv2.imread(str(tmp_path / name))
        assert shot is not None and shot.shape[1] == 1280 and shot.shape[0] >= 600
        assert shot.std() > 10  # a page with content, not a blank window
