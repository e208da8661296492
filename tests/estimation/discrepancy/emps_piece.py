"""A piece of the embedded EMPS estimation record with its rigid baseline fitted: the
shared start of the tests that make synthetic drive-side data from the real motion."""

from dataclasses import replace

from ehsa_opt.datasets.bench_format import load_bench
from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.estimation.discrepancy.fit import fit_group
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.estimation.discrepancy.rig import Rig, linear_baseline


def emps_piece(start: int, stop: int):
    """``(prepared test, rig without generator, baseline parameters)`` of samples
    ``start:stop`` of the first EMPS record."""
    data = load_bench(embedded_data_dir("emps"))
    t0 = data.tests[0]
    k = slice(start, stop)
    test = replace(t0, time_s=t0.time_s[k], displacement_m=t0.displacement_m[k],
                   force_N=t0.force_N[k])
    rig = Rig(data.harvester, False, ())
    pt = prepare_tests([test], False)[0]
    base = dict(fit_group([pt], rig, [linear_baseline([pt], rig)]).parameters)
    return pt, rig, base
