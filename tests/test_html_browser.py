"""The pages of ``check --html`` and ``fuzz --html`` in a real browser: headless Chromium (Debian's ``chromium`` and
``chromium-driver``, driven by Selenium) loads each with no console error, shows the verdict and the failing
limit in the summary, and decodes every image. A screenshot of each is kept in ``out/test-artifacts/html``."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from html_pages import ROOT

SCREENSHOTS = ROOT / "out" / "test-artifacts" / "html"
CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
)


@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    """Headless Chromium under chromedriver, with a fresh profile; skipped where either is not installed."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver_path = shutil.which("chromedriver")
    if chromium is None or driver_path is None:
        pytest.skip(
            "headless Chromium not found: the browser test needs Debian's chromium and chromium-driver "
            "(apt-get install chromium chromium-driver)"
        )
    webdriver = pytest.importorskip("selenium.webdriver", reason="the browser test needs selenium (the test extra)")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={tmp_path_factory.mktemp('chromium-profile')}")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(executable_path=driver_path), options=options)
    try:
        yield driver
    finally:
        driver.quit()


@pytest.mark.parametrize(
    ("name", "verdict", "in_summary"),
    [
        ("failing.html", "FAIL", "tracking_error_max_m"),
        ("passing.html", "PASS", "every limit held"),
        ("fuzz.html", "FAIL", "cross_track_error_max_m"),
    ],
)
def test_the_page_loads_in_chromium_without_errors_and_every_image_decodes(
    browser: Any, pages: dict[str, Any], name: str, verdict: str, in_summary: str
) -> None:
    from selenium.webdriver.common.by import By

    page: Path = pages["dir"] / name
    browser.set_window_size(1200, 1000)
    browser.get(page.as_uri())
    errors = [entry for entry in browser.get_log("browser") if entry["level"] == "SEVERE"]
    assert errors == []
    assert browser.find_element(By.ID, "verdict").text == verdict
    assert in_summary in browser.find_element(By.ID, "summary").text
    images = browser.execute_script(
        "return Array.from(document.images, i => [i.complete, i.naturalWidth, i.naturalHeight]);"
    )
    assert images and all(done and width > 0 and height > 0 for done, width, height in images), images
    height = browser.execute_script("return document.documentElement.scrollHeight;")
    browser.set_window_size(1200, min(int(height), 12000))
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    shot = SCREENSHOTS / name.replace(".html", ".png")
    assert browser.save_screenshot(str(shot))
    print(f"screenshot of {name}: {shot}")
