"""The reproduce step cache, verified before use.

Each ``OUT/cache/<step>.json`` entry is standard JSON::

    {"format": "ehsa_opt-step-cache/1", "step": KEY, "hash": INPUT_HASH,
     "figures_sha256": {path: digest}, "payload": {...}, "sha256": DIGEST}

``DIGEST`` is the SHA-256 of the canonical JSON of everything else.  An entry is used
only when it parses, its digest matches, it belongs to this step and these inputs, and
every figure it lists exists with the recorded digest; otherwise the step is
recomputed and the log says why.  Non-finite floats are stored as
``{"__float__": "nan"}`` so that results come back exactly, and the runner passes
fresh results through the same encoding, so a resumed run sees the very values an
uninterrupted one did.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from pathlib import Path
from typing import Any, Callable

from ..utils.io import atomic_write_text
from ..utils.output_folder import stale_temp_files
from ..utils.limits import parse_json

__all__ = ["CACHE_FORMAT", "encode", "decode", "StepCache", "remove_stale_temp_files",
           "unsafe_markdown"]

CACHE_FORMAT = "ehsa_opt-step-cache/1"


def _tag(obj: Any) -> Any:
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else {"__float__": repr(obj)}
    if isinstance(obj, dict):
        return {str(k): _tag(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_tag(v) for v in obj]
    if isinstance(obj, (str, int, bool)) or obj is None:
        return obj
    if hasattr(obj, "tolist"):
        return _tag(obj.tolist())
    return _tag(float(obj))


def _untag(obj: dict) -> Any:
    if set(obj) == {"__float__"}:
        return float(obj["__float__"])
    return obj


def encode(obj: Any) -> str:
    """Canonical standard JSON of ``obj`` (sorted keys, tagged non-finite floats)."""
    return json.dumps(_tag(obj), sort_keys=True, separators=(",", ":"), allow_nan=False)


def decode(text: str) -> Any:
    """Inverse of :func:`encode` (nesting limited, standard JSON only)."""
    return parse_json(text, "cache entry", object_hook=_untag)


#: Raw HTML as CommonMark recognises it (a complete tag, comment, declaration or
#: processing instruction) and autolinks; a plain "x < y" is text.
_HTML = re.compile(r"<\s*/?\s*[A-Za-z][A-Za-z0-9-]*(\s[^<>]*)?/?>|<!|<\?"
                   r"|<[A-Za-z][A-Za-z0-9+.-]*:[^<>\s]*>")
_LINK = re.compile(r"\]\(\s*<?([^)>\s]*)")
_LINK_DEF = re.compile(r"^\s{0,3}\[[^\]]+\]:", re.M)
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")


def unsafe_markdown(markdown: Any, out_dir: Path) -> str | None:
    """Why a section's Markdown may not reach the report (None: it may).

    The report sections we write are text, pipe tables and images of our own figures.  A
    cache entry is only checksummed (anyone who can write ``OUT/cache`` can re-sign it),
    so its text is checked before it is used: no raw HTML (``<img``, ``<script``, ...),
    no autolinks or link definitions, and every link or image target a relative path
    to an existing file inside ``out_dir`` (no URL scheme, no ``..``, no absolute path).
    """
    if not isinstance(markdown, str):
        return "its section text is not a string"
    if not markdown.isprintable() and any(
            not c.isprintable() and c not in "\n\t" for c in markdown):
        return "its section text holds control characters"
    m = _HTML.search(markdown)
    if m:
        return f"its section text holds HTML ({markdown[m.start():m.start() + 20]!r})"
    if _LINK_DEF.search(markdown):
        return "its section text holds a link definition"
    root = Path(out_dir).resolve()
    for target in _LINK.findall(markdown):
        p = Path(target)
        if (not target or _SCHEME.match(target) or p.is_absolute() or ".." in p.parts
                or not (root / p).resolve().is_relative_to(root)
                or not (root / p).is_file()):
            return f"its section text links to {target[:60]!r} (not a file of this folder)"
    return None


def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def remove_stale_temp_files(out_dir: Path) -> list[Path]:
    """Delete the temporary files of atomic writes a killed run left behind in ``out_dir``,
    ``cache``, ``figures`` and ``tables`` (only ``.NAME.ehsa_opt-XXXXXXXX.tmp`` of a
    ``NAME`` the folder's manifest lists: :func:`~ehsa_opt.utils.output_folder.stale_temp_files`).

    Call it only while holding the folder's lock (no other writer is alive then).
    """
    out = Path(out_dir)
    stale = stale_temp_files(out, [out, out / "cache", out / "figures", out / "tables"])
    for f in stale:
        f.unlink(missing_ok=True)
    return stale


class StepCache:
    """Verified step cache in ``out_dir / "cache"``.

    Parameters
    ----------
    out_dir : Path
    log : callable
        Receives one line per entry that is refused (and why).
    """

    def __init__(self, out_dir: Path, log: Callable[[str], None]) -> None:
        self.out = Path(out_dir)
        self.dir = self.out / "cache"
        self.dir.mkdir(parents=True, exist_ok=True)
        self.log = log

    def path(self, step: str) -> Path:
        return self.dir / f"{step}.json"

    def load(self, step: str, key: str) -> dict | None:
        """The payload of a valid entry for ``step`` with input hash ``key``, else None."""
        f = self.path(step)
        if not f.is_file():
            return None
        why = None
        try:
            doc = decode(f.read_text(encoding="utf-8"))
        except (ValueError, UnicodeDecodeError, OSError, TypeError) as exc:
            doc, why = None, f"unreadable ({type(exc).__name__}: truncated or not JSON)"
        if doc is not None:
            if not isinstance(doc, dict) or doc.get("format") != CACHE_FORMAT:
                why = "not a cache entry of this version"
            else:
                digest = doc.pop("sha256", None)
                if digest != hashlib.sha256(encode(doc).encode()).hexdigest():
                    why = "its SHA-256 digest does not match its content (altered or damaged)"
                elif doc.get("step") != step:
                    why = f"it belongs to step '{doc.get('step')}'"
                elif doc.get("hash") != key:
                    return None  # inputs or code changed: an ordinary recompute
                elif not isinstance(doc.get("figures_sha256", {}), dict) or not all(
                        isinstance(k, str) and isinstance(v, str)
                        for k, v in doc.get("figures_sha256", {}).items()):
                    why = "its figure digests are not a table of names and digests"
                else:
                    for fig, want in doc.get("figures_sha256", {}).items():
                        p = self.out / fig
                        if not p.is_file() or _sha256_file(p) != want:
                            why = f"its figure {fig} is missing or changed"
                            break
                    payload = doc.get("payload")
                    if why is None and not (isinstance(payload, dict)
                                            and isinstance(payload.get("results"), dict)):
                        why = "it has no payload of results"
                    elif why is None:
                        why = unsafe_markdown(payload.get("markdown"), self.out)
        if why is not None:
            self.log(f"cache {f}: {why}; not used, the step is recomputed")
            return None
        return doc["payload"]

    def store(self, step: str, key: str, payload: dict) -> dict:
        """Write an entry atomically; return the payload as a later load returns it."""
        figs = {fig: _sha256_file(self.out / fig) for fig in payload.get("figures", [])
                if (self.out / fig).is_file()}
        doc = {"format": CACHE_FORMAT, "step": step, "hash": key, "figures_sha256": figs,
               "payload": payload}
        body = encode(doc)
        doc["sha256"] = hashlib.sha256(body.encode()).hexdigest()
        atomic_write_text(self.path(step), encode(doc))
        return decode(encode(payload))
