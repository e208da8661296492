"""Command-line interface ``ehsa-opt`` — a thin layer over the public API.

Every subcommand parses its arguments, calls one library function and prints a
short summary.  Input errors exit with status 2 and a message that says what to
fix; nothing is written half-way.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Callable, Sequence

from . import FRICTION_LAWS, BenchDataError, ParameterError
from .utils.cli_args import (  # argument types and up-front checks
    NON_NEGATIVE as _NON_NEGATIVE,
    POSITIVE as _POSITIVE,
    UsageError as _UsageError,
    bounded as _bounded,
    cap_jobs as _cap_jobs,
    check_outputs as _check_outputs,
    non_negative_float as _NON_NEGATIVE_FLOAT,
    os_error_message as _os_error_message,
)

__all__ = ["main", "build_parser"]

#: Upper bounds of the size arguments (beyond them a run would not finish or not fit).
_MAX_POP, _MAX_GENS, _MAX_STARTS = 10_000, 100_000, 1_000


_OVERWRITE_HELP = ("write into a non-empty folder ehsa-opt did not write (it still never "
                   "replaces a file its manifest does not list)")


def _writes_folder(p: argparse.ArgumentParser, *produces: str) -> None:
    """The command writes the folder ``--out``: ``--overwrite`` and the paths it always
    writes (checked against the folder's manifest before any work)."""
    p.add_argument("--overwrite", action="store_true", help=_OVERWRITE_HELP)
    p.set_defaults(produces=produces)


# ------------------------------------------------------------------ bench
def _cmd_bench_generate(args: argparse.Namespace) -> int:
    from . import generate_bench
    from .utils.progress import progress_bar
    command = "ehsa-opt bench generate " + " ".join(
        [args.out_dir] + [f"--effect {e}" for e in args.effect]
        + [f"--effect-param {e}" for e in args.effect_param]
        + [f"--seed {args.seed}", f"--noise-force-N {args.noise_force_N:g}",
           f"--noise-voltage-V {args.noise_voltage_V:g}", f"--cycles {args.cycles:g}"]
        + [f"--harvester {h}" for h in args.harvester]
        + [f"--amplitude-m {a:g}" for a in args.amplitude_m]
        + [f"{o} '{v}'" for o, v in (("--frequencies-hz", args.frequencies_hz),
                                      ("--loads-ohm", args.loads_ohm)) if v is not None]
        + [f"--protocol '{p}'" for p in args.protocol])
    with progress_bar(desc="bench tests", unit="test") as bar:
        def tick(done: int, total: int) -> None:
            bar.total, bar.n = total, done
            bar.refresh()
        bench = generate_bench(
            effects=args.effect, effect_params=args.effect_param, harvester=args.harvester,
            frequencies_hz=args.frequencies_hz, loads_ohm=args.loads_ohm,
            amplitudes_m=args.amplitude_m, protocols=args.protocol, seed=args.seed,
            noise_force_N=args.noise_force_N, noise_voltage_V=args.noise_voltage_V,
            cycles=args.cycles, command=command, progress=tick)
    out = bench.save(args.out_dir, overwrite=args.overwrite)
    print(f"wrote {len(bench.tests)} tests to {out} (truth in {Path(out) / 'truth.toml'})")
    return 0


def _cmd_bench_check(args: argparse.Namespace) -> int:
    from . import check_bench
    print(check_bench(args.data_dir, lenient=args.lenient).summary())
    return 0


def _cmd_bench_convert_emps(args: argparse.Namespace) -> int:
    from . import convert_emps
    out = convert_emps(args.source_dir).save(args.out_dir, overwrite=args.overwrite)
    print(f"wrote EMPS bench data to {out}")
    return 0


# ------------------------------------------------------------------ design
def _cmd_optimize(args: argparse.Namespace) -> int:
    import contextlib

    from . import load_problem, optimize
    from .utils.progress import progress_bar
    problem = load_problem(args.problem, friction=args.friction,
                           friction_mode=args.friction_mode)
    nsga2 = (args.method or problem.config.method) == "nsga2"
    bar_cm = (progress_bar(total=args.gens or problem.config.nsga2.gens, desc="generations",
                           unit="gen") if nsga2 else contextlib.nullcontext())
    with bar_cm as bar:
        def tick(done: int, total: int | None) -> None:
            if bar is not None:
                bar.n = done
                bar.refresh()
        result = optimize(problem, termination=("n_gen", args.gens) if args.gens else None,
                          seed=args.seed, method=args.method or problem.config.method,
                          pop_size=args.pop, checkpoint=args.checkpoint, resume=args.resume,
                          stop_after=args.stop_after, scheduler=args.scheduler, progress=tick)
    out = Path(args.out)
    result.save(out)
    result.write_figures(out / "figures")
    print(result.summary())
    print(f"wrote {out / 'result.json'}" + (f", {out / 'pareto.csv'}" if nsga2 else ""))
    return 0 if result.success or args.stop_after else 1


def _cmd_sweep(args: argparse.Namespace) -> int:
    from . import sweep
    result = sweep(args.problem, friction_from=args.friction, jobs=args.jobs,
                   scheduler=args.scheduler)
    out = Path(args.out)
    result.save(out)
    where = f"Dask scheduler {args.scheduler}" if args.scheduler else f"{args.jobs} local job(s)"
    print(f"{len(result.rows)} cases in {result.seconds:.2f} s on {where}; wrote "
          f"{out / 'sweep.csv'}")
    return 0


# ------------------------------------------------------------------ identify
def _cmd_identify(args: argparse.Namespace) -> int:
    from . import identify, load_bench
    from .utils.progress import progress_bar
    data = load_bench(args.data_dir, lenient=args.lenient)  # refuses bad data before solving
    with progress_bar(total=len(data.tests), desc="identify", unit="test") as bar:
        result = identify(data, starts=args.starts, jobs=args.jobs, seed=args.seed,
                          progress=lambda k: bar.update(1), friction_law=args.friction_law)
    out = Path(args.out)
    result.save(out)
    print(result.summary(out / "identification.json"))
    return 0 if result.success else 1


def _cmd_plan_tests(args: argparse.Namespace) -> int:
    from . import plan_tests
    result = plan_tests(args.identification, args.vehicle, args.rig, n_tests=args.n,
                        weight=args.weight)
    print(result.summary())
    written = result.save(args.out)
    if written:
        print(f"wrote {written[0]} (skeleton for the rig operator) and {written[1]}")
    return 0 if result.success else 1


# ------------------------------------------------------------------ discrepancy
def _cmd_discrepancy(args: argparse.Namespace) -> int:
    from . import DiscrepancySettings, discrepancy_report
    if args.dynamic_law is not None and not args.dynamic_friction:
        raise _UsageError(f"--dynamic-law {args.dynamic_law} chooses the law "
                          f"--dynamic-friction offers: add --dynamic-friction")
    members = DiscrepancySettings().candidates
    members += tuple(m for m in args.with_members if m not in members)
    settings = DiscrepancySettings(seed=args.seed, jobs=args.jobs, top=args.top,
                                   candidates=members,
                                   max_tests=args.max_tests, presliding=args.presliding,
                                   dynamic_friction=args.dynamic_friction,
                                   dynamic_law=args.dynamic_law or "lugre",
                                   scheduler=args.scheduler,
                                   **({} if args.max_fits is None
                                      else {"max_member_fits": args.max_fits or None}))
    report = discrepancy_report(args.data_dir, settings, wall_cap_s=args.wall_cap_s,
                                on_message=lambda m: print(m, flush=True))
    js, md = report.save(args.out)[:2]
    seconds = report.record.get("seconds")
    print(f"wrote {js} and {md}" + ("" if seconds is None else f" ({seconds:.0f} s)"))
    return 0 if report.success else 1


# ------------------------------------------------------------------ reproduce
def _cmd_reproduce(args: argparse.Namespace) -> int:
    from tqdm.auto import tqdm

    from . import reproduce
    reproduce(quick=args.quick, jobs=args.jobs, data=args.data, vehicle=args.vehicle,
              friction_bounds=args.friction_bounds, workdir=args.out,
              on_message=tqdm.write)  # prints above the progress bar
    print(f"report: {Path(args.out) / 'REPORT.md'}")
    return 0


def _cmd_simulate(args: argparse.Namespace) -> int:
    from . import simulate
    result = simulate(args.problem, friction=args.friction, keep_series=False)
    print(result.to_json() if args.json else result.summary())
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The ``ehsa-opt`` argument parser."""
    parser = argparse.ArgumentParser(
        prog="ehsa-opt",
        description="Identify, simulate and optimally design ball-screw energy-harvesting "
                    "shock absorbers.")
    from . import __version__
    parser.add_argument("--version", action="version", version=f"ehsa-opt {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    bench = sub.add_parser("bench", help="generate, check or convert bench data")
    bsub = bench.add_subparsers(dest="bench_command", required=True, metavar="ACTION")
    g = bsub.add_parser("generate", help="write synthetic bench data (the paper's 21 sine tests by "
                        "default; other rigs, amplitudes and non-sine protocols)")
    g.add_argument("out_dir", metavar="OUT_DIR")
    g.add_argument("--seed", type=_NON_NEGATIVE, default=0, help="noise seed (default 0)")
    from . import COMPONENTS
    g.add_argument("--effect", action="append", default=[], metavar="EFFECT",
                   help="hide a physical effect in the data (repeatable): "
                        + ", ".join(sorted(COMPONENTS)))
    g.add_argument("--effect-param", action="append", default=[], metavar="NAME=VALUE",
                   help="override an effect parameter, e.g. backlash_gap_m=2e-4")
    g.add_argument("--noise-force-N", type=float, default=2.0, help="force noise std (N)")
    g.add_argument("--noise-voltage-V", type=float, default=0.05, help="voltage noise std (V)")
    g.add_argument("--cycles", type=float, default=2.0, help="recorded cycles per test")
    for opt, hlp in (("--harvester", "harvester constant NAME=VALUE, e.g. lead_mm_per_rev=10"),
                     ("--protocol", "non-sine test (excitation = recorded) KIND:NAME=VALUE,..., "
                      "KIND triangle|trapezoid|multisine|road, e.g. triangle:load_ohm=10,"
                      "velocity_m_per_s=0.06")):
        g.add_argument(opt, action="append", default=[], help=hlp + " (repeatable)")
    g.add_argument("--frequencies-hz", help="sine frequencies, comma list ('' for none)")
    g.add_argument("--loads-ohm", help="loads of the sine tests, comma list")
    g.add_argument("--amplitude-m", action="append", type=float, default=[],
                   help="sine amplitude, m (repeatable)")
    g.add_argument("--overwrite", action="store_true", help="replace a non-empty OUT_DIR")
    g.set_defaults(func=_cmd_bench_generate)
    c = bsub.add_parser("check", help="validate a bench data directory")
    c.add_argument("data_dir", metavar="DATA_DIR")
    c.add_argument("--lenient", action="store_true",
                   help="report signals that contradict bench.toml (frequency, amplitude, "
                        "units) as warnings instead of refusing the data")
    c.set_defaults(func=_cmd_bench_check)
    e = bsub.add_parser("convert-emps", help="convert the raw EMPS CSVs to bench format")
    e.add_argument("source_dir", metavar="SOURCE_DIR")
    e.add_argument("out_dir", metavar="OUT_DIR")
    e.add_argument("--overwrite", action="store_true")
    e.set_defaults(func=_cmd_bench_convert_emps)

    o = sub.add_parser("optimize", help="optimal design: goal attainment or NSGA-II front")
    o.add_argument("problem", metavar="PROBLEM.toml")
    o.add_argument("--method", default=None,
                   help="goal-attainment or nsga2 (default: [design] method of the file)")
    o.add_argument("--pop", type=_bounded(1, _MAX_POP, "a larger front does not fit a run"),
                   default=None,
                   help="NSGA-II population (default [nsga2])")
    o.add_argument("--gens", type=_bounded(1, _MAX_GENS, "use --checkpoint and --resume"),
                   default=None, help="NSGA-II generations (total)")
    o.add_argument("--seed", type=_NON_NEGATIVE, default=None, help="NSGA-II seed")
    o.add_argument("--checkpoint", default=None, metavar="DIR",
                   help="save the NSGA-II state after every generation (atomic)")
    o.add_argument("--resume", default=None, metavar="DIR",
                   help="continue an NSGA-II run from its checkpoint")
    o.add_argument("--stop-after", type=_POSITIVE, default=None, metavar="G",
                   help="stop after G generations (as if interrupted; resume later)")
    o.add_argument("--scheduler", default=None, metavar="ADDR",
                   help="evaluate populations on a Dask cluster, e.g. tcp://127.0.0.1:8786")
    o.add_argument("--friction", action="append", default=None, metavar="ID.json[:CASE]",
                   help="design with this friction (identification result, case min|best|max;"
                        " repeatable); default: the file's [friction] table, else none")
    o.add_argument("--friction-mode", default=None, choices=("at", "worst", "mean"),
                   help="combine several friction sets: worst case (default) or mean")
    o.add_argument("--out", required=True, metavar="OUT_DIR")
    o.set_defaults(func=_cmd_optimize)
    _writes_folder(o, "result.json")

    w = sub.add_parser("sweep", help="design-space study: [sweep] grid, tidy CSV + figure")
    w.add_argument("problem", metavar="PROBLEM.toml")
    w.add_argument("--jobs", type=_POSITIVE, default=1, help="local worker processes (default 1)")
    w.add_argument("--scheduler", default=None, metavar="ADDR",
                   help="Dask scheduler address, e.g. tcp://127.0.0.1:8786")
    w.add_argument("--out", required=True, metavar="OUT_DIR")
    w.add_argument("--friction", default=None, metavar="FILE",
                   help="take the sweep's min/best/max friction sets from this "
                        "identification.json (overrides [sweep] friction_from)")
    w.set_defaults(func=_cmd_sweep)
    _writes_folder(w, "sweep.csv")

    s = sub.add_parser("simulate", help="simulate a quarter car with the harvester on a road")
    s.add_argument("problem", metavar="PROBLEM.toml")
    s.add_argument("--json", action="store_true", help="print one JSON object of metrics")
    s.add_argument("--friction", default=None, metavar="FILE[:CASE]",
                   help="friction from an identification.json (CASE min|best|max, default "
                        "best); overrides the problem file's [friction]")
    s.set_defaults(func=_cmd_simulate)
    i = sub.add_parser("identify", help="identify the friction of every bench test (paper §3)")
    i.add_argument("data_dir", metavar="DATA_DIR")
    i.add_argument("--out", required=True, metavar="OUT_DIR",
                   help="output folder (identification.json and figures)")
    i.add_argument("--starts", type=_bounded(1, _MAX_STARTS, "more starts find nothing new"),
                   default=4,
                   help="multistart points per test (default 4)")
    i.add_argument("--jobs", type=_POSITIVE, default=1, help="parallel processes (default 1)")
    i.add_argument("--seed", type=_NON_NEGATIVE, default=0,
                   help="seed of the start draws (default 0)")
    i.add_argument("--lenient", action="store_true",
                   help="use data whose signals contradict bench.toml (warnings, not errors)")
    i.add_argument("--friction-law", choices=FRICTION_LAWS, default="static",
                   help="friction law: the static Simscape map or the same map as the "
                        "steady state of a LuGre bristle (presliding) (default static)")
    i.set_defaults(func=_cmd_identify)
    _writes_folder(i, "identification.json")
    pt = sub.add_parser("plan-tests", help="propose bench tests where the road puts the strokes")
    for a, kw in (("identification", {"metavar": "ID.json"}), ("--vehicle", {"required": True}),
                  ("--rig", {"required": True}), ("--n", {"type": _POSITIVE, "default": 3}),
                  ("--out", {"default": "plan"}),
                  ("--weight", {"choices": ("energy", "time"), "default": "energy",
                                "help": "road weight of a velocity: the friction energy "
                                        "dissipated there (default) or the time"})):
        pt.add_argument(a, **kw)
    pt.set_defaults(func=_cmd_plan_tests)
    _writes_folder(pt, "bench.toml", "plan.json")
    d = sub.add_parser("discrepancy", help="find, name and add the missing effect in a model "
                                           "(localise residuals, rank candidates, re-identify)")
    d.add_argument("data_dir", metavar="DATA_DIR")
    d.add_argument("--out", required=True, metavar="OUT_DIR",
                   help="writes discrepancy.json, report.md and figures/")
    d.add_argument("--jobs", type=_POSITIVE, default=1, help="parallel candidate fits (default 1)")
    d.add_argument("--seed", type=_NON_NEGATIVE, default=0,
                   help="seed of the held-out split (default 0)")
    d.add_argument("--top", type=_POSITIVE, default=3, help="candidates re-identified (default 3)")
    d.add_argument("--max-tests", type=_POSITIVE, default=None,
                   help="use at most this many tests, spread over the grid")
    d.add_argument("--max-fits", type=_NON_NEGATIVE, default=None,
                   help="work budget: member fits the search may start (default: the "
                        "library's, DiscrepancySettings.max_member_fits; 0: none); the same "
                        "answer for any --jobs and machine load; when spent, a partial "
                        "answer, exit 1")
    d.add_argument("--wall-cap-s", "--budget-s", dest="wall_cap_s", type=_NON_NEGATIVE_FLOAT,
                   default=1800.0,
                   help="wall-time safety cap, s (default 1800; 0: none): not a budget — when "
                        "it binds, a partial answer that says it depends on the machine's "
                        "speed and load, exit 1")
    d.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="make the member fits on the Dask cluster at ADDRESS (e.g. "
                        "tcp://127.0.0.1:8786) instead of --jobs local processes; the same "
                        "answer")
    d.add_argument("--presliding", action="store_true",
                   help="offer the base friction law a presliding transition (adopted only "
                        "when it earns on the baseline; off by default)")
    d.add_argument("--dynamic-friction", action="store_true",
                   help="offer the base model the dynamic (LuGre) friction law, fitted from "
                        "the static optimum and adopted when it earns (off by default)")
    d.add_argument("--dynamic-law", choices=("lugre", "lugre_stribeck"), default=None,
                   help="the law --dynamic-friction offers: lugre (default; a bristle whose "
                        "steady state is the Simscape curve) or lugre_stribeck (the "
                        "generalised Stribeck curve, its exponent fitted)")
    d.add_argument("--with", dest="with_members", action="append", default=[],
                   metavar="MEMBER",
                   help="also search a member listed by choice (force_sensor, "
                        "voltage_sensor: a channel's second-order sensor dynamics); "
                        "repeatable")
    d.set_defaults(func=_cmd_discrepancy)
    _writes_folder(d, "report.md", "discrepancy.json")

    r = sub.add_parser("reproduce", help="reproduce the paper end to end on the embedded data "
                                         "or on your own bench data (--data)")
    r.add_argument("--data", default=None, metavar="DATA_DIR",
                   help="your bench data directory (bench.toml + CSVs; your harvester from its "
                        "[harvester]) instead of the embedded data")
    r.add_argument("--vehicle", default=None, metavar="PROBLEM.toml",
                   help="problem file whose preset / [vehicle] is the vehicle of the studies "
                        "and the design (default: passenger car)")
    r.add_argument("--friction-bounds", choices=("data", "paper"), default="data",
                   help="min/max friction sets of the studies and the design: 'data' = the "
                        "envelope of the rod friction the data support (default), 'paper' = the "
                        "paper's per-parameter min/max over the tests (over-states the spread)")
    r.add_argument("--quick", action="store_true", help="fewer starts, shorter roads (minutes)")
    r.add_argument("--out", default="results/latest", help="output folder (default results/latest)")
    r.add_argument("--jobs", type=_POSITIVE, default=2, help="parallel processes (default 2)")
    r.set_defaults(func=_cmd_reproduce)
    _writes_folder(r, "REPORT.md")
    return parser


def _shorten(message: str) -> str:
    """A message quoting a file's content stays readable: every run of more than 120
    characters without a space (an over-long field or name) is cut to its first 60."""
    import re
    return re.sub(r"\S{121,}", lambda m: f"{m.group()[:60]}...({len(m.group())} characters)",
                  message)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``ehsa-opt`` console script."""
    from .utils.log import stderr_handler
    with stderr_handler():  # the library's warnings (``ehsa_opt`` logger), lines on stderr
        return _main(argv)


def _main(argv: Sequence[str] | None = None) -> int:
    """Parse, run the command, turn input errors into exit status 2."""
    parser = build_parser()
    args = parser.parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    from .utils.process import die_with_parent, single_threaded_blas
    die_with_parent()  # pool workers forked from here on die with this process
    # our parallelism is by processes (--jobs): a multi-threaded BLAS beside them, or
    # beside other work on the machine, spins its threads (10x the CPU of a rod-law fit)
    with single_threaded_blas():
        return _run(func, args)


def _run(func: Callable[[argparse.Namespace], int], args: argparse.Namespace) -> int:
    """Run the parsed command: output locks, errors as messages and exit codes."""
    try:
        _check_outputs(args)
        _cap_jobs(args)
        folders = [getattr(args, a, None) for a in ("out", "checkpoint")]
        if getattr(args, "resume", None) and not getattr(args, "checkpoint", None):
            folders.append(args.resume)  # checkpoints go back into --resume
        folders = [f for f in folders if isinstance(f, str) and f]
        if not folders:
            return func(args)
        import contextlib

        from .utils.lock import LOCK_NAME, output_lock
        from .utils.output_folder import claimed
        created = {f: not Path(f).exists() for f in folders}
        try:
            with contextlib.ExitStack() as stack:
                if getattr(args, "produces", None) is not None:  # never a folder of the user's
                    stack.enter_context(claimed(args.out, overwrite=args.overwrite,
                                                produces=args.produces))
                for f in folders:  # one run per output and checkpoint folder
                    stack.enter_context(output_lock(f))
                return func(args)
        finally:  # a refused run leaves no empty folder behind
            for f, new in created.items():
                if new and Path(f).is_dir() and \
                        [g.name for g in Path(f).iterdir()] == [LOCK_NAME]:
                    (Path(f) / LOCK_NAME).unlink(missing_ok=True)
                    Path(f).rmdir()
    except (BenchDataError, ParameterError, _UsageError, FileExistsError, ValueError) as exc:
        print(f"error: {_shorten(str(exc))}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"error: {_os_error_message(exc)}", file=sys.stderr)
        return 2
    except MemoryError:
        print("error: out of memory; reduce the problem (shorter road, lower sample rate, "
              "fewer tests or designs, --jobs 1) or run on a machine with more memory",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\ninterrupted: finished steps and checkpoints are kept; run the same command "
              "again to resume", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
