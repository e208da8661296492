"""Largest difference between the numbers of two reproduce reports.

Usage: ``python benchmarks/report_diff.py OLD/REPORT.md NEW/REPORT.md``

Compares the reports line by line (the run log, which holds wall times, is left out):
lines whose text differs only in numbers are paired and their numbers compared; prints
the largest absolute and relative differences with the lines they come from, and lines
that differ in words.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

NUM = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def body(path: str) -> list[str]:
    text = Path(path).read_text(encoding="utf-8")
    return text.split("## Run log")[0].splitlines()


def main(old: str, new: str) -> int:
    a, b = body(old), body(new)
    worst: list[tuple[float, float, str, str]] = []
    worded = []
    for la, lb in zip(a, b):
        if la == lb:
            continue
        if NUM.sub("#", la) != NUM.sub("#", lb):
            worded.append((la, lb))
            continue
        for xa, xb in zip(NUM.findall(la), NUM.findall(lb)):
            fa, fb = float(xa), float(xb)
            if fa != fb:
                rel = abs(fa - fb) / max(abs(fa), abs(fb), 1e-300)
                worst.append((rel, abs(fa - fb), la.strip()[:120], lb.strip()[:120]))
    worst.sort(reverse=True)
    print(f"{len(a)} vs {len(b)} lines; {len(worst)} numbers differ; "
          f"{len(worded)} lines differ in words")
    for rel, ab, la, lb in worst[:10]:
        print(f"  rel {rel:.3g} (abs {ab:.3g})\n    old: {la}\n    new: {lb}")
    for la, lb in worded[:10]:
        print(f"  words:\n    old: {la[:120]}\n    new: {lb[:120]}")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
