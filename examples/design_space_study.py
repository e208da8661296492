"""A design-space study from a script: harvested power, efficiency, comfort and road
holding over a grid of ball-screw lead × electrical load, at two vehicle speeds.

The quarter car of the shipped problem ``quarter_car_class_c`` (passenger car, ISO 8608
class C road) without friction, on the exact frequency-domain path: 7 leads × 5 loads ×
2 speeds = 70 cases in about a second.  Saves the table (``sweep.csv``) and the figure of
the metrics against the lead, one line per load and speed, into a temporary folder (or
the folder given as the first argument).

    python examples/design_space_study.py [OUT_DIR]
"""

import sys
import tempfile
from pathlib import Path

import ehsa_opt
from ehsa_opt import plots


def main(out_dir: Path) -> None:
    study = ehsa_opt.sweep("quarter_car_class_c",
                           design={"lead_mm_per_rev": [4, 6, 8, 10, 12, 16, 20],
                                   "load_ohm": [5, 10, 20, 50, 100]},
                           speed_km_per_h=[50, 100], friction=["none"])
    print(study.summary())

    for speed in (50.0, 100.0):
        rows = [r for r in study.rows if r["speed_km_per_h"] == speed]
        # without friction the harvested power depends on the load only (the road's
        # dissipation splits between R_e and the winding), not on the lead
        spread = max(max(r["power_W"] for r in rows if r["load_ohm"] == load)
                     - min(r["power_W"] for r in rows if r["load_ohm"] == load)
                     for load in {r["load_ohm"] for r in rows})
        best = min(rows, key=lambda r: r["comfort"])
        print(f"at {speed:g} km/h: power {min(r['power_W'] for r in rows):.1f} .. "
              f"{max(r['power_W'] for r in rows):.1f} W (spread over the leads at one load "
              f"{spread:.2g} W); best comfort alpha {best['comfort']:.3f} with lead "
              f"{best['lead_mm_per_rev']:g} mm/rev and R_e {best['load_ohm']:g} ohm "
              f"({best['power_W']:.1f} W, road holding {best['road_holding']:.3f})")

    study.save(out_dir)  # sweep.csv and sweep.png (metrics against speed)
    fig = study.plot(x="lead_mm_per_rev")  # metrics against the lead, a line per load/speed
    plots.save(fig, out_dir / "power_vs_lead.png")
    print(f"wrote {out_dir}/sweep.csv, sweep.png and power_vs_lead.png")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp()))
