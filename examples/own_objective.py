"""A design problem of one's own: the paper's design problem with a rated generator frame
(``examples/own_motor_design.toml``), plus a user-defined objective — the generator's
peak current — and a user-defined constraint — the peak stroke within 70 mm — solved
with NSGA-II and, for comparison, with pymoo's SMS-EMOA.

The functions receive every evaluator output as an array over the designs
(``current_rms_A``, ``voltage_rms_V``, ``stroke_rms_m``, ``stroke_velocity_rms_m_s``,
``power_W``, ``efficiency`` …, and the design variables); on the Gaussian road a peak
is 3.5 × the rms value (the peak factor of the design's own rated limits).

    python examples/own_objective.py
"""

from pathlib import Path

from pymoo.algorithms.moo.sms import SMSEMOA

import ehsa_opt

PEAK_FACTOR = 3.5  # peak / rms of a Gaussian signal (exceeded 0.05 % of the time)
PROBLEM = Path(__file__).with_name("own_motor_design.toml")


def main() -> None:
    problem = (ehsa_opt.load_problem(PROBLEM)
               .with_objective("peak_current_A", lambda o: PEAK_FACTOR * o["current_rms_A"],
                               unit="A")
               .with_constraint("peak_stroke_m", lambda o: PEAK_FACTOR * o["stroke_rms_m"],
                                upper=0.07, unit="m"))
    result = ehsa_opt.optimize(problem, termination=("n_gen", 15), pop_size=24, seed=1)
    print(result.summary())

    front = result.table()  # a DataFrame with pandas, else a dict of arrays
    print(f"\n{len(front['peak_current_A'])} front designs: peak current "
          f"{min(front['peak_current_A']):.2f} .. {max(front['peak_current_A']):.2f} A for "
          f"power {min(front['power_W']):.1f} .. {max(front['power_W']):.1f} W; peak stroke "
          f"at most {1000 * max(front['peak_stroke_m']):.1f} mm (limit 70 mm)")
    print("objectives (columns of F, minimised):", ", ".join(result.objective_names))
    print("constraints (columns of G, <= 0 feasible):", ", ".join(result.constraint_names))

    other = ehsa_opt.optimize(problem, algorithm=SMSEMOA(pop_size=24),
                              termination=("n_gen", 15), seed=1, goal_attainment=False)
    print(f"\nSMS-EMOA: {other.message}; lowest peak current "
          f"{other.F[:, -1].min():.2f} A (NSGA-II {result.F[:, -1].min():.2f} A)")


if __name__ == "__main__":
    main()
