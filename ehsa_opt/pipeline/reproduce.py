"""``ehsa-opt reproduce``: the paper end to end on the embedded data, one report.

The pipeline is a list of :class:`Step` s.  Each step gets a :class:`Context`
(output folder, quick flag, jobs, results of earlier steps), returns a
:class:`StepOutput` (Markdown section, figures, JSON-able results), and is cached
in ``OUT/cache/<step>.json`` under a hash of its inputs: a re-run after an
interruption skips finished steps (the log says so) and gives the same report.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any, Callable

from ..utils.io import atomic_write_bytes, atomic_write_text
from ..utils.progress import progress_bar
from ..utils.version import __version__
from .background import BackgroundStep, runs_in_background, shared_jobs
from .base import Context, Step, StepOutput, code_digest, data_digest, hash_json
from .bench_report import step_bench_truth, step_data, step_harvester

__all__ = ["Step", "StepOutput", "Context", "STEPS", "reproduce", "atomic_write_text",
           "atomic_write_bytes"]


def _identify_steps():
    from . import identify_report
    return identify_report


def _quarter_car_step(name: str, ctx: Context) -> StepOutput:
    from . import quarter_car_report
    return getattr(quarter_car_report, name)(ctx)


def _qc_inputs(ctx: Context) -> Any:
    from .quarter_car_report import friction_inputs
    return friction_inputs(ctx)


def _design_steps() -> list[Step]:
    from .design_problem import design_inputs
    from .design_report import (step_friction_on_optimum, step_goal_attainment, step_pareto)
    from .invariants_report import step_paper_invariants
    from .motor_design_report import step_motor_design
    return [
        Step("design", "Optimal design by goal attainment (paper §4.2, Figs 17–19)",
             step_goal_attainment, design_inputs),
        Step("design_motor", "Design with real hardware: motor, winding and screw from "
             "catalogues with their limits, against the paper's fixed winding",
             step_motor_design, design_inputs),
        Step("design_pareto", "Pareto front of the design problem (NSGA-II)", step_pareto,
             design_inputs, depends=("design",)),
        Step("paper_invariants", "The paper's numbers through the invariants (P/η, P ∝ V, "
             "short-circuit damping)", step_paper_invariants, design_inputs),
        Step("design_friction", "Friction on the optimised design (paper Fig 20, Table 4)",
             step_friction_on_optimum, lambda ctx: [design_inputs(ctx), _qc_inputs(ctx)],
             depends=("design", "identification")),
    ]


def _robust_step(ctx: Context) -> StepOutput:
    from .robust_design_report import step_robust_design
    return step_robust_design(ctx)


def _robust_inputs(ctx: Context) -> Any:
    from .robust_design_report import robust_inputs
    return robust_inputs(ctx)


def _step_discrepancy(ctx: Context) -> StepOutput:
    from .discrepancy_report import step_discrepancy  # lazy: heavy imports only when run
    return step_discrepancy(ctx)


def _step_discrepancy_emps(ctx: Context) -> StepOutput:
    from .discrepancy_report import step_discrepancy_emps
    return step_discrepancy_emps(ctx)


#: The pipeline, in order: bench data and model (§2) → identification (§3) → discrepancy
#: (backlash; EMPS asymmetric friction) → §4.1 studies → design (§4.2) → friction on the
#: optimum (Fig 20, Table 4, Fig 21) → real EMPS identification.
STEPS: list[Step] = [
    Step("data", "Bench data", step_data,
         lambda ctx: [data_digest(ctx_path) for ctx_path in _data_paths(ctx)]),
    Step("harvester", "Harvester equivalent quantities (paper Eqs 1–3)", step_harvester,
         lambda ctx: ctx.inputs()),
    Step("bench_truth", "Bench model against the data", step_bench_truth,
         lambda ctx: data_digest(_data_paths(ctx)[0])),
    Step("identification", "Friction identification on the bench data "
         "(paper §3, Table 2, Figs 8–12)",
         lambda ctx: _identify_steps().step_identify_prototype(ctx),
         lambda ctx: data_digest(_data_paths(ctx)[0])),
    Step("discrepancy", "Model discrepancy: find, name and add the missing effect",
         _step_discrepancy, lambda ctx: data_digest(_data_paths(ctx)[0]), background=True),
    Step("discrepancy_emps", "Model discrepancy on the real EMPS data",
         _step_discrepancy_emps, lambda ctx: data_digest(_data_paths(ctx)[1]),
         background=True),
    Step("qc_paths", "Quarter car: W_k, frequency vs time domain, dissipation bound",
         lambda ctx: _quarter_car_step("step_quarter_car_paths", ctx),
         lambda ctx: [ctx.quick, ctx.inputs()]),
    Step("qc_fig13", "Quarter car: frequency responses, no/min/max friction (paper Fig 13)",
         lambda ctx: _quarter_car_step("step_fig13", ctx), _qc_inputs,
         depends=("identification",)),
    Step("qc_fig14", "Harvester force–velocity loops and equivalent damping (paper Fig 14)",
         lambda ctx: _quarter_car_step("step_fig14", ctx), _qc_inputs,
         depends=("identification",)),
    Step("qc_fig15_16", "Class C at 100 km/h with equal damping slopes (paper Figs 15/16)",
         lambda ctx: _quarter_car_step("step_fig15_16", ctx), _qc_inputs,
         depends=("identification",)),
    *_design_steps(),
    Step("robust_design", "Design with friction in the loop (fast friction-aware path, "
         "robust optimum, price of ignoring friction)", lambda ctx: _robust_step(ctx),
         lambda ctx: _robust_inputs(ctx), depends=("design", "identification")),
    Step("qc_fig21", "Power time history of the optimised design (paper Fig 21)",
         lambda ctx: _quarter_car_step("step_fig21", ctx), _qc_inputs,
         depends=("identification", "design")),
    Step("identify_emps", "Friction identification on the real EMPS data",
         lambda ctx: _identify_steps().step_identify_emps(ctx),
         lambda ctx: data_digest(_data_paths(ctx)[1])),
]

#: Steps that only make sense on the embedded data (EMPS beside its published reference).
EMBEDDED_ONLY = ("discrepancy_emps", "identify_emps")


def _data_paths(ctx: Context | None = None) -> list[Path]:
    from ..datasets.embedded import embedded_data_dir
    if ctx is not None and ctx.custom_data:
        return [ctx.bench_dir]
    return [embedded_data_dir("bench_prototype"), embedded_data_dir("emps")]


def _write_tables(out: Path, key: str, markdown: str) -> list[Path]:
    """Every Markdown table of a step's section as ``OUT/tables/<step>_<k>.csv``."""
    import csv
    import io
    from .base import markdown_tables
    paths = []
    for k, table in enumerate(markdown_tables(markdown), start=1):
        buf = io.StringIO()
        # a cell a spreadsheet would run as a formula is written as text
        csv.writer(buf, lineterminator="\n").writerows(
            [[f"'{c}" if c[:1] in ("=", "@") else c for c in row] for row in table])
        path = out / "tables" / f"{key}_{k}.csv"
        atomic_write_text(path, buf.getvalue())
        paths.append(path)
    return paths


def reproduce(out_dir: str | Path = "results/latest", quick: bool = False, jobs: int = 2,
              steps: list[Step] | None = None, log: Callable[[str], None] | None = None,
              data_dir: str | Path | None = None, vehicle: str | Path | None = None,
              friction_bounds: str = "data") -> Path:
    """Run the pipeline and write ``OUT/REPORT.md`` (every table also as
    ``OUT/tables/<step>_<k>.csv``); returns its path.

    Steps whose inputs did not change since a previous run in the same ``out_dir``
    are taken from ``OUT/cache`` (logged as cached) after verifying each entry
    (:class:`~.cache.StepCache`: digest, step, inputs, figures); one run per folder
    (:func:`~ehsa_opt.utils.lock.output_lock`); a non-empty folder ehsa-opt did not write
    is refused (:mod:`~ehsa_opt.utils.output_folder`).  ``data_dir``: a user's bench
    data directory instead of the embedded data (validated first); ``vehicle``: a
    problem file whose ``preset`` / ``[vehicle]`` replaces the passenger car;
    ``friction_bounds``: "data" (data-supported min/max friction sets, default) or
    "paper" (the paper's per-parameter min/max) for the §4 studies and the design.
    """
    from ..utils.lock import output_lock
    from ..utils.output_folder import claimed
    from ..utils.process import single_threaded_blas
    with claimed(out_dir, produces=("REPORT.md",)), output_lock(out_dir), \
            single_threaded_blas():  # parallel by processes (jobs)
        return _reproduce(out_dir, quick, jobs, steps, log, data_dir, vehicle, friction_bounds)


def _reproduce(out_dir: str | Path, quick: bool, jobs: int, steps: list[Step] | None,
               log: Callable[[str], None] | None, data_dir: str | Path | None = None,
               vehicle: str | Path | None = None, friction_bounds: str = "data") -> Path:
    from .cache import StepCache, remove_stale_temp_files
    from tqdm.auto import tqdm
    log = log or tqdm.write  # prints above the progress bar
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ctx = Context(out, quick, jobs, data_dir=None if data_dir is None else Path(data_dir),
                  vehicle_file=None if vehicle is None else Path(vehicle),
                  friction_bounds=friction_bounds)
    if data_dir is not None:
        ctx.bench()  # refuses bad data (file, row, fix) before any step runs or file goes
    if vehicle is not None:
        ctx.vehicle()
    cache = StepCache(out, log)
    for f in remove_stale_temp_files(out):  # we hold the lock: nobody else writes here
        log(f"removed {f} (a partial write of an interrupted run)")
    if steps is None:
        steps = [s for s in STEPS if not (ctx.custom_data and s.key in EMBEDDED_ONLY)]
    sections: list[str | None] = []
    hashes: dict[str, str] = {}
    downstream: set[str] = set()
    timings: list[tuple[str, str, float] | None] = []
    code = code_digest()
    t_all = time.perf_counter()

    def step_key(step: Step) -> str:
        # the friction-bounds choice reaches every step downstream of the identification
        if any(d == "identification" or d in downstream for d in step.depends):
            downstream.add(step.key)
        return hash_json({"step": step.key, "version": __version__, "code": code, "quick": quick,
                          "inputs": step.inputs(ctx), "depends": [hashes[d] for d in step.depends],
                          **({"friction_bounds": friction_bounds}
                             if step.key in downstream and friction_bounds != "data" else {})})

    def finish(n: int, step: Step, key: str, output: StepOutput, dt: float) -> None:
        # the results later steps see are those a resumed run would read back
        stored = cache.store(step.key, key, {"markdown": output.markdown,
                                             "figures": output.figures,
                                             "results": output.results, "seconds": dt})
        log(f"[{n}/{len(steps)}] {step.title}: done in {dt:.1f} s")
        timings[n - 1] = (step.title, "computed", dt)
        ctx.results[step.key] = stored["results"]
        _write_tables(out, step.key, stored["markdown"])
        sections[n - 1] = f"## {n}. {step.title}\n\n{stored['markdown']}"

    # steps nobody reads (the discrepancy workflow) start at once, beside the others
    background: dict[str, tuple[BackgroundStep, str]] = {}
    pending = [(step, step_key(step)) for step in steps if runs_in_background(step, steps, ctx)]
    pending = [(step, key) for step, key in pending if cache.load(step.key, key) is None]
    each, main_jobs = shared_jobs(jobs, len(pending))
    for step, key in pending:
        background[step.key] = (BackgroundStep(step, dataclasses.replace(ctx, jobs=each)), key)
        log(f"{step.title}: started beside the other steps ({each} job{'s' * (each > 1)})")
    ctx.jobs = main_jobs
    bar = progress_bar(total=len(steps), desc="reproduce", unit="step")
    try:
        for n, step in enumerate(steps, start=1):
            bar.set_postfix_str(step.key)
            sections.append(None)
            timings.append(None)
            key = hashes[step.key] = (background[step.key][1] if step.key in background
                                      else step_key(step))
            if step.key in background:
                continue  # collected below
            cached = cache.load(step.key, key)
            if cached is not None:
                log(f"[{n}/{len(steps)}] {step.title}: cached (hash {key}), not recomputed")
                timings[n - 1] = (step.title, "cached", float(cached.get("seconds", 0.0)))
                ctx.results[step.key] = cached["results"]
                _write_tables(out, step.key, cached["markdown"])
                sections[n - 1] = f"## {n}. {step.title}\n\n{cached['markdown']}"
            else:
                log(f"[{n}/{len(steps)}] {step.title} ...")
                t0 = time.perf_counter()
                output = step.run(ctx)
                finish(n, step, key, output, time.perf_counter() - t0)
            bar.update(1)
        for n, step in enumerate(steps, start=1):
            if step.key in background:
                bar.set_postfix_str(f"{step.key} (waiting)")
                output, dt = background.pop(step.key)[0].result()
                finish(n, step, hashes[step.key], output, dt)
                bar.update(1)
    finally:
        for bg, _ in background.values():  # an interrupted run: stop the children
            bg.cancel()
    bar.close()
    rows = "\n".join(f"| {t} | {how} | {sec:.1f} |" for t, how, sec in filter(None, timings))
    sections.append("## Run log\n\n| step | this run | compute time (s) |\n|---|---|---|\n"
                    + rows + "\n")
    mode = "quick" if quick else "full"
    head = ("# ehsa_opt reproduction report\n\nBowen, Viñolas & Olazagoitia (2019), *The "
            "influence of friction parameters in a ball-screw energy-harvesting shock "
            "absorber*, reproduced on "
            + (f"the bench data in `{ctx.bench_dir}`" if ctx.custom_data else "the embedded data")
            + (f" with the vehicle of `{ctx.vehicle_file}`" if ctx.vehicle_file else "")
            + (", min/max friction by the paper's per-parameter method"
               if friction_bounds == "paper" else "")
            + f" ({mode} mode, ehsa_opt {__version__}). Every table is also a CSV file in "
            f"`tables/` (`<step>_<k>.csv`).\n\n")
    report = out / "REPORT.md"
    atomic_write_text(report, head + "\n".join(filter(None, sections)))
    log(f"report written in {time.perf_counter() - t_all:.1f} s: {report}")
    return report
