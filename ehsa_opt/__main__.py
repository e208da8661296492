"""``python -m ehsa_opt`` — same as the ``ehsa-opt`` console script."""

import sys

from .cli import main

sys.exit(main())
