"""Report conclusions are decided by the numbers, and the paper's numbers come from one
module."""

import ast
from pathlib import Path

import numpy as np

from ehsa_opt.pipeline import paper_reference
from ehsa_opt.pipeline.quarter_car_report import fig21_ordering

PIPELINE = Path(paper_reference.__file__).parent


def test_the_ordering_sentence_follows_the_numbers() -> None:
    ordered = {"power_W": np.array([150.0, 120.0, 90.0]),
               "efficiency": np.array([0.8, 0.7, 0.6])}
    text = fig21_ordering(ordered, True)
    assert "holds here" in text and "150.0 > 120.0 > 90.0 W" in text
    swapped = {"power_W": np.array([150.0, 90.0, 120.0]),
               "efficiency": np.array([0.8, 0.7, 0.6])}
    assert "NOT reproduced" in fig21_ordering(swapped, True)
    assert fig21_ordering(ordered, False).startswith("No ordering is stated")


def test_reports_take_no_private_name_from_each_other() -> None:
    for path in PIPELINE.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level:
                private = [a.name for a in node.names
                           if a.name.startswith("_") and not a.name.startswith("__")]
                assert not private, f"{path.name} imports {private} from {node.module}"


def test_the_paper_tables_agree_with_each_other() -> None:
    # Fig 21 and Table 4 are the same published runs
    t4, f21 = paper_reference.PAPER_TABLE4, paper_reference.PAPER_FIG21
    for k, case in enumerate(("none", "min", "max")):
        assert f21[case][0] == t4["power_W"][k] and f21[case][1] == t4["efficiency_pct"][k]
    assert paper_reference.PAPER_OPTIMUM["efficiency_pct"][1] == t4["efficiency_pct"][0]
