"""Check a built documentation site: no raw Sphinx/numpydoc role (``:class:`…```) left as
text, no unexpanded ``{{ ehsa-opt-help … }}`` or ``{{ ehsa-opt-gallery }}`` line, no broken
internal link (the file and, when given, the anchor exist) and no missing image.

    python tools/check_site.py site          # exit 1 and the offenders, else a summary
"""

from __future__ import annotations

import re
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

#: A role left as text, as the Markdown renderer leaves it.
RAW_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|obj|exc|const|ref):"
                      r"(?:<code>|`|&lt;code&gt;)")


#: HTML markup in a page's text: an attribute value with an unescaped quote ended early.
MARKUP_AS_TEXT = re.compile(r'" (?:href|class|title)="')


class _Page(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.ids: set[str] = set()
        self.hrefs: list[str] = []
        self.images: list[str] = []
        self.leaks: list[str] = []

    def handle_data(self, data: str) -> None:
        if MARKUP_AS_TEXT.search(data):  # an attribute broken by a quote: markup as text
            self.leaks.append(data.strip()[:80])

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        for key, value in attrs:
            if key in ("id", "name") and value:
                self.ids.add(value)
            if tag == "a" and key == "href" and value:
                self.hrefs.append(value)
            if tag == "img" and key == "src" and value:
                self.images.append(value)


def check_site(site: Path) -> list[str]:
    """The problems of the site in ``site`` (empty when it is clean)."""
    problems: list[str] = []
    pages: dict[Path, _Page] = {}
    for path in sorted(site.rglob("*.html")):
        text = path.read_text(encoding="utf-8")
        for m in RAW_ROLE.finditer(text):
            problems.append(f"{path.relative_to(site)}: raw role "
                            f"{text[m.start():m.end() + 40]!r}")
        for marker in ("{{ ehsa-opt-help", "{{ ehsa-opt-gallery"):
            if marker in text:
                problems.append(f"{path.relative_to(site)}: unexpanded {marker[3:]} line")
        parser = _Page()
        parser.feed(text)
        problems += [f"{path.relative_to(site)}: HTML markup shown as text: {leak!r}"
                     for leak in parser.leaks]
        pages[path.resolve()] = parser
    index = site / "search" / "search_index.json"
    if index.is_file():
        for m in RAW_ROLE.finditer(index.read_text(encoding="utf-8")):
            problems.append(f"search index: raw role {m.group()!r}")
    for path, page in pages.items():
        for src in page.images:
            parts = urlsplit(src)
            if parts.scheme or parts.netloc or src.startswith("data:"):
                continue
            base = site if parts.path.startswith("/") else path.parent
            if not (base / unquote(parts.path).lstrip("/")).resolve().is_file():
                problems.append(f"{path.relative_to(site.resolve())}: missing image {src}")
        for href in page.hrefs:
            parts = urlsplit(href)
            if parts.scheme or parts.netloc or href.startswith("mailto:"):
                continue  # external
            base = site if parts.path.startswith("/") else path.parent  # 404.html: root-based
            target = path if not parts.path else (base / unquote(parts.path).lstrip("/")
                                                  ).resolve()
            if target.is_dir():
                target = target / "index.html"
            if not target.exists():
                problems.append(f"{path.relative_to(site.resolve())}: broken link {href}")
                continue
            if parts.fragment and target in pages and parts.fragment not in pages[target].ids:
                problems.append(f"{path.relative_to(site.resolve())}: missing anchor {href}")
    return problems


def main(argv: list[str]) -> int:
    site = Path(argv[0] if argv else "site")
    if not (site / "index.html").is_file():
        print(f"{site}: no built site (run mkdocs build first)", file=sys.stderr)
        return 2
    problems = check_site(site.resolve())
    for p in problems:
        print(p)
    n = len(list(site.rglob("*.html")))
    print(f"{site}: {n} pages, {len(problems)} problem(s)", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
