"""Check pages of the built documentation site in a real headless browser and take their
screenshots.

The site is served over HTTP from a local port (as a reader's browser would get it) and
each page is opened in headless Chromium through Playwright.  A page fails when the
browser reports a console error or an uncaught exception, a request of the page answers
4xx/5xx, an image does not load (lazy images are loaded first), or its rendered text
shows a raw Sphinx role (``:class:`…```), HTML markup (an attribute broken by a quote) or an
unexpanded ``{{ ehsa-opt-… }}`` line.
A full-page screenshot of each page goes to ``--shots``.

    pip install ".[docs]"                      # mkdocs, and playwright (the Python package)
    mkdocs build --strict
    python tools/browser_check.py site --shots site-shots
    python tools/browser_check.py site --pages index.html gallery/index.html

The browser: ``--browser PATH`` or ``$EHSA_BROWSER``, else Playwright's own Chromium
(``python -m playwright install chromium``, which downloads it), else a system Chromium on
``PATH`` (e.g. Debian's ``chromium-headless-shell`` or ``chromium`` package).  Exit 0: every
page clean; 1: problems (listed); 2: no site, no playwright or no browser (the message
says which and how to get it).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import http.server
import os
import re
import shutil
import sys
import threading
from pathlib import Path
from typing import Iterator, Sequence

#: The pages checked by default (relative to the site): the home page, the tutorial, the
#: gallery, the API reference and one guide page.
DEFAULT_PAGES = ("index.html", "tutorial/index.html", "gallery/index.html",
                 "api/index.html", "guide/identify/index.html")

#: A Sphinx/numpydoc role left as text in the rendered page.
RAW_ROLE_TEXT = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|obj|exc|const|ref):"
                           r"[`~\w]")
#: A docs-hook line left unexpanded.
RAW_HOOK_TEXT = re.compile(r"\{\{ ehsa-opt-[a-z]+")
#: HTML markup shown as text (an attribute value with an unescaped quote ended early).
MARKUP_TEXT = re.compile(r'" (?:href|class|title)="')

#: System browsers tried after Playwright's own, in order.
SYSTEM_BROWSERS = ("chromium-headless-shell", "chromium", "chromium-browser",
                   "google-chrome", "google-chrome-stable")

#: How long a page may take to load and settle, ms.
PAGE_TIMEOUT_MS = 30_000


class NoBrowser(RuntimeError):
    """No way to run a headless browser here; the message says what to install."""


def text_problems(text: str) -> list[str]:
    """The raw roles and unexpanded hook lines in a page's rendered text."""
    found = [f"raw role {m.group()!r} in {text[max(0, m.start() - 30):m.end() + 30]!r}"
             for m in RAW_ROLE_TEXT.finditer(text)]
    found += [f"HTML markup as text: {text[max(0, m.start() - 40):m.end() + 20]!r}"
              for m in MARKUP_TEXT.finditer(text)]
    return found + [f"unexpanded {m.group()!r}" for m in RAW_HOOK_TEXT.finditer(text)]


def page_paths(site: Path, pages: Sequence[str]) -> list[str]:
    """The pages to open (relative POSIX paths); a page the site does not have is an
    error naming it."""
    missing = [p for p in pages if not (site / p).is_file()]
    if missing:
        raise FileNotFoundError(f"{site}: no page {', '.join(missing)} (build the site with "
                                f"`mkdocs build`, or give pages that exist)")
    return [Path(p).as_posix() for p in pages]


def find_browser(explicit: str | None = None) -> str | None:
    """The browser executable: ``explicit``, ``$EHSA_BROWSER``, else None (Playwright's
    own Chromium) when it is installed, else the first system browser on ``PATH``.

    Raises
    ------
    NoBrowser
        An explicit path that does not exist, or no browser at all.
    """
    explicit = explicit or os.environ.get("EHSA_BROWSER") or None
    if explicit:
        if not Path(explicit).is_file() and shutil.which(explicit) is None:
            raise NoBrowser(f"browser {explicit!r} not found")
        return shutil.which(explicit) or explicit
    if _playwright_chromium():
        return None
    for name in SYSTEM_BROWSERS:
        if (path := shutil.which(name)):
            return path
    raise NoBrowser("no headless browser: run `python -m playwright install chromium` "
                    "(downloads Chromium), or install a system one (Debian: `apt-get install "
                    "chromium-headless-shell`), or give --browser PATH")


def _playwright_chromium() -> bool:
    """Playwright's own Chromium is downloaded."""
    root = Path(os.environ.get("PLAYWRIGHT_BROWSERS_PATH")
                or Path.home() / ".cache" / "ms-playwright")
    return root.is_dir() and any(root.glob("chromium*/chrome-linux*/chrome*"))


@contextlib.contextmanager
def serve(site: Path) -> Iterator[str]:
    """Serve ``site`` over HTTP on a free local port; yields the base URL."""
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args: object) -> None:
            pass
    handler = functools.partial(Quiet, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()


_LOAD_IMAGES = """async () => {
  const imgs = Array.from(document.images);
  imgs.forEach(i => { i.loading = "eager"; });
  await Promise.all(imgs.map(i => i.complete ? null : new Promise(r => {
      i.addEventListener("load", r); i.addEventListener("error", r); })));
  return imgs.filter(i => i.naturalWidth === 0).map(i => i.getAttribute("src"));
}"""


def check_pages(site: Path, pages: Sequence[str], shots: Path | None,
                browser: str | None) -> list[str]:
    """Open every page of ``pages`` in headless Chromium; the problems found (empty: all
    clean).  Screenshots (full page, PNG) into ``shots`` when given."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        raise NoBrowser("playwright is not installed: pip install playwright (or "
                        "pip install '.[docs]')") from None
    problems: list[str] = []
    if shots is not None:
        shots.mkdir(parents=True, exist_ok=True)
    with serve(site) as base, sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=browser, args=["--no-sandbox"])
        try:
            for rel in page_paths(site, pages):
                problems += [f"{rel}: {p}" for p in _check_page(b, base + rel, rel, shots)]
        finally:
            b.close()
    return problems


def _check_page(browser: object, url: str, rel: str, shots: Path | None) -> list[str]:
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    found: list[str] = []
    page.on("console", lambda m: found.append(f"console {m.type}: {m.text}")
            if m.type == "error" else None)
    page.on("pageerror", lambda e: found.append(f"uncaught exception: {e}"))
    page.on("response", lambda r: found.append(f"HTTP {r.status}: {r.url}")
            if r.status >= 400 else None)
    page.on("requestfailed", lambda r: found.append(f"request failed: {r.url} ({r.failure})"))
    try:
        page.goto(url, wait_until="load", timeout=PAGE_TIMEOUT_MS)
        found += [f"image does not load: {src}" for src in page.evaluate(_LOAD_IMAGES)]
        page.wait_for_load_state("networkidle", timeout=PAGE_TIMEOUT_MS)
        found += text_problems(page.inner_text("body"))
        if shots is not None:
            page.screenshot(path=str(shots / (rel.replace("/", "_")[:-5] + ".png")),
                            full_page=True)
    finally:
        page.close()
    return found


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("site", nargs="?", default="site", help="the built site (default site)")
    ap.add_argument("--pages", nargs="+", default=list(DEFAULT_PAGES),
                    help="pages to open, relative to the site")
    ap.add_argument("--shots", default=None, help="folder for the screenshots")
    ap.add_argument("--browser", default=None, help="Chromium executable (default: "
                    "$EHSA_BROWSER, Playwright's Chromium, a system Chromium)")
    args = ap.parse_args(argv)
    site = Path(args.site)
    if not (site / "index.html").is_file():
        print(f"{site}: no built site (run mkdocs build first)", file=sys.stderr)
        return 2
    try:
        page_paths(site, args.pages)
        browser = find_browser(args.browser)
        problems = check_pages(site.resolve(), args.pages,
                               None if args.shots is None else Path(args.shots), browser)
    except (NoBrowser, FileNotFoundError) as exc:
        print(f"browser check not run: {exc}", file=sys.stderr)
        return 2
    for p in problems:
        print(p)
    print(f"{site}: {len(args.pages)} page(s) opened in headless Chromium "
          f"({browser or 'Playwright'}), {len(problems)} problem(s)"
          + (f"; screenshots in {args.shots}" if args.shots else ""), file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
