"""The documentation's browser check (``tools/browser_check.py``) and gallery
(``tools/gallery.py``): the parts that need no browser always, and the page check itself
in headless Chromium when one is on this machine (a page with a console error, a broken
image and a raw role is caught; a clean page passes)."""

from __future__ import annotations

import importlib.util
import urllib.request

import pytest

from tests.paths import ROOT


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "tools" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _site(tmp_path):
    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / "index.html").write_text("<html><body><h1>Home</h1><p>fine</p>"
                                         '<img src="ok.png"></body></html>')
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "index.html").write_text(
        "<html><body><p>see :class:`~ehsa_opt.DesignResult` here</p>"
        '<img src="missing.png"><script>console.error("boom")</script></body></html>')
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig = plt.figure(figsize=(1, 1))
    fig.savefig(tmp_path / "ok.png")
    plt.close(fig)
    return tmp_path


def test_text_problems_find_raw_roles_and_hook_lines() -> None:
    bc = _load("browser_check")
    found = bc.text_problems("uses :meth:`.DesignProblem.with_objective` and {{ ehsa-opt-help x }}")
    assert len(found) == 2 and "raw role ':meth:`'" in found[0] and "ehsa-opt-help" in found[1]
    assert bc.text_problems("a ratio 1:2, the time 10:30 and `code`") == []
    leak = bc.text_problems('evidence\', 0.0)) dataclass " href="#ehsa_opt.Criterion">Criterion')
    assert len(leak) == 1 and "HTML markup as text" in leak[0]


def test_site_check_finds_markup_shown_as_text(tmp_path) -> None:
    """An attribute value with an unescaped double quote ends early: the rest of the tag
    is page text (a link title that carried a signature did this)."""
    check = _load("check_site")
    (tmp_path / "index.html").write_text(
        '<p>decided by <a title="C(x=_f("|dBIC| > 10 is strong", 1)) dataclass" '
        'href="#c"><code>C</code></a></p>'
        '<h2 id="c">C</h2>')
    problems = check.check_site(tmp_path)
    assert len(problems) == 1 and "HTML markup shown as text" in problems[0], problems


def test_pages_and_server(tmp_path) -> None:
    bc = _load("browser_check")
    site = _site(tmp_path)
    assert bc.page_paths(site, ["index.html", "bad/index.html"]) == ["index.html",
                                                                     "bad/index.html"]
    with pytest.raises(FileNotFoundError, match="no page nope.html"):
        bc.page_paths(site, ["index.html", "nope.html"])
    with bc.serve(site) as base:
        with urllib.request.urlopen(base + "index.html", timeout=10) as r:
            assert b"<h1>Home</h1>" in r.read()
    with pytest.raises(urllib.error.URLError):
        urllib.request.urlopen(base + "index.html", timeout=2)  # stopped with the block


def test_browser_lookup_and_exit_codes(tmp_path, monkeypatch, capsys) -> None:
    bc = _load("browser_check")
    with pytest.raises(bc.NoBrowser, match="not found"):
        bc.find_browser(str(tmp_path / "no-such-browser"))
    monkeypatch.setenv("PATH", str(tmp_path))  # no system browser
    monkeypatch.setenv("PLAYWRIGHT_BROWSERS_PATH", str(tmp_path / "none"))
    monkeypatch.delenv("EHSA_BROWSER", raising=False)
    with pytest.raises(bc.NoBrowser, match="apt-get install chromium-headless-shell"):
        bc.find_browser()
    assert bc.main([str(_site(tmp_path / "s"))]) == 2  # default pages not in this site
    assert "browser check not run" in capsys.readouterr().err
    assert bc.main([str(tmp_path / "s"), "--pages", "index.html"]) == 2  # no browser
    assert "no headless browser" in capsys.readouterr().err
    assert bc.main([str(tmp_path / "empty")]) == 2
    assert "no built site" in capsys.readouterr().err


def _browser_or_skip():
    bc = _load("browser_check")
    pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    try:
        return bc, bc.find_browser()
    except bc.NoBrowser as exc:
        pytest.skip(str(exc))


def test_headless_browser_finds_the_broken_page(tmp_path) -> None:
    bc, browser = _browser_or_skip()
    site = _site(tmp_path / "site")
    shots = tmp_path / "shots"
    problems = bc.check_pages(site, ["index.html", "bad/index.html"], shots, browser)
    assert not [p for p in problems if p.startswith("index.html")], problems
    bad = [p for p in problems if p.startswith("bad/index.html")]
    assert any("console error: boom" in p for p in bad), bad
    assert any("image does not load: missing.png" in p for p in bad), bad
    assert any("HTTP 404" in p and "missing.png" in p for p in bad), bad
    assert any("raw role ':class:`'" in p for p in bad), bad
    assert sorted(p.name for p in shots.iterdir()) == ["bad_index.png", "index.png"]
    assert (shots / "index.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_gallery_captions_every_report_figure(tmp_path) -> None:
    g = _load("gallery")
    assert g.check() == []
    listed = {f.path for figs in g.FIGURES.values() for f in figs}
    assert set(g.report_figures()) <= listed
    # a report figure without caption, and a caption of a missing file, are named
    ref = tmp_path / "ref"
    (ref / "figures").mkdir(parents=True)
    (ref / "REPORT.md").write_text("![new](figures/new_study.png)\n")
    problems = g.check(ref)
    assert any("figures/new_study.png: in REPORT.md but without a caption" in p
               for p in problems)
    assert any("no such file" in p for p in problems)
    md = g.markdown()
    assert md.count("![") == len(listed) and "{#discrepancy}" in md


def test_gallery_line_expands_with_paths_from_the_page() -> None:
    from types import SimpleNamespace
    hooks = _load("docs_hooks")
    page = SimpleNamespace(file=SimpleNamespace(src_uri="guide/gallery.md"))
    md = hooks.on_page_markdown("# G\n\n{{ ehsa-opt-gallery }}\n", page, None, None)
    assert "{{ ehsa-opt-gallery }}" not in md
    assert "](../gallery/figures/bench_truth_fit.png)" in md  # relative to the page
    assert "(../guide/identify.md)" in md
