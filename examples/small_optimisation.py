"""A small optimal design of the harvester (paper §4.2) from Python.

Goal attainment (MATLAB ``fgoalattain`` semantics) and a small seeded NSGA-II front on the
shipped problem ``paper_design`` in the paper's own design space (``[motor] model =
"paper"``: R_i and L_i fixed for every k_n, no hardware limits; the shipped file designs
with catalogue hardware instead) — passenger car, class C at 70 km/h, the paper's Table 3
box, goals = the prototype's objectives — both on the exact frequency-domain quarter car.
Then checks that no front design beats the goal-attainment point on every objective by
more than 1 %. Runs in well under a minute.

    python examples/small_optimisation.py
"""

import tempfile
from pathlib import Path

import numpy as np

from ehsa_opt.datasets.problem_file import resolve_problem_path
from ehsa_opt.design import run_nsga2, solve_goal_attainment
from ehsa_opt.design.config import load_design_config
from ehsa_opt.design.optimize import build_problem, goals_and_weights


def paper_space(folder: Path) -> Path:
    """The shipped ``paper_design`` with the paper's design space instead of its hardware."""
    out, skip = [], False
    for line in resolve_problem_path("paper_design").read_text(encoding="utf-8").splitlines():
        if line.startswith("["):
            skip = line.split("]")[0].strip("[ ") in ("motor", "screw", "limits")
        if not skip:
            out.append(line)
    path = folder / "paper_space.toml"
    path.write_text("\n".join(out) + '\n[motor]\nmodel = "paper"\n', encoding="utf-8")
    return path


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        cfg = load_design_config(paper_space(Path(tmp)))
    problem = build_problem(cfg)              # a pymoo Problem, vectorised over designs
    goals, weights, proto = goals_and_weights(cfg, problem)
    names = problem.objective_names

    ga = solve_goal_attainment(problem, goals, weights, cfg.prototype_design,
                               n_starts=3, seed=0)
    assert ga.success, ga.message
    print(f"goal attainment: gamma = {ga.gamma:.4f} ({'every goal beaten' if ga.gamma < 0 else 'goals missed'})")
    print("  design:     " + ", ".join(f"{k} = {v:.4g}" for k, v in ga.design.items()))
    print("  objectives: " + ", ".join(f"{k} = {v:.4g} (prototype {proto[k]:.4g})"
                                       for k, v in ga.objectives.items() if k in names))
    print(f"  power {ga.objectives['power_W']:.1f} W (prototype {proto['power_W']:.1f} W), "
          f"efficiency {100 * ga.objectives['efficiency']:.1f} % "
          f"(prototype {100 * proto['efficiency']:.1f} %)")

    # hypervolume of the front normalised by the prototype's objectives, reference point 2
    f_proto = [proto[k] for k in names]
    front = run_nsga2(problem, pop_size=24, n_gen=12, seed=1, hv_scale=f_proto,
                      hv_reference=[2.0] * len(names))
    print(f"NSGA-II: {front.F.shape[0]} non-dominated designs after "
          f"{len(front.history)} generations, hypervolume {front.history[-1]['hv']:.3f}")
    i = front.preferred
    print("  knee:       " + ", ".join(f"{k} = {v[i]:.4g}" for k, v in front.designs.items()))
    dominating = np.all(front.F < 0.99 * np.array([ga.objectives[k] for k in names]), axis=1)
    print(f"  front designs better than goal attainment by 1 % on every objective: "
          f"{int(dominating.sum())}")


if __name__ == "__main__":
    main()
