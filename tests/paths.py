"""Paths the tests share: the repository root and the files they read from it."""

from __future__ import annotations

from pathlib import Path

__all__ = ["ROOT", "PACKAGE", "PAPER_DESIGN", "paper_model_design"]

ROOT = Path(__file__).resolve().parents[1]
"""The repository root (the folder holding ``ehsa_opt/``, ``validation/`` and ``tools/``)."""

PACKAGE = ROOT / "ehsa_opt"
"""The package's source folder."""

PAPER_DESIGN = ROOT / "problems" / "paper_design.toml"
"""The paper's design problem file."""


def paper_model_design(folder: Path) -> Path:
    """A copy of the paper's design problem in ``folder`` with the paper's own design space
    (``[motor] model = "paper"``: R_i, L_i fixed for every k_n, no hardware limits) instead
    of the catalogue hardware the shipped file designs with."""
    out, skip = [], False
    for line in PAPER_DESIGN.read_text(encoding="utf-8").splitlines():
        if line.startswith("["):
            skip = line.split("]")[0].strip("[ ") in ("motor", "screw", "limits")
        if not skip:
            out.append(line)
    path = Path(folder) / "paper_model_design.toml"
    path.write_text("\n".join(out) + '\n[motor]\nmodel = "paper"\n', encoding="utf-8")
    return path
