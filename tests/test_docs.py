"""The documentation site as a reader meets it (slow tier).

The site is built from the repository into a temporary folder (``make docs``'s command: offline,
warnings as errors, the gallery's examples run), then read: every relative link and anchor of
every page resolves, nothing is fetched from the network, every public name of the package has
its entry in the API reference, and three pages open in headless Chromium with their images
loaded and the search finds ``phi_d_map``.
"""

from __future__ import annotations

import functools
import http.server
import importlib
import os
import pkgutil
import shutil
import subprocess
import sys
import threading
import time
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

import sloshrom

# building the site (the gallery's examples run when changed) takes minutes, more on a loaded
# machine than pytest-timeout's 300 s that the build fixture shares with the first test
pytestmark = [pytest.mark.slow, pytest.mark.timeout(1800)]

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
# the three pages a reader opens first: a class of the API, an example, the command line
NSS_PAGE = "api/sloshrom.rom.NSS.html"
EXAMPLE_PAGE = "auto_examples/plot_01_identify_from_csv.html"
CLI_PAGE = "api/cli.html"


def public_modules() -> list[str]:
    """Every public module of the package (no part of its dotted path starts with ``_``)."""
    names = [m.name for m in pkgutil.walk_packages(sloshrom.__path__, "sloshrom.")]
    return ["sloshrom", *sorted(n for n in names
                                if not any(p.startswith("_") for p in n.split(".")))]


def public_names() -> dict[str, list[str]]:
    """Each public module's ``__all__`` (the modules that have one)."""
    out = {}
    for name in public_modules():
        listed = getattr(importlib.import_module(name), "__all__", None)
        if listed is not None:
            out[name] = list(listed)
    return out


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site built by ``make docs``'s command into a temporary folder."""
    pytest.importorskip("sphinx", reason="Sphinx is not installed (pip install -e '.[docs]')")
    pytest.importorskip("sphinx_gallery", reason="sphinx-gallery is not installed")
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "MPLBACKEND": "Agg"}
    cmd = [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-q",
           "-d", str(out / "doctrees"), str(ROOT / "docs"), str(out / "html")]
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, f"{' '.join(cmd)}\n{proc.stdout[-4000:]}\n{proc.stderr[-8000:]}"
    return out / "html"


class _Page(HTMLParser):
    """The ids of a page and the URLs it refers to (links, images, scripts, style sheets)."""

    def __init__(self) -> None:
        super().__init__()
        self.ids: set[str] = set()
        self.refs: list[tuple[str, str]] = []  # (tag, url)
        self.links: list[tuple[str, str]] = []  # (href, title) of <a>
        self._a: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.ids.add(a["name"])
        for key in ("href", "src"):
            if a.get(key) and tag in ("a", "img", "script", "link", "source", "iframe"):
                self.refs.append((tag, a[key]))
        if tag == "a" and a.get("href"):
            self._a = [a["href"], ""]

    def handle_data(self, data):
        if self._a is not None:
            self._a[1] += data

    def handle_endtag(self, tag):
        if tag == "a" and self._a is not None:
            self.links.append((self._a[0], self._a[1].strip()))
            self._a = None


@functools.cache
def _parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8", errors="replace"))
    return page


def test_no_broken_internal_link_and_nothing_from_the_network(site):
    # the pages (not the theme's templates that it copies into _static/)
    pages = sorted(p for p in site.rglob("*.html") if "_static" not in p.relative_to(site).parts)
    assert len(pages) > 100, len(pages)  # the pages of docs/, the API, the gallery
    broken, remote = [], []
    for page in pages:
        for tag, url in _parse(page).refs:
            parts = urlsplit(url)
            if parts.scheme in ("http", "https") or url.startswith("//"):
                if tag != "a":  # a resource the browser would fetch: the site reads offline
                    remote.append(f"{page.relative_to(site)}: {tag} {url}")
                continue
            if parts.scheme or (not parts.path and not parts.fragment):
                continue  # mailto:, javascript:, data:, an empty link
            target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if target.is_dir():
                target = target / "index.html"
            if not target.is_file():
                broken.append(f"{page.relative_to(site)}: {url} (no file)")
            elif parts.fragment and target.suffix == ".html":
                if unquote(parts.fragment) not in _parse(target).ids:
                    broken.append(f"{page.relative_to(site)}: {url} (no anchor)")
    assert not broken, f"{len(broken)} broken internal links:\n" + "\n".join(broken[:40])
    assert not remote, "resources from the network:\n" + "\n".join(remote[:40])


def test_every_public_name_is_in_the_api_reference(site):
    modules = public_modules()
    missing_pages = [m for m in modules if not (site / "api" / f"{m}.html").is_file()]
    assert not missing_pages, f"public modules without an API page: {missing_pages}"
    missing = []
    names = public_names()
    assert len(names) > 50 and "sloshrom.rom" in names and "NSS" in names["sloshrom.rom"]
    for module, listed in names.items():
        page = site / "api" / f"{module}.html"
        entries = {}
        for href, text in _parse(page).links:
            entries.setdefault(text, href)
        for name in listed:
            href = entries.get(name)
            if href is None or "#" not in href:
                missing.append(f"{module}.{name}")
                continue
            # the entry links to the one place that documents the object in full
            path, fragment = href.split("#", 1)
            target = (page.parent / path).resolve() if path else page
            if not target.is_file() or fragment not in _parse(target).ids \
                    or not fragment.endswith(f".{name}"):
                missing.append(f"{module}.{name} -> {href}")
    total = sum(map(len, names.values()))
    assert not missing, f"{len(missing)} of {total} public names have no entry:\n" + \
        "\n".join(missing[:40])


@pytest.fixture(scope="module")
def browser(site):
    """Headless Chromium (the system's, driven by its chromedriver) and the site's URL."""
    webdriver = pytest.importorskip("selenium.webdriver",
                                    reason="selenium is not installed (the docs extra)")
    if CHROMIUM is None or CHROMEDRIVER is None:
        pytest.skip("Chromium or chromedriver is not installed (apt install chromium "
                    "chromium-driver)")
    handler = functools.partial(_QuietHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    profile = site.parent / "chromium-profile"
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage",
                f"--user-data-dir={profile}"):
        options.add_argument(arg)
    service = webdriver.ChromeService(executable_path=CHROMEDRIVER)
    driver = webdriver.Chrome(options=options, service=service)
    driver.set_page_load_timeout(60)
    try:
        yield driver, f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        driver.quit()
        server.shutdown()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def _wait(driver, script: str, timeout: float = 60.0):
    """Poll ``script`` in the page until it returns a true value (or fail with its last)."""
    end = time.monotonic() + timeout
    value = None
    while time.monotonic() < end:
        value = driver.execute_script(script)
        if value:
            return value
        time.sleep(0.25)
    raise AssertionError(f"timed out waiting for: {script} (last: {value!r})")


IMAGES = """
const imgs = Array.from(document.images);
if (!imgs.every(i => i.complete)) return null;
return imgs.map(i => [i.currentSrc || i.src, i.naturalWidth]);
"""


@pytest.mark.parametrize("page, text, least_images", [
    (NSS_PAGE, "sloshrom.rom.NSS", 0),
    (EXAMPLE_PAGE, "Identify a ROM from your own shaker record", 2),
    (CLI_PAGE, "sloshrom train", 0),
])
def test_a_page_opens_with_its_images(browser, page, text, least_images):
    driver, base = browser
    driver.get(f"{base}/{page}")
    _wait(driver, "return document.readyState === 'complete'")
    assert text in driver.find_element("tag name", "body").text
    images = _wait(driver, IMAGES) if least_images else driver.execute_script(
        "return Array.from(document.images).map(i => [i.currentSrc || i.src, i.naturalWidth]);")
    broken = [src for src, width in images if not width]
    assert not broken, f"{page}: images that did not load: {broken}"
    assert len(images) >= least_images, images
    if page == NSS_PAGE:  # the class, its fit and predict, documented on its page
        ids = driver.execute_script(
            "return Array.from(document.querySelectorAll('dt[id]')).map(e => e.id);")
        assert {"sloshrom.rom.NSS", "sloshrom.rom.NSS.fit", "sloshrom.rom.NSS.predict"} \
            <= set(ids), ids


def test_the_search_finds_phi_d_map(browser):
    driver, base = browser
    driver.get(f"{base}/search.html?q=phi_d_map")
    hits = _wait(driver, """
        const links = Array.from(document.querySelectorAll('#search-results ul.search li a'));
        return links.length ? links.map(a => [a.textContent, a.getAttribute('href')]) : null;
    """)
    assert any("phi_d_map" in text and "sloshrom.energy" in href for text, href in hits), hits
