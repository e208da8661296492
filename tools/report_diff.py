"""Largest difference between the numbers of two reproduce reports.

Aligns the two reports on their wording with numbers masked (difflib; the run log,
which holds wall times, is left out), compares the numbers of every aligned line and
prints the largest relative and absolute differences with the lines they come from,
and how many lines exist in one report only.

Usage: ``python tools/report_diff.py OLD/REPORT.md NEW/REPORT.md [TOP]``
"""

from __future__ import annotations

import difflib
import re
import sys
from pathlib import Path

NUM = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def body(path: str) -> list[str]:
    text = Path(path).read_text(encoding="utf-8")
    return text.split("## Run log")[0].splitlines()


def main(old: str, new: str) -> int:
    a, b = body(old), body(new)
    # align the two reports on their wording (numbers masked), so inserted sections and
    # rows do not shift the comparison; then compare the numbers of aligned lines
    ta, tb = [NUM.sub("#", x) for x in a], [NUM.sub("#", x) for x in b]
    matcher = difflib.SequenceMatcher(a=ta, b=tb, autojunk=False)
    worst: list[tuple[float, float, str, str]] = []
    paired = 0
    for block in matcher.get_matching_blocks():
        for k in range(block.size):
            la, lb = a[block.a + k], b[block.b + k]
            paired += 1
            for xa, xb in zip(NUM.findall(la), NUM.findall(lb)):
                fa, fb = float(xa), float(xb)
                if fa != fb:
                    rel = abs(fa - fb) / max(abs(fa), abs(fb), 1e-300)
                    worst.append((rel, abs(fa - fb), la.strip()[:120], lb.strip()[:120]))
    only_old = len(a) - paired
    only_new = len(b) - paired
    worst.sort(reverse=True)
    print(f"{len(a)} vs {len(b)} lines; {paired} lines aligned by wording, of which "
          f"{len({w[2] for w in worst})} hold numbers that differ ({len(worst)} numbers); "
          f"{only_old} lines only in the old report, {only_new} only in the new")
    for rel, ab, la, lb in worst[:top]:
        print(f"  rel {rel:.3g} (abs {ab:.3g})\n    old: {la}\n    new: {lb}")
    return 0


if __name__ == "__main__":
    top = int(sys.argv[3]) if len(sys.argv) > 3 else 10
    sys.exit(main(*sys.argv[1:3]))
