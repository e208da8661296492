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

from .data import BenchDataError
from .params import ParameterError

__all__ = ["main", "build_parser"]


class _UsageError(Exception):
    """A CLI-level input error (printed without a traceback)."""


def _parse_effect_params(items: Sequence[str]) -> dict[str, float]:
    out = {}
    for item in items:
        if "=" not in item:
            raise _UsageError(f"--effect-param '{item}': write NAME=VALUE, e.g. "
                              f"backlash_gap_m=1e-4")
        k, v = item.split("=", 1)
        try:
            out[k.strip()] = float(v)
        except ValueError:
            raise _UsageError(f"--effect-param '{item}': '{v}' is not a number") from None
    return out


# ------------------------------------------------------------------ bench
def _cmd_bench_generate(args: argparse.Namespace) -> int:
    from .models import COMPONENTS, make_component
    from .progress import progress_bar
    from .synthetic import SyntheticSpec, write_synthetic

    effect_params = _parse_effect_params(args.effect_param)
    effects: dict[str, dict[str, float]] = {}
    for name in args.effect:
        comp = make_component(name)
        effects[name] = {k: v for k, v in effect_params.items()
                         if k in {q.name for q in comp.parameters}}
    known = {q.name for n in effects for q in COMPONENTS[n].parameters}
    unknown = set(effect_params) - known
    if unknown:
        raise _UsageError(f"--effect-param: {', '.join(sorted(unknown))} belong to no chosen "
                          f"--effect (chosen: {', '.join(effects) or 'none'})")
    spec = SyntheticSpec(effects=effects, seed=args.seed, noise_force_N=args.noise_force_N,
                         noise_voltage_V=args.noise_voltage_V, cycles=args.cycles)
    n = len(spec.frequencies_hz) * len(spec.loads_ohm)
    command = "ehsa-opt bench generate " + " ".join(
        [args.out_dir] + [f"--effect {e}" for e in args.effect]
        + [f"--effect-param {e}" for e in args.effect_param]
        + [f"--seed {args.seed}", f"--noise-force-N {args.noise_force_N:g}",
           f"--noise-voltage-V {args.noise_voltage_V:g}", f"--cycles {args.cycles:g}"])
    with progress_bar(total=n, desc="bench tests", unit="test") as bar:
        out = write_synthetic(args.out_dir, spec, command=command, overwrite=args.overwrite,
                              progress=lambda k: bar.update(1))
    print(f"wrote {n} tests to {out} (truth in {Path(out) / 'truth.toml'})")
    return 0


def _cmd_bench_check(args: argparse.Namespace) -> int:
    from .data import check_bench
    print(check_bench(args.data_dir))
    return 0


def _cmd_bench_convert_emps(args: argparse.Namespace) -> int:
    from .emps import convert_emps
    out = convert_emps(args.source_dir, args.out_dir, overwrite=args.overwrite)
    print(f"wrote EMPS bench data to {out}")
    return 0


# ------------------------------------------------------------------ discrepancy
def _cmd_discrepancy(args: argparse.Namespace) -> int:
    from .discrepancy import DiscrepancySettings, run_discrepancy
    from .discrepancy_report import write_report

    settings = DiscrepancySettings(seed=args.seed, jobs=args.jobs, top=args.top,
                                   max_tests=args.max_tests)
    res = run_discrepancy(args.data_dir, settings, log=lambda m: print(m, flush=True))
    js, md = write_report(res, args.out)
    print(f"effect: {res.effect}; relative force error on {res.evaluation}: "
          f"{res.error_before:.3f} % -> {res.error_after:.3f} %")
    print(f"wrote {js} and {md} ({res.seconds:.0f} s)")
    return 0


# ------------------------------------------------------------------ reproduce
def _cmd_reproduce(args: argparse.Namespace) -> int:
    from .reproduce import reproduce
    report = reproduce(out_dir=args.out, quick=args.quick, jobs=args.jobs)
    print(f"report: {report}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The ``ehsa-opt`` argument parser."""
    parser = argparse.ArgumentParser(
        prog="ehsa-opt",
        description="Identify, simulate and optimally design ball-screw energy-harvesting "
                    "shock absorbers.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    bench = sub.add_parser("bench", help="generate, check or convert bench data")
    bsub = bench.add_subparsers(dest="bench_command", required=True, metavar="ACTION")
    g = bsub.add_parser("generate", help="write synthetic bench data for the paper's 21 tests")
    g.add_argument("out_dir", metavar="OUT_DIR")
    g.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    g.add_argument("--effect", action="append", default=[],
                   help="hide a physical effect in the data (repeatable), e.g. backlash")
    g.add_argument("--effect-param", action="append", default=[], metavar="NAME=VALUE",
                   help="override an effect parameter, e.g. backlash_gap_m=2e-4")
    g.add_argument("--noise-force-N", type=float, default=2.0, help="force noise std (N)")
    g.add_argument("--noise-voltage-V", type=float, default=0.05, help="voltage noise std (V)")
    g.add_argument("--cycles", type=float, default=2.0, help="recorded cycles per test")
    g.add_argument("--overwrite", action="store_true", help="replace a non-empty OUT_DIR")
    g.set_defaults(func=_cmd_bench_generate)
    c = bsub.add_parser("check", help="validate a bench data directory")
    c.add_argument("data_dir", metavar="DATA_DIR")
    c.set_defaults(func=_cmd_bench_check)
    e = bsub.add_parser("convert-emps", help="convert the raw EMPS CSVs to bench format")
    e.add_argument("source_dir", metavar="SOURCE_DIR")
    e.add_argument("out_dir", metavar="OUT_DIR")
    e.add_argument("--overwrite", action="store_true")
    e.set_defaults(func=_cmd_bench_convert_emps)

    d = sub.add_parser("discrepancy", help="find, name and add the missing effect in a model "
                                           "(localise residuals, rank candidates, re-identify)")
    d.add_argument("data_dir", metavar="DATA_DIR")
    d.add_argument("--out", required=True, metavar="OUT_DIR",
                   help="writes discrepancy.json, report.md and figures/")
    d.add_argument("--jobs", type=int, default=1, help="parallel candidate fits (default 1)")
    d.add_argument("--seed", type=int, default=0, help="seed of the held-out split (default 0)")
    d.add_argument("--top", type=int, default=3, help="candidates re-identified (default 3)")
    d.add_argument("--max-tests", type=int, default=None,
                   help="use at most this many tests, spread over the grid")
    d.set_defaults(func=_cmd_discrepancy)

    r = sub.add_parser("reproduce", help="reproduce the paper end to end on the embedded data")
    r.add_argument("--quick", action="store_true", help="fewer starts, shorter roads (minutes)")
    r.add_argument("--out", default="results/latest", help="output folder (default results/latest)")
    r.add_argument("--jobs", type=int, default=2, help="parallel processes (default 2)")
    r.set_defaults(func=_cmd_reproduce)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``ehsa-opt`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except (BenchDataError, ParameterError, _UsageError, FileExistsError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
