"""Where a hardware catalogue (motors, ball screws) is read from: the name of one shipped
in ``ehsa_opt/data/<folder>``, or a path resolved against the folder of the file naming
it."""

from __future__ import annotations

from pathlib import Path

from .params import ParameterError, nearest_name

__all__ = ["catalogue_file"]


def catalogue_file(kind: str, folder: str, shipped_name: str, name: str | Path,
                   base_dir: str | Path | None = None) -> Path:
    """The catalogue file ``name`` of ``kind`` (e.g. ``"motor catalogue"``): a bare name
    (no suffix, no folder) is one shipped in ``ehsa_opt/data/<folder>``; anything else is
    a path, relative to ``base_dir`` when not absolute, that must lead to an existing file
    (it never falls back on a shipped catalogue).  ``shipped_name`` is the shipped default
    the messages suggest."""
    text = str(name)
    if not text or not text.isprintable():
        raise ParameterError(f"{kind} {text!r}: not a file name (empty or a control "
                             f"character); give a .toml path or '{shipped_name}'")
    p = Path(text)
    shipped_dir = Path(__file__).resolve().parents[1] / "data" / folder
    if p.suffix != ".toml" and len(p.parts) == 1:
        shipped = shipped_dir / f"{text}.toml"
        if shipped.is_file():
            return shipped
        names = sorted(f.stem for f in shipped_dir.glob("*.toml"))
        near = nearest_name(text, names)
        raise ParameterError(f"{kind} '{text}': no shipped catalogue of that name"
                             + (f"; did you mean '{near}'?" if near else "")
                             + f" (shipped: {', '.join(names)}; or give the path of a .toml "
                               f"file)")
    if not p.is_absolute() and base_dir is not None:
        p = Path(base_dir) / p
    if not p.is_file():
        where = (f" (resolved against {Path(base_dir).resolve()})"
                 if base_dir is not None and not Path(text).is_absolute() else "")
        raise ParameterError(f"{kind} '{text}': no such file{where}; give the path of the "
                             f"catalogue relative to the problem file, or '{shipped_name}' "
                             f"for the shipped one")
    return p
