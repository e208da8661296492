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


# ------------------------------------------------------------------ reproduce
def _cmd_reproduce(args: argparse.Namespace) -> int:
    from .reproduce import reproduce
    report = reproduce(out_dir=args.out, quick=args.quick, jobs=args.jobs)
    print(f"report: {report}")
    return 0


def _cmd_simulate(args: argparse.Namespace) -> int:
    import json
    import warnings

    from .problem import load_problem
    from .quarter_car import RoadHoldingWarning, simulate_quarter_car
    prob = load_problem(args.problem)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RoadHoldingWarning)
        sim = simulate_quarter_car(prob.vehicle, prob.harvester, prob.friction, prob.road,
                                   settle_s=prob.simulation.settle_s,
                                   sample_rate_hz=prob.simulation.sample_rate_hz,
                                   base_dir=prob.base_dir, keep_series=False)
    for w in caught:
        print(f"warning: {w.message}", file=sys.stderr)
    m = sim.metrics_of(0)
    if not sim.success:
        raise ValueError(f"{args.problem}: simulation failed: {sim.message}")
    if args.json:
        out = dict(m)
        out["road"] = sim.road_source
        out["frictionless"] = prob.friction is None or prob.friction.is_frictionless
        out["wall_s"] = round(sim.stats["wall_s"], 4)
        print(json.dumps(out))
        return 0
    rows = [("comfort alpha (-)", m["comfort"]),
            ("W_k-weighted rms acceleration (m/s^2)", m["comfort_weighted_rms_m_s2"]),
            ("road holding (-)", m["road_holding"]),
            ("power in R_e (W)", m["power_W"]),
            ("power, dimensionless (-)", m["power_dimensionless"]),
            ("efficiency (%)", 100.0 * m["efficiency"]),
            ("power absorbed by the damper (W)", m["dissipated_power_W"]),
            ("dissipation bound (W)", m["dissipation_bound_W"]),
            ("peak power (W)", m["peak_power_W"]),
            ("energy balance residual (%)", 100.0 * m["energy_residual"])]
    print(f"{args.problem}: {sim.road_source}, "
          f"{'frictionless' if prob.friction is None else 'with friction'}, "
          f"{sim.stats['steps']} steps in {sim.stats['wall_s']:.2f} s")
    for label, value in rows:
        print(f"  {label:<40s} {'n/a' if value is None else format(value, '.4g')}")
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

    s = sub.add_parser("simulate", help="simulate a quarter car with the harvester on a road")
    s.add_argument("problem", metavar="PROBLEM.toml")
    s.add_argument("--json", action="store_true", help="print one JSON object of metrics")
    s.set_defaults(func=_cmd_simulate)

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
