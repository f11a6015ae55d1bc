"""A real headless browser for the tests that open what calibrax writes for people to read: Debian's
Chromium driven through its ChromeDriver by Selenium (``make setup`` installs the packages
``chromium`` and ``chromium-driver``). A missing browser fails the test with the fix; it never skips."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import pytest

CHROMIUM = ("chromium", "chromium-browser")
CHROMEDRIVER = "chromedriver"
#: how long a page may take to load its images (s)
LOAD_TIMEOUT_S = 60
#: Chromium's flags for a machine with no screen and no network (its background services would
#: otherwise try to reach Google's hosts at every start)
FLAGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--disable-quic",
         "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-extensions", "--window-size=1280,1024")
#: every image of the page: its address' scheme, whether it finished loading and its decoded size (px)
IMAGES_JS = ("return Array.from(document.images).map(i => ({scheme: i.currentSrc.split(':')[0], "
             "complete: i.complete, width: i.naturalWidth, height: i.naturalHeight, alt: i.alt}));")


def _binary(names: tuple[str, ...] | str) -> str:
    for name in (names,) if isinstance(names, str) else names:
        found = shutil.which(name)
        if found:
            return found
    pytest.fail(f"no {names} on PATH: install Debian's chromium and chromium-driver (make setup does)")


def page_images(page: Path) -> list[dict]:
    """Open ``page`` (a local HTML file) in headless Chromium, wait until it has loaded, and return
    its images as {scheme, complete, width, height, alt}; an image that failed to load has width 0."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.support.ui import WebDriverWait

    options = webdriver.ChromeOptions()
    options.binary_location = _binary(CHROMIUM)
    for flag in FLAGS:
        options.add_argument(flag)
    with tempfile.TemporaryDirectory(prefix="calibrax-chromium-") as profile:
        options.add_argument(f"--user-data-dir={profile}")
        driver = webdriver.Chrome(service=Service(executable_path=_binary(CHROMEDRIVER)), options=options)
        try:
            driver.set_page_load_timeout(LOAD_TIMEOUT_S)
            driver.get(Path(page).resolve().as_uri())
            WebDriverWait(driver, LOAD_TIMEOUT_S).until(
                lambda d: d.execute_script("return document.readyState") == "complete"
                and all(i["complete"] for i in d.execute_script(IMAGES_JS)))
            return driver.execute_script(IMAGES_JS)
        finally:
            driver.quit()
