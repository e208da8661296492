"""Tutorial: from bench CSVs to a Pareto front, in one script.

1. Bench data: a directory with ``bench.toml`` and one CSV per test (time, displacement,
   force, voltage). Here a small synthetic campaign stands in for yours (6 sine tests of
   the prototype rig, true friction known); point ``DATA`` at your own directory instead.
2. Identify the friction of every test, and the data-supported friction sets
   ``min`` / ``best`` / ``max``.
3. Simulate the quarter car with the harvester and the identified friction on an ISO 8608
   class C road.
4. Design: the Pareto front of a rated generator frame (``own_motor_design.toml``) with the
   identified friction in the loop.

Everything is computed in memory; the script saves each result into a temporary folder (or
the folder given as the first argument) to show what ``save`` writes.

    python examples/tutorial.py [OUT_DIR]
"""

import sys
import tempfile
from pathlib import Path

import ehsa_opt

HERE = Path(__file__).parent


def main(out: Path) -> None:
    # 1. bench data (a stand-in for your own CSVs)
    data_dir = ehsa_opt.generate_bench(frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(15.0, 47.0),
                                       seed=3).save(out / "bench")
    data = ehsa_opt.load_bench(data_dir)  # strict checks: a bad file is refused, named
    print(f"1. {len(data.tests)} bench tests in {data_dir}")

    # 2. identification
    ident = ehsa_opt.identify(data, starts=2, seed=0)
    print("2. " + ident.summary())
    ident.save(out / "identification")
    best = ident.friction_sets["best"]
    print(f"   best set: nut Coulomb {best['nut_coulomb_N']:.1f} N (truth 40.0 N), nut "
          f"viscous {best['nut_viscous_Ns_per_m']:.0f} N s/m (truth 150 N s/m)")

    # 3. the quarter car with the identified friction
    friction = f"{out / 'identification' / 'identification.json'}:best"
    sim = ehsa_opt.simulate("quarter_car_class_c", friction=friction)
    m = sim.metrics
    print(f"3. quarter car, class C road at 70 km/h: power {m['power_W']:.1f} W, "
          f"efficiency {100 * m['efficiency']:.1f} %, comfort alpha {m['comfort']:.3f}, "
          f"peak current {m['peak_current_A']:.2f} A")
    sim.save(out / "simulation")

    # 4. the Pareto front of one's own generator frame, the identified friction in the loop
    problem = ehsa_opt.load_problem(HERE / "own_motor_design.toml", friction=friction)
    front = ehsa_opt.optimize(problem, termination=("n_gen", 10), pop_size=16, seed=1)
    print("4. " + front.summary())
    table = front.table()
    print(f"   {len(table['power_W'])} front designs: power {min(table['power_W']):.1f} .. "
          f"{max(table['power_W']):.1f} W, comfort {min(table['comfort']):.3f} .. "
          f"{max(table['comfort']):.3f}")
    front.save(out / "design")
    front.write_figures(out / "design" / "figures")
    print(f"saved in {out}: bench/, identification/, simulation/, design/")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp()))
