"""The friction law's effect on the vehicle figures: LuGre sets against static sets of the
same bench data, on the paper's Table 4 road (ISO 8608 class C, 100 km/h) with the paper's
optimum harvester (J_t 250 g cm², 7 mm/rev, 29.8 rpm/V, 75 Ω), paired on the same Gaussian
road realisations (ehsa_opt.vehicle.friction_law_study).

Make the two identifications first (the LuGre one costs minutes per test)::

    ehsa-opt identify DATA --out ID_STATIC
    ehsa-opt identify DATA --friction-law lugre --out ID_LUGRE
    python validation/vehicle_friction_law.py ID_STATIC/identification.json \
        ID_LUGRE/identification.json [--seeds 8] [--length-m 1000] [--out result.json]
"""

from __future__ import annotations

import argparse
import json
import time

from ehsa_opt.datasets.friction_source import load_friction_sets
from ehsa_opt.physics.params import RoadParams, VehicleParams
from ehsa_opt.utils.io import json_safe
from ehsa_opt.vehicle.friction_law_study import friction_law_effect
from ehsa_opt.vehicle.studies import paper_optimum_harvester
from ehsa_opt.vehicle.uncertainty import DEFAULT_SEEDS


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("static", help="identification.json made with the static law")
    ap.add_argument("lugre", help="identification.json made with --friction-law lugre")
    ap.add_argument("--seeds", type=int, default=DEFAULT_SEEDS)
    ap.add_argument("--length-m", type=float, default=1000.0)
    ap.add_argument("--speed-km-per-h", type=float, default=100.0)
    ap.add_argument("--out", default=None, help="also write the result as JSON")
    args = ap.parse_args(argv)
    static, lugre = load_friction_sets(args.static), load_friction_sets(args.lugre)
    road = RoadParams(iso_class="C", speed_km_per_h=args.speed_km_per_h,
                      length_m=args.length_m)
    t0 = time.perf_counter()
    eff = friction_law_effect(VehicleParams(), paper_optimum_harvester(), road, static, lugre,
                              n_seeds=args.seeds)
    best = lugre["best"]
    print(f"LuGre sets: sigma_0 = {best.presliding_stiffness_N_per_m:.4g} N/m, sigma_1 = "
          f"{best.presliding_damping_Ns_per_m:.4g} N s/m; road class C, "
          f"{args.speed_km_per_h:g} km/h, {args.length_m:g} m, {args.seeds} realisations "
          f"({time.perf_counter() - t0:.0f} s)\n")
    print(eff.table())
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            json.dump(json_safe({"sigma0_N_per_m": best.presliding_stiffness_N_per_m,
                                 "sigma1_Ns_per_m": best.presliding_damping_Ns_per_m,
                                 **eff.as_dict()}), fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
