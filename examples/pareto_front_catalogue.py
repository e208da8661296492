"""A Pareto front with a motor catalogue, from a script.

The shipped problem ``catalogue_design`` (the paper's design problem, passenger car on an
ISO 8608 class C road at 70 km/h) designs the harvester around real generators: one
NSGA-II run per motor of the catalogue named in its ``[motor]`` table (the shipped
``dc_generators``; give your own file there: ``catalogue = "my_motors.toml"``, format on
the Formats page), each motor's rated current and voltage and the stroke as
constraints.  The front is the feasible designs of every motor, non-dominated across
motors.  Writes ``front.csv``, ``result.json`` and the front's figure into a temporary
folder (or the folder given as the first argument).

    python examples/pareto_front_catalogue.py [OUT_DIR]
"""

import sys
import tempfile
from pathlib import Path

import ehsa_opt


def main(out_dir: Path) -> None:
    problem = ehsa_opt.load_problem("catalogue_design")
    result = ehsa_opt.optimize(problem, termination=("n_gen", 12), pop_size=20, seed=1)
    print(result.summary())

    front = result.table()  # one row per front design; a DataFrame with pandas
    print(f"\nfront: {len(front['motor'])} designs from the motors "
          f"{sorted(set(front['motor']))}")
    for i in range(min(5, len(front["motor"]))):
        print(f"  {front['motor'][i]:<24s} lead {front['lead_mm_per_rev'][i]:5.2f} mm/rev, "
              f"R_e {front['load_ohm'][i]:7.2f} ohm: power {front['power_W'][i]:5.1f} W, "
              f"efficiency {100 * front['efficiency'][i]:4.1f} %, "
              f"comfort {front['comfort'][i]:.3f}")
    print(f"chosen (knee) design: {result.design}")

    result.save(out_dir)
    result.write_figures(out_dir / "figures")
    print(f"wrote {out_dir}/result.json, front.csv, pareto.csv and figures/")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp()))
