"""The package's logger: ``logging.getLogger("ehsa_opt")``.

The library reports progress (``INFO``) and what a user should know about a result
(``WARNING``: a design beyond the friction's identified range, road holding beyond 1 …)
through this logger and prints nothing; a script sees the warnings through Python's
default handler (``logging.lastResort``, stderr) and can configure the rest as usual, e.g.
``logging.basicConfig(level=logging.INFO)``.  The command line installs
:func:`stderr_handler` (the message alone on stderr, as printed before).
"""

from __future__ import annotations

import contextlib
import logging
import sys
from typing import Iterator

__all__ = ["LOGGER_NAME", "logger", "stderr_handler"]

#: Name of the package's logger.
LOGGER_NAME = "ehsa_opt"

#: The package's logger.
logger = logging.getLogger(LOGGER_NAME)


class _CurrentStderr(logging.Handler):
    """Writes the bare message to the *current* ``sys.stderr`` (which a test or a caller
    may have replaced since the handler was made)."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            print(self.format(record), file=sys.stderr, flush=True)
        except Exception:  # noqa: BLE001 - logging must never raise
            self.handleError(record)


@contextlib.contextmanager
def stderr_handler(level: int = logging.WARNING) -> Iterator[logging.Handler]:
    """While active, the package's messages of ``level`` and above go to stderr as bare
    lines, and not on to the root logger (each message printed once)."""
    handler = _CurrentStderr(level)
    handler.setFormatter(logging.Formatter("%(message)s"))
    propagate = logger.propagate
    logger.addHandler(handler)
    logger.propagate = False
    try:
        yield handler
    finally:
        logger.removeHandler(handler)
        logger.propagate = propagate
