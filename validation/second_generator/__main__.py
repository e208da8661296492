"""Write one campaign of the second generator as a bench data directory.

    PYTHONPATH=. python -m validation.second_generator OUT_DIR [--rig rig_b|rig_c]
        [--protocol sines|strokes|multi|mixed|campaign27|smoke] [--seed N]
        [--effect NAME=VALUE ...] [--asym-coulomb-N X] [--pause-s S] [--overwrite]

``--effect`` sets any field of :class:`~validation.second_generator.model.Effects`
(e.g. ``--effect play_m=3e-4 --effect contact_stiffness=3e10``).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import fields

from .campaign import PROTOCOL_SETS, RIGS, Campaign, write_campaign
from .model import Effects


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m validation.second_generator",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--rig", choices=sorted(RIGS), default="rig_b")
    ap.add_argument("--protocol", choices=PROTOCOL_SETS, default="mixed")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--effect", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--asym-coulomb-N", type=float, default=0.0)
    ap.add_argument("--asym-viscous-Ns-per-m", type=float, default=0.0)
    ap.add_argument("--pause-s", type=float, default=20.0,
                    help="rig at rest between two tests, s (the drift's grease cools)")
    ap.add_argument("--overwrite", action="store_true")
    args = ap.parse_args(argv)
    known = {f.name: f.type for f in fields(Effects)}
    kw = {}
    for item in args.effect:
        name, _, value = item.partition("=")
        if name not in known or not value:
            ap.error(f"--effect {item!r}: expected NAME=VALUE with NAME one of {sorted(known)}")
        kw[name] = int(value) if name == "cogging_detents" else float(value)
    c = Campaign(rig=args.rig, protocol=args.protocol, seed=args.seed, effects=Effects(**kw),
                 asym_coulomb_N=args.asym_coulomb_N,
                 asym_viscous_Ns_per_m=args.asym_viscous_Ns_per_m, pause_s=args.pause_s)
    d = write_campaign(args.out, c, overwrite=args.overwrite)
    print(f"wrote {d} ({sum(1 for _ in d.glob('*.csv'))} tests; truth in "
          f"{d / 'generator_truth.toml'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
