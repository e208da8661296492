"""The EMPS real ball-screw data set (Janot, Gautier & Brunot 2019), converted to the
bench format: displacement = measured load-side position, force =
g_τ × controller output voltage, no voltage column (the rig has no generator).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .bench_format import BenchTest, write_bench

__all__ = ["GAIN_N_PER_V", "EMPS_REFERENCE", "read_emps", "convert_emps"]

#: Drive gain g_τ (N/V): force on the load side = g_τ × controller voltage.
GAIN_N_PER_V = 35.15065188248547

#: Published reference (inverse model, least squares; Janot et al. 2019).
EMPS_REFERENCE = {
    "inertia_kg": 95.11, "viscous_Ns_per_m": 203.5, "coulomb_N": 20.39, "offset_N": -3.16,
    "force_relative_error_percent": 4.08,
    "direction_dependent": {"viscous_pos_Ns_per_m": 166.7, "viscous_neg_Ns_per_m": 240.4,
                            "coulomb_pos_N": 20.14, "coulomb_neg_N": 20.63,
                            "force_relative_error_percent": 3.11},
}

CITATION = ("A. Janot, M. Gautier, M. Brunot, 'Data Set and Reference Models of EMPS', "
            "2019 Workshop on Nonlinear System Identification Benchmarks, Eindhoven.")


def _read(path: Path, columns: tuple[str, ...], min_columns: int) -> np.ndarray:
    """A raw EMPS CSV, validated before anything is written: the header, at least
    ``len(columns)`` numeric columns, enough rows, finite values, increasing time."""
    from .bench_format import BenchDataError, read_number_table
    where = str(path)
    arr, header = read_number_table(path, min_columns=min_columns)
    if header[:len(columns)] != list(columns):
        raise BenchDataError(f"{where}: row 1 (header): expected the columns "
                             f"{','.join(columns)}, found {','.join(header)}; give the raw EMPS "
                             f"file")
    if arr.shape[0] < 5:
        raise BenchDataError(f"{where}: only {arr.shape[0]} data rows; at least 5 are needed")
    dt = np.diff(arr[:, 0])
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0))
        raise BenchDataError(f"{where}: row {k + 3}: time_s = {arr[k + 1, 0]:g} does not "
                             f"increase (previous row {arr[k, 0]:g}); time must be strictly "
                             f"increasing")
    return arr


_EST_COLUMNS = ("time_s", "position_m", "reference_position_m", "control_voltage_V")


def read_emps(source_dir: str | Path) -> tuple[BenchTest, BenchTest, dict, str]:
    """The raw EMPS files of ``source_dir`` as bench tests: the estimation test, the
    validation test (the force contains the pulses), the ``[rig]`` table and the text of
    ``pulses.csv`` (the pulse signal, a 0/5 square wave that the benchmark calls
    ``pulses_N``; at each edge the recorded force steps by g_tau x 5 V, so it is 5 V added
    to the controller output, already contained in the force — a marker of the pulse
    edges, not a missing force).  Both sources are validated (header, columns, rows,
    finite values, increasing time); nothing is written."""
    src = Path(source_dir)
    est = _read(src / "emps_estimation.csv", _EST_COLUMNS, 4)
    val = _read(src / "emps_validation_pulses.csv", _EST_COLUMNS, 5)  # + the pulse force
    rig = {"name": "EMPS", "has_generator": False,
           "description": "Electro-Mechanical Positioning System (Maxon DC motor + Star ball "
                          "screw + load), 1 kHz; force = g_tau * controller voltage, g_tau = "
                          f"{GAIN_N_PER_V} N/V. {CITATION}"}
    test = BenchTest(file="emps_estimation.csv", frequency_hz=None, amplitude_m=None,
                     load_ohm=None, excitation="recorded", time_s=est[:, 0],
                     displacement_m=est[:, 1], force_N=GAIN_N_PER_V * est[:, 3],
                     description="estimation trajectory (position-controlled, ~25 s)")
    vtest = BenchTest(file="emps_validation_pulses.csv", frequency_hz=None, amplitude_m=None,
                      load_ohm=None, excitation="recorded", time_s=val[:, 0],
                      displacement_m=val[:, 1], force_N=GAIN_N_PER_V * val[:, 3],
                      description="validation with pulses: a 0/5 V square wave (period 1 s) "
                                  "added to the controller output, so each of its 49 edges "
                                  "steps the recorded force by g_tau x 5 V = 176 N; the force "
                                  "here contains the pulses, pulses.csv marks them")
    pulses = "time_s,pulse_V\n" + "\n".join(
        f"{t:.9g},{f:.9g}" for t, f in zip(val[:, 0], val[:, 4])) + "\n"
    return test, vtest, rig, pulses


def convert_emps(source_dir: str | Path, out_dir: str | Path, overwrite: bool = False) -> Path:
    """Convert ``emps_estimation.csv`` (and the validation set) to bench format.

    Writes ``out_dir/bench.toml`` + ``emps_estimation.csv`` and
    ``out_dir/validation/`` with the pulse test and ``pulses.csv``
    (:func:`read_emps`); an existing ``README.md`` of ``out_dir`` is kept.  Both sources
    are validated before anything is written.
    """
    from .bench_format import write_marker
    test, vtest, rig, pulses = read_emps(source_dir)
    out = Path(out_dir)
    readme = (out / "README.md").read_text() \
        if (out / "README.md").is_file() and not (out / "README.md").is_symlink() else ""
    write_bench(out, [test], rig=rig, overwrite=overwrite,
                extra_files={"README.md": readme} if readme else None)
    write_bench(out / "validation", [vtest], rig=rig, overwrite=True,
                extra_files={"pulses.csv": pulses})
    write_marker(out)  # the validation folder is ours too
    return out
