"""Paths the tests share: the repository root and the files they read from it."""

from __future__ import annotations

from pathlib import Path

__all__ = ["ROOT", "PACKAGE", "PAPER_DESIGN"]

ROOT = Path(__file__).resolve().parents[1]
"""The repository root (the folder holding ``ehsa_opt/``, ``validation/`` and ``tools/``)."""

PACKAGE = ROOT / "ehsa_opt"
"""The package's source folder."""

PAPER_DESIGN = ROOT / "problems" / "paper_design.toml"
"""The paper's design problem file."""
