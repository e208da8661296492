"""Design room: the design space and its pymoo :class:`~pymoo.core.problem.Problem`
(:mod:`.problem`), goal attainment (:mod:`.goal`), NSGA-II with checkpoints
(:mod:`.nsga2`), Pareto tools (:mod:`.pareto`), problem files (:mod:`.config`), the
CLI-facing driver (:mod:`.optimize`), sweeps (:mod:`.sweep`) and friction on the optimum
(:mod:`.friction_optimum`). Imports vehicle, physics, datasets and utils."""

from .goal import GoalAttainmentResult, default_goals, solve_goal_attainment
from .nsga2 import ParetoResult, run_nsga2
from .pareto import dominates_by, hypervolume, non_dominated, pick_preferred
from .problem import (
                      DESIGN_VARIABLES,
                      OBJECTIVE_NAMES,
                      PAPER_BOX,
                      DesignProblem,
                      DesignSpace,
                      QuarterCarObjectives,
)

__all__ = ["DESIGN_VARIABLES", "OBJECTIVE_NAMES", "PAPER_BOX", "DesignSpace",
           "QuarterCarObjectives", "DesignProblem", "GoalAttainmentResult",
           "solve_goal_attainment", "default_goals", "ParetoResult", "run_nsga2",
           "pick_preferred", "hypervolume", "non_dominated", "dominates_by"]
