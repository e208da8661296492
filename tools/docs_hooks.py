"""MkDocs hooks of the documentation site (``hooks:`` in mkdocs.yml).

Cross-references
    The docstrings use numpydoc/Sphinx roles (``:class:`~ehsa_opt.design.problem.DesignProblem```,
    ``:func:``, ``:meth:``, ``:mod:``, ``:data:``, ``:attr:`` …), which the Markdown renderer
    leaves as raw text.  :func:`on_page_content` turns each into a marked ``<code>`` (the
    ``~`` form shows the last name only, a leading ``.`` is relative) and records the API
    anchors of the page; :func:`on_post_build` links every marked name to the page that
    documents it (exact id, else the unique documented object whose dotted name ends with
    it, preferring the same page).  Names the site does not document (pymoo, numpy, private
    helpers) stay code, without a link.  ``tools/check_site.py`` verifies that the built site
    has no raw role left.

Version and licence
    :func:`on_config` puts the package's version (from ``ehsa_opt/utils/version.py``) and
    its licence in the site's footer, and the repository link when ``pyproject.toml`` names
    one (``[project.urls] Repository``).

Command help
    A line ``{{ ehsa-opt-help bench generate }}`` in a page becomes a console block with
    ``ehsa-opt bench generate --help`` as the code prints it (100 columns), so the
    documented options are always the real ones.

Gallery
    :func:`on_files` adds the figures of the committed reference report
    (``results/reference``) to the site under ``gallery/``, and the line
    ``{{ ehsa-opt-gallery }}`` becomes the gallery of ``tools/gallery.py`` (a caption per
    figure); a report figure without caption, or a caption without its file, fails the
    build.
"""

from __future__ import annotations

import contextlib
import html
import io
import os
import re
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]

#: The roles converted (Sphinx Python domain and numpydoc).
ROLES = ("class", "func", "meth", "mod", "data", "attr", "obj", "exc", "const", "ref",
         "py:class", "py:func", "py:meth", "py:mod", "py:data", "py:attr", "py:obj",
         "py:exc", "py:const")
_ROLE = re.compile(r":(?:%s):<code>([^<]+)</code>" % "|".join(re.escape(r) for r in ROLES))
_XREF = re.compile(r'<code class="xref" data-xref="([^"]+)">([^<]*)</code>')
_ANCHOR = re.compile(r'id="(ehsa_opt(?:\.[A-Za-z_][A-Za-z0-9_]*)*)"')
_HELP = re.compile(r"^\{\{ ehsa-opt-help ([a-z -]*?) ?\}\}$", re.MULTILINE)
_GALLERY = re.compile(r"^\{\{ ehsa-opt-gallery \}\}$", re.MULTILINE)

_anchors: dict[str, str] = {}  # documented dotted name -> page url


def on_config(config: Any) -> Any:
    """Version, licence and (when known) repository of the site."""
    import tomllib
    text = (ROOT / "ehsa_opt" / "utils" / "version.py").read_text(encoding="utf-8")
    version = re.search(r'__version__ = "([^"]+)"', text).group(1)
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    licence = project.get("license", {}).get("text", "")
    config["copyright"] = (f"ehsa_opt {version}" + (f" · {licence} licence" if licence else "")
                           + " · cite with CITATION.cff")
    repo = project.get("urls", {}).get("Repository")
    if repo and not config.get("repo_url"):
        config["repo_url"] = repo
    return config


def _mark(match: re.Match) -> str:
    target = html.unescape(match.group(1)).strip()
    shown = target.lstrip("~")
    if target.startswith("~"):
        shown = shown.rstrip("()").split(".")[-1] + ("()" if shown.endswith("()") else "")
    shown = shown.lstrip(".")
    return (f'<code class="xref" data-xref="{html.escape(target.lstrip("~"), quote=True)}">'
            f"{html.escape(shown)}</code>")


def _gallery() -> Any:
    import importlib.util
    spec = importlib.util.spec_from_file_location("ehsa_opt_gallery", ROOT / "tools" / "gallery.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def on_files(files: Any, config: Any) -> Any:
    """Add the reference report's figures to the site (``gallery/…``); refuse a figure
    without caption."""
    from mkdocs.structure.files import File
    gallery = _gallery()
    problems = gallery.check()
    if problems:
        raise ValueError("gallery (tools/gallery.py):\n" + "\n".join(problems))
    for figs in gallery.FIGURES.values():
        for f in figs:
            files.append(File.generated(config, f"{gallery.SITE_DIR}/{f.path}",
                                        abs_src_path=str(gallery.REFERENCE / f.path)))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """Expand the ``{{ ehsa-opt-help COMMAND }}`` lines and ``{{ ehsa-opt-gallery }}``."""
    if _GALLERY.search(markdown):
        depth = page.file.src_uri.count("/")
        up = "../" * depth
        text = _gallery().markdown(image_prefix=up + "gallery/", guide_prefix=up)
        markdown = _GALLERY.sub(lambda m: text, markdown)
    return _HELP.sub(lambda m: command_help(m.group(1).split()), markdown)


def command_help(command: list[str]) -> str:
    """A console block with ``ehsa-opt COMMAND --help`` as the code prints it."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from ehsa_opt.cli import main
    out = io.StringIO()
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"
    try:
        with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
            main([*command, "--help"])
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old
    text = out.getvalue().rstrip()
    if not text.startswith("usage:"):
        raise ValueError(f"ehsa-opt {' '.join(command)} --help printed no usage: {text!r}")
    return f"```console\n$ ehsa-opt {' '.join(command)} --help\n{text}\n```"


def on_page_content(html_text: str, page: Any, config: Any, files: Any) -> str:
    """Mark the roles; record the page's API anchors."""
    for name in _ANCHOR.findall(html_text):
        _anchors.setdefault(name, page.url)
    return _ROLE.sub(_mark, html_text)


def _resolve(target: str, page_url: str) -> tuple[str, str] | None:
    """(page url, anchor) of a role's target, or None when the site does not document it."""
    name = target.rstrip("()")
    if name in _anchors:
        return _anchors[name], name
    suffix = "." + name.lstrip(".")
    cands = [k for k in _anchors if k.endswith(suffix)]
    same = [k for k in cands if _anchors[k] == page_url]
    pick = same[0] if len(same) == 1 else cands[0] if len(cands) == 1 else None
    return None if pick is None else (_anchors[pick], pick)


def on_post_build(config: Any) -> None:
    """Link the marked names to their documentation."""
    site = Path(config["site_dir"])
    for path in site.rglob("*.html"):
        text = path.read_text(encoding="utf-8")
        if 'class="xref"' not in text:
            continue
        rel = path.relative_to(site).parent.as_posix()
        page_url = "" if rel == "." else rel + "/"

        def link(m: re.Match) -> str:
            found = _resolve(html.unescape(m.group(1)), page_url)
            if found is None:
                return f"<code>{m.group(2)}</code>"
            url, anchor = found
            href = os.path.relpath(site / url, path.parent).replace(os.sep, "/")
            href = ("" if href == "." else href + "/") + "#" + anchor
            return f'<a class="autorefs" href="{href}"><code>{m.group(2)}</code></a>'
        path.write_text(_XREF.sub(link, text), encoding="utf-8")
