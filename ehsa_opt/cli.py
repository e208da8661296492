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


# ------------------------------------------------------------------ identify
def _cmd_identify(args: argparse.Namespace) -> int:
    import json

    from .data import load_bench
    from .identify import identify
    from .progress import progress_bar
    from .reproduce import atomic_write_text

    data = load_bench(args.data_dir)  # refuses bad data before any solve
    out = Path(args.out)
    with progress_bar(total=len(data.tests), desc="identify", unit="test") as bar:
        rep = identify(data, starts=args.starts, jobs=args.jobs, seed=args.seed,
                       progress=lambda k: bar.update(1))
    out.mkdir(parents=True, exist_ok=True)
    rep.plot(out)
    atomic_write_text(out / "identification.json", json.dumps(rep.to_json(), indent=1))
    ok = sum(f.success for f in rep.fits)
    print(f"identified {ok}/{len(rep.fits)} tests in {rep.seconds:.1f} s "
          f"({args.starts} starts each); results in {out / 'identification.json'}")
    for t, f in zip(data.tests, rep.fits):
        if f.success:
            dv = f"{f.delta_V:.4f}" if f.delta_V is not None else "—"
            print(f"  {t.file}: δ_F {f.delta_F:.4f}  δ_V {dv}  force error "
                  f"{f.force_relative_error_percent:.2f} %  ({f.status})")
        else:
            print(f"  {t.file}: FAILED ({f.message})")
    if not data.has_generator and rep.fits[0].success:
        p = rep.fits[0].parameters
        print(f"  M = {p['inertia_kg']:.2f} kg, F_v = {p['nut_viscous_Ns_per_m']:.1f} N s/m, "
              f"F_C = {p['nut_coulomb_N']:.2f} N, offset = {p['offset_N']:.2f} N")
    return 0 if ok else 1


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

    i = sub.add_parser("identify", help="identify the friction of every bench test (paper §3)")
    i.add_argument("data_dir", metavar="DATA_DIR")
    i.add_argument("--out", required=True, metavar="OUT_DIR",
                   help="output folder (identification.json and figures)")
    i.add_argument("--starts", type=int, default=4, help="multistart points per test (default 4)")
    i.add_argument("--jobs", type=int, default=1, help="parallel processes (default 1)")
    i.add_argument("--seed", type=int, default=0, help="seed of the start draws (default 0)")
    i.set_defaults(func=_cmd_identify)

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
