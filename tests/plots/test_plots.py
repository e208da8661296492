"""Plot functions draw the data they are given, into a given axes when asked, and write
nothing; only ``plots.save`` writes (atomically)."""

import ast
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ehsa_opt import plots
from ehsa_opt.plots.design import hypervolume_history
from ehsa_opt.plots.quarter_car import wk_figure
from ehsa_opt.vehicle.iso2631 import ISO2631_WK_TABLE, wk_abs2

PLOTS = Path(plots.__file__).parent


def test_one_panel_figures_draw_into_the_given_axes_and_write_nothing(tmp_path,
                                                                      monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    fig, (a, b) = plt.subplots(1, 2)
    f_hz = np.geomspace(0.5, 80.0, 50)
    w = np.sqrt(wk_abs2(f_hz))
    assert wk_figure(f_hz, w, w, ISO2631_WK_TABLE, "fit", ax=a) is fig
    hist = [{"n_eval": 10, "hv": 0.1}, {"n_eval": 20, "hv": 0.3}]
    assert hypervolume_history({"run": hist}, ax=b) is fig
    assert len(a.lines) >= 2 and [ln.get_ydata()[-1] for ln in b.lines] == [0.3]
    assert len(fig.axes) == 2 and list(tmp_path.iterdir()) == []
    path = plots.save(fig, tmp_path / "f" / "x.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_modules_run_nothing_of_a_lower_room_and_write_only_through_save() -> None:
    # runtime imports of plot modules: matplotlib, numpy, physics laws, utils; the
    # types of the results they draw come in under TYPE_CHECKING only
    for path in PLOTS.glob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        guarded = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
                   and getattr(node.test, "id", "") == "TYPE_CHECKING"
                   for n in ast.walk(node)}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and id(node) not in guarded and node.level:
                mod = node.module or ""
                assert not mod.startswith(("estimation", "design", "vehicle", "pipeline")), \
                    f"{path.name} imports {mod} at run time"
            if isinstance(node, ast.Attribute) and node.attr == "savefig":
                assert path.name == "__init__.py", f"{path.name} writes a figure"
