"""The documentation site, served on 127.0.0.1 and opened in headless Chromium (the system's, driven by
Playwright): every page loads without a console error, a failed or off-machine request, or a broken image; every
internal link and anchor resolves; MathJax typesets every formula; every interactive figure draws (a screenshot of
its plot area is not blank). A few screenshots are kept in ``GEOMECH_SCREENSHOTS``.

Run by ``make test-browser`` (after ``make docs``); ``GEOMECH_SITE`` is the built site, ``CHROMIUM`` the browser
(default: ``chromium`` on the PATH).
"""

from __future__ import annotations

import functools
import http.server
import io
import os
import shutil
import threading
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import numpy as np
import pytest
from PIL import Image

SITE = Path(os.environ.get("GEOMECH_SITE", "docs/_build/html")).resolve()
SHOTS = Path(os.environ["GEOMECH_SCREENSHOTS"]) if os.environ.get("GEOMECH_SCREENSHOTS") else None
PAGES = sorted(
    p.relative_to(SITE).as_posix() for p in SITE.rglob("*.html") if not p.relative_to(SITE).parts[0].startswith("_")
)
# Kept as pictures of the build: the landing page, a tutorial, the gallery, a page with an interactive figure.
SHOWN = {
    "index.html": "landing",
    "auto_tutorials/serret_andoyer_spacecraft.html": "tutorial",
    "auto_examples/index.html": "gallery",
    "auto_examples/rotor_stability_map.html": "interactive",
}
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


class _Links(HTMLParser):
    """The ids a page defines and the links it makes (href and src)."""

    def __init__(self) -> None:
        super().__init__()
        self.ids: set[str] = set()
        self.links: list[str] = []

    def handle_starttag(self, tag: str, attrs: list) -> None:
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.ids.add(a["name"])
        for key in ("href", "src"):
            if a.get(key) and tag in ("a", "img", "script", "link", "iframe"):
                self.links.append(a[key])


@functools.cache
def _parsed(page: str) -> _Links:
    parser = _Links()
    parser.feed((SITE / page).read_text(encoding="utf-8"))
    return parser


def test_the_site_has_its_parts():
    assert (SITE / "index.html").exists(), f"no site at {SITE}: run `make docs`"
    names = set(PAGES)
    assert {"index.html", "auto_examples/index.html", "auto_tutorials/index.html", "api/index.html"} <= names
    assert sum(p.startswith("auto_examples/") for p in names) >= 13  # the gallery: index + every example
    assert sum(p.startswith("api/generated/") for p in names) > 200  # a page per public name


def test_every_internal_link_and_anchor_resolves():
    broken = []
    for page in PAGES:
        for link in _parsed(page).links:
            parts = urlsplit(link)
            if parts.scheme in ("http", "https", "mailto", "data", "javascript") or link.startswith("//"):
                continue
            path, anchor = parts.path, parts.fragment  # without the query (?v=...) of static files
            target = (SITE / page).parent / unquote(path) if path else SITE / page
            target = target.resolve()
            if target.is_dir():
                target = target / "index.html"
            if not target.exists() or SITE not in target.parents:
                broken.append(f"{page}: {link}")
            elif anchor and target.suffix == ".html":
                if unquote(anchor) not in _parsed(target.relative_to(SITE).as_posix()).ids:
                    broken.append(f"{page}: {link} (no such anchor)")
    assert not broken, f"{len(broken)} broken links, e.g. {broken[:10]}"


@pytest.fixture(scope="module")
def server():
    handler = functools.partial(_QuietHandler, directory=str(SITE))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args) -> None:  # noqa: A002
        pass


@pytest.fixture(scope="module")
def browser():
    playwright = pytest.importorskip("playwright.sync_api")
    executable = os.environ.get("CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    assert executable, "no Chromium: `make test-browser` installs it from the system's package manager"
    with playwright.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=executable, args=FLAGS)
        context = chromium.new_context(viewport={"width": 1280, "height": 900})  # one cache for every page
        yield context
        context.close()
        chromium.close()


def _not_blank(png: bytes) -> tuple[int, float]:
    """Distinct colours, and the fraction of pixels that differ from the most common one (the background)."""
    pixels = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).reshape(-1, 3)
    colours, counts = np.unique(pixels, axis=0, return_counts=True)
    return len(colours), 1.0 - counts.max() / counts.sum()


def _open(context, server: str, page: str):
    tab = context.new_page()
    problems: list[str] = []
    tab.on("console", lambda msg: problems.append(f"console {msg.type}: {msg.text}") if msg.type == "error" else None)
    tab.on("pageerror", lambda exc: problems.append(f"page error: {exc}"))
    tab.on("requestfailed", lambda req: problems.append(f"request failed: {req.url} ({req.failure})"))
    tab.on("response", lambda r: problems.append(f"HTTP {r.status}: {r.url}") if r.status >= 400 else None)

    def local_only(request) -> None:  # observed, not routed: routing would turn the browser's cache off
        if urlsplit(request.url).scheme in ("http", "https") and urlsplit(request.url).hostname != "127.0.0.1":
            problems.append(f"off-machine request: {request.url}")

    tab.on("request", local_only)
    tab.goto(f"{server}/{page}", wait_until="load")
    return tab, problems


@pytest.mark.parametrize("page", PAGES)
def test_page_loads_cleanly(browser, server, page):
    tab, problems = _open(browser, server, page)
    try:
        if tab.locator(".math").count():  # MathJax typesets every formula of the page
            tab.wait_for_function(
                "() => document.querySelectorAll('.math').length <= document.querySelectorAll('mjx-container').length",
                timeout=20_000,
            )
        broken = tab.evaluate(
            "() => [...document.images].filter(i => !i.complete || i.naturalWidth === 0).map(i => i.src)"
        )
        assert not broken, f"{page}: images that did not load: {broken}"
        figures = tab.locator(".plotly-graph-div")
        for i in range(figures.count()):
            figure = figures.nth(i)
            figure.scroll_into_view_if_needed()
            figure.locator(".main-svg").first.wait_for(timeout=20_000)
            colours, drawn = _not_blank(figure.screenshot())
            assert colours > 50 and drawn > 0.05, f"{page}: interactive figure {i} looks blank ({colours}, {drawn})"
        if SHOTS is not None and page in SHOWN:
            SHOTS.mkdir(parents=True, exist_ok=True)
            target = figures.first if SHOWN[page] == "interactive" and figures.count() else tab
            target.screenshot(path=str(SHOTS / f"{SHOWN[page]}.png"))
        tab.wait_for_timeout(100)  # errors raised by scripts that run after load
        assert not problems, f"{page}: {problems[:5]}"
    finally:
        tab.close()
