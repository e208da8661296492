"""The figure gallery of the documentation site: the figures of the committed reference
report (``results/reference``, written by ``ehsa-opt reproduce``), each with a caption
that says what it shows.

The docs hook (``tools/docs_hooks.py``) copies the figures into the site under
``gallery/`` and expands the line ``{{ ehsa-opt-gallery }}`` of ``docs/gallery.md`` into
the gallery; :func:`check` fails the build when the report has a figure without a caption
here, or a caption names a figure the report does not have.

    python tools/gallery.py        # check the captions against results/reference
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parents[1]
#: The reference report whose figures the gallery shows.
REFERENCE = ROOT / "results" / "reference"
#: Where the figures go in the site.
SITE_DIR = "gallery"


class Figure(NamedTuple):
    """One figure: its path under :data:`REFERENCE`, a title, the caption, and the guide
    page of the command that makes it (relative to ``docs/``)."""

    path: str
    title: str
    caption: str
    guide: str


#: The gallery's sections, in order: (anchor, heading, what the section is about).
SECTIONS = (
    ("bench", "Bench data and identification",
     "The embedded synthetic bench data (21 sine tests, hidden backlash) and the paper's "
     "friction identification on it (`ehsa-opt identify`)."),
    ("discrepancy", "Model discrepancy",
     "The effects the base model misses, found, named and judged on held-out tests "
     "(`ehsa-opt discrepancy`), on the synthetic data and on the real EMPS benchmark."),
    ("vehicle", "Quarter car",
     "The harvester in a quarter car on ISO 8608 roads (`ehsa-opt simulate`), the paper's "
     "Figs 13–16 and 21."),
    ("design", "Optimal design",
     "Goal attainment and the NSGA-II Pareto front (`ehsa-opt optimize`), friction on the "
     "optimum and the design with friction in the loop (`ehsa-opt sweep`)."),
    ("emps", "The real EMPS data",
     "Friction identification on the EMPS ball-screw benchmark (Janot et al. 2019)."),
)

_ID = "guide/identify.md"
_DIS = "guide/discrepancy.md"
_SIM = "guide/simulate.md"
_OPT = "guide/optimize.md"
_SWEEP = "guide/sweep.md"

#: Section anchor → its figures.
FIGURES: dict[str, tuple[Figure, ...]] = {
    "bench": (
        Figure("figures/bench_truth_fit.png", "The bench model with the true friction",
               "One test (1.5 Hz, 47 Ω): measured force and voltage against the rigid "
               "bench model (no backlash) simulated with the data's true friction. The "
               "short force peaks after each velocity reversal are the hidden backlash the "
               "rigid model lacks.",
               "guide/bench.md"),
        Figure("figures/identify_prototype/fig08_objective_iterations.png",
               "Objective per iteration (paper Fig 8)",
               "IPOPT iterations of one test's fit (2 Hz, 47 Ω): the normalised rms force "
               "and voltage errors and the scaled objective. The fit settles in about ten "
               "iterations.", _ID),
        Figure("figures/identify_prototype/fig09_parameter_iterations.png",
               "Parameters per iteration (paper Fig 9)",
               "The eight friction parameters of the same fit at every IPOPT iteration.",
               _ID),
        Figure("figures/identify_prototype/fig10_objective_vs_tv.png",
               "Objective against the bearing viscous coefficient (paper Fig 10)",
               "Final objective of every multistart point of every test against the "
               "bearing viscous coefficient (a star marks the start kept). A flat spread "
               "means the data hardly determine the parameter.", _ID),
        Figure("figures/identify_prototype/fig11_measured_vs_simulated.png",
               "Measured against simulated (paper Fig 11)",
               "Force and voltage of one test (2 Hz, 47 Ω), measured and simulated with "
               "the identified friction; δ_F and δ_V are the paper's error measures. The "
               "identified model misses the backlash peaks.", _ID),
        Figure("figures/identify_prototype/fig12_bounds.png",
               "Identified friction per test (paper Fig 12, Table 2)",
               "Each friction parameter identified per test, with its bounds and the "
               "paper's per-parameter min/max over the tests.", _ID),
        Figure("figures/identify_prototype/identifiability.png", "Identifiability",
               "Left: the Fisher-information spectrum of every test's fit (scaled "
               "parameters) against the identifiability threshold — the small eigenvalues "
               "are directions the data do not fix. Right: each test's rod friction up to "
               "its own peak velocity: the total agrees across tests where the split "
               "between nut and bearing does not.", _ID),
        Figure("figures/identify_prototype/joint_fit_holdout.png",
               "Joint fit on a held-out test",
               "One friction set fitted to all but a few tests, judged on a held-out test "
               "(1 Hz, 15 Ω): force and voltage, measured and simulated.", _ID),
        Figure("figures/identify_prototype/friction_bounds.png",
               "Friction sets the data support",
               "Rod friction against velocity: the measured range (shaded), the best set "
               "with its 95 % band, the min/max sets of the data-supported envelope, the "
               "per-test fits and the paper's per-parameter min/max, which over-state the "
               "spread. These sets feed the vehicle studies and the design.", _ID),
    ),
    "discrepancy": (
        Figure("discrepancy/bench_prototype/figures/discrepancy_residual_maps.png",
               "Where the baseline disagrees (synthetic data)",
               "Binned mean of the force residual (measured − simulated) against velocity, "
               "time since reversal, displacement and other coordinates, for the baseline "
               "and with the effect added; a structured residual points at a missing "
               "effect.", _DIS),
        Figure("discrepancy/bench_prototype/figures/discrepancy_ranking.png",
               "Ranking of the candidates (synthetic data)",
               "Left: each candidate effect's signature score (share of the residual it "
               "explains). Right: ΔBIC of the refitted candidates on the fit and held-out "
               "tests; below zero on both is necessary for an effect to earn.", _DIS),
        Figure("discrepancy/bench_prototype/figures/discrepancy_per_test_errors.png",
               "Error per test (synthetic data)",
               "Relative force error of every test, baseline against baseline + backlash; "
               "a star marks the held-out tests, not used in the fit.", _DIS),
        Figure("discrepancy/bench_prototype/figures/discrepancy_zoom.png",
               "Zoom on a reversal (synthetic data)",
               "Force and voltage around a velocity reversal of two held-out tests: the "
               "measured backlash peak, the baseline that misses it and the model with "
               "the backlash found.", _DIS),
        Figure("discrepancy/emps/figures/discrepancy_residual_maps.png",
               "Where the baseline disagrees (EMPS)",
               "The residual maps of the real EMPS data, baseline and with the effect "
               "added.", _DIS),
        Figure("discrepancy/emps/figures/discrepancy_ranking.png",
               "Ranking of the candidates (EMPS)",
               "Signature scores and held-out ΔBIC of the candidate effects on EMPS.", _DIS),
        Figure("discrepancy/emps/figures/discrepancy_per_test_errors.png",
               "Error per test (EMPS)",
               "Relative force error on the estimation trajectory and on the held-out "
               "pulse test, baseline against baseline + asymmetric friction.", _DIS),
        Figure("discrepancy/emps/figures/discrepancy_zoom.png", "Zoom (EMPS)",
               "Force on a pulse edge of the held-out test and on a stretch of the "
               "estimation trajectory: measured, baseline and with the effect found.",
               _DIS),
    ),
    "vehicle": (
        Figure("figures/qc_wk.png", "The ISO 2631 W_k comfort weighting",
               "The exact W_k filter, the 6-state fit used in the time domain and the "
               "values tabulated in ISO 2631-1: comfort is the W_k-weighted rms "
               "acceleration.", _SIM),
        Figure("figures/qc_overview.png", "A quarter-car simulation",
               "Class C road at the reference speed with the prototype harvester: road and "
               "sprung displacement, harvested power, sprung acceleration and the damper "
               "force against stroke velocity.", _SIM),
        Figure("figures/fig13_frequency_response.png",
               "Frequency responses with friction (paper Fig 13)",
               "Generator voltage and sprung displacement against road frequency for "
               "three loads, without friction and with the data-supported min/max "
               "friction (a mean-of-steady-state under a constant displacement "
               "amplitude).", _SIM),
        Figure("figures/fig14_force_velocity.png",
               "Force–velocity loops (paper Fig 14)",
               "Harvester force against stroke velocity, open and short circuit, without "
               "and with friction, and the equivalent damping slopes.", _SIM),
        Figure("figures/fig15_passenger_car.png", "Passenger car on a class C road (paper Fig 15)",
               "Road spectrum, time histories, power spectra and the force–velocity "
               "scatter of the passenger car at 100 km/h, with no/min/max friction at "
               "equal damping slopes.", _SIM),
        Figure("figures/fig16_single_seater.png", "Single seater on a class C road (paper Fig 16)",
               "The same study for the single-seater race car.", _SIM),
        Figure("figures/fig21_power_history.png", "Power of the optimised design (paper Fig 21)",
               "Instantaneous harvested power of the optimised design on a class C road, "
               "with no/min/max friction, their means and the largest peak.", _SIM),
    ),
    "design": (
        Figure("figures/fig17_design_history.png", "Design variables per iteration (paper Fig 17)",
               "Goal attainment from the prototype: inertia, screw lead, generator speed "
               "constant and load resistance at each iteration.", _OPT),
        Figure("figures/fig18_equivalent_mass.png", "Equivalent mass per iteration (paper Fig 18)",
               "The harvester's equivalent mass J_t / r² along the same iterations.", _OPT),
        Figure("figures/fig19_objective_history.png", "Objectives per iteration (paper Fig 19)",
               "Comfort, road holding, power and efficiency along the goal-attainment "
               "iterations.", _OPT),
        Figure("figures/pareto_projections.png", "The Pareto front in two dimensions",
               "2-D projections of the NSGA-II front (all objectives minimised: comfort, "
               "road holding, 1/power, 1/efficiency), with the knee pick, the goal-"
               "attainment optimum and the prototype.", _OPT),
        Figure("figures/pareto_parallel.png", "The Pareto front in parallel coordinates",
               "Every design of the front across its design variables and objectives "
               "(colour: comfort), with the knee pick and the goal-attainment optimum.",
               _OPT),
        Figure("figures/pareto_hypervolume.png", "Convergence of the front",
               "Hypervolume of the normalised front against objective evaluations, of the "
               "population front and of all designs evaluated.", _OPT),
        Figure("figures/fig20_friction_on_optimum.png", "Friction on the optimum (paper Fig 20)",
               "Power, efficiency, comfort and road-holding change of the optimised design "
               "against speed, without friction and with the min/max friction.", _OPT),
        Figure("figures/robust_fronts.png", "Fronts with friction in the loop",
               "Power against comfort and road holding: the frictionless front and the "
               "friction-aware front, both evaluated with friction (worst of min/max), "
               "and their goal-attainment optima.", _SWEEP),
        Figure("figures/robust_design_space.png", "The optimum against speed",
               "Optimal screw lead and load resistance against vehicle speed for no, min "
               "and max friction: how far friction moves the design.", _SWEEP),
    ),
    "emps": (
        Figure("figures/identify_emps/fig08_objective_iterations.png",
               "Objective per iteration (EMPS)",
               "IPOPT iterations of the fit on the EMPS estimation trajectory.", _ID),
        Figure("figures/identify_emps/fig09_parameter_iterations.png",
               "Parameters per iteration (EMPS)",
               "The friction parameters, inertia and offset along the same fit.", _ID),
        Figure("figures/identify_emps/fig11_measured_vs_simulated.png",
               "Measured against simulated (EMPS)",
               "The EMPS estimation trajectory: measured force and the identified model.",
               _ID),
        Figure("figures/identify_emps/identifiability.png", "Identifiability (EMPS)",
               "Fisher-information spectrum of the EMPS fit and the rod friction it "
               "implies.", _ID),
    ),
}


def report_figures(reference: Path = REFERENCE) -> list[str]:
    """The figures ``REPORT.md`` of ``reference`` shows, in order (relative paths)."""
    text = (reference / "REPORT.md").read_text(encoding="utf-8")
    return re.findall(r"!\[[^\]]*\]\(([^)\s]+\.png)\)", text)


def check(reference: Path = REFERENCE) -> list[str]:
    """What is wrong between the captions and the report (empty when they agree): a
    report figure without caption, a caption of a missing file, a duplicate."""
    listed = [f.path for figs in FIGURES.values() for f in figs]
    problems = [f"{p}: listed twice" for p in sorted({p for p in listed if listed.count(p) > 1})]
    problems += [f"{p}: no such file in {reference}" for p in listed
                 if not (reference / p).is_file()]
    problems += [f"{p}: in REPORT.md but without a caption in tools/gallery.py"
                 for p in report_figures(reference) if p not in listed]
    problems += [f"section {k!r}: not in SECTIONS" for k in FIGURES
                 if k not in {s[0] for s in SECTIONS}]
    return problems


def markdown(image_prefix: str = SITE_DIR + "/", guide_prefix: str = "") -> str:
    """The gallery as Markdown: per section a heading, its sentence, and per figure a
    title, the image (linked to the full-size file), the caption and the guide."""
    out = []
    for anchor, heading, about in SECTIONS:
        out += [f"## {heading} {{#{anchor}}}", "", about, ""]
        for f in FIGURES.get(anchor, ()):
            src = image_prefix + f.path
            out += [f"### {f.title}", "",
                    f"[![{f.title}]({src}){{ loading=lazy }}]({src})", "",
                    f"{f.caption} *Command:* [{Path(f.guide).stem.replace('_', '-')}]"
                    f"({guide_prefix}{f.guide}); file `results/reference/{f.path}`.", ""]
    return "\n".join(out)


if __name__ == "__main__":
    found = check()
    print("\n".join(found) or f"gallery: {sum(map(len, FIGURES.values()))} figures, "
                               f"every figure of REPORT.md captioned")
    sys.exit(1 if found else 0)
