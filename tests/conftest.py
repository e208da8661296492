import os

os.environ.setdefault("EHSA_OPT_QUIET", "1")
