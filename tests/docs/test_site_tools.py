"""The documentation tools: numpydoc roles become links to the page that documents the
name (or plain code when the site does not document it), ``--help`` blocks come from the
parser, and the site check finds raw roles and broken links."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from types import SimpleNamespace

import pytest

from tests.paths import ROOT


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "tools" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _site(tmp_path, pages: dict[str, str]):
    for url, text in pages.items():
        path = tmp_path / url / "index.html"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return tmp_path


def test_roles_become_links_or_code(tmp_path) -> None:
    hooks = _load("docs_hooks")
    hooks._anchors.clear()
    api = ('<h2 id="ehsa_opt.design.problem.DesignProblem">DesignProblem</h2>'
           '<h3 id="ehsa_opt.design.problem.DesignProblem.with_objective">w</h3>'
           'see :class:<code>~ehsa_opt.design.problem.DesignProblem</code>')
    guide = ('uses :meth:<code>.problem.DesignProblem.with_objective</code>, '
             ':class:<code>~pymoo.core.problem.Problem</code> and '
             ':func:<code>ehsa_opt.nowhere</code>')
    pages = {"api/design": api, "guide/x": guide}
    html = {u: hooks.on_page_content(t, SimpleNamespace(url=u + "/"), None, None)
            for u, t in pages.items()}
    assert ":class:" not in html["api/design"] and ":meth:" not in html["guide/x"]
    site = _site(tmp_path, html)
    hooks.on_post_build({"site_dir": str(site)})
    out_api = (site / "api/design/index.html").read_text()
    out_guide = (site / "guide/x/index.html").read_text()
    assert '<a class="autorefs" href="#ehsa_opt.design.problem.DesignProblem">' \
           '<code>DesignProblem</code></a>' in out_api
    assert ('href="../../api/design/#ehsa_opt.design.problem.DesignProblem.with_objective">'
            '<code>problem.DesignProblem.with_objective</code>') in out_guide
    # not documented on the site: code without a link
    assert "<code>Problem</code>" in out_guide and "<code>ehsa_opt.nowhere</code>" in out_guide
    assert out_guide.count("<a ") == 1
    check = _load("check_site")
    (site / "index.html").write_text("home", encoding="utf-8")
    assert check.check_site(site) == []


def test_site_check_finds_raw_roles_and_broken_links(tmp_path) -> None:
    check = _load("check_site")
    site = _site(tmp_path, {
        ".": '<a href="a/">a</a>',
        "a": 'text :func:<code>x.y</code> <a href="../b/">b</a> <a href="#nope">n</a>'})
    problems = check.check_site(site)
    assert any("raw role" in p and "x.y" in p for p in problems)
    assert any("broken link ../b/" in p for p in problems)
    assert any("missing anchor #nope" in p for p in problems)
    run = subprocess.run([sys.executable, str(ROOT / "tools" / "check_site.py"), str(site)],
                         capture_output=True, text=True)
    assert run.returncode == 1 and "3 problem(s)" in run.stderr


def test_help_blocks_are_the_parser_s(tmp_path) -> None:
    hooks = _load("docs_hooks")
    md = hooks.on_page_markdown("before\n{{ ehsa-opt-help plan-tests }}\nafter", None, None, None)
    block = re.search(r"```console\n(.*?)```", md, re.S).group(1)
    assert block.startswith("$ ehsa-opt plan-tests --help\nusage: ehsa-opt plan-tests")
    for option in ("--vehicle", "--rig", "--weight"):
        assert option in block
    with pytest.raises(ValueError, match="printed no usage"):
        hooks.command_help(["no-such-command"])
