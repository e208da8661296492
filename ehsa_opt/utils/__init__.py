"""Small shared utilities at the bottom of the import graph: atomic writes,
hashing, progress bars, the package version. Nothing here imports another room."""

from .io import atomic_write_bytes, atomic_write_text
from .version import __version__

__all__ = ["atomic_write_text", "atomic_write_bytes", "__version__"]
