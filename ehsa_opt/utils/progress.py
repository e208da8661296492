"""Progress bars (tqdm) for long work; quiet when ``EHSA_OPT_QUIET=1``."""

from __future__ import annotations

import os
from typing import Any

from tqdm.auto import tqdm

__all__ = ["progress_bar"]


def progress_bar(total: int | None = None, desc: str = "", unit: str = "it", **kw: Any) -> tqdm:
    """A tqdm bar with ETA on stderr (disabled if EHSA_OPT_QUIET is set)."""
    disable = os.environ.get("EHSA_OPT_QUIET", "") not in ("", "0")
    return tqdm(total=total, desc=desc, unit=unit, disable=disable, dynamic_ncols=True, **kw)
