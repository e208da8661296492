"""Bench data from a script: :func:`generate_bench`, :func:`check_bench`,
:func:`convert_emps` and their result :class:`BenchSet`.

Each returns the bench data in memory (the tests with their samples, the ``[harvester]``
and ``[rig]`` tables, the text files written beside them) and writes nothing;
:meth:`BenchSet.save` writes a bench data directory (atomically; an existing folder is
replaced only with ``overwrite`` and only when ehsa-opt wrote all of it), and
:meth:`BenchSet.load` reads one back, checked.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

from ..datasets.bench_format import (
    BenchData,
    BenchTest,
    check_summary,
    load_bench_checked,
    write_bench,
    write_marker,
)
from ..datasets.synthetic import SyntheticSpec, generate_bench_tests, spec_from_options, \
    synthetic_files
from ..physics.params import HarvesterParams
from ..utils.log import logger

__all__ = ["BenchSet", "generate_bench", "check_bench", "convert_emps"]

#: Name of the held-out sub-directory of a bench data directory (EMPS' pulse test).
VALIDATION_DIR = "validation"


@dataclass(frozen=True)
class BenchSet:
    """Bench data in memory: what a bench data directory holds.

    Attributes
    ----------
    tests : list of BenchTest
        The tests with their samples (``time_s``, ``displacement_m``, ``force_N``,
        ``voltage_V``).
    harvester : HarvesterParams or None
        The ``[harvester]`` table (None: the paper's Table 1).
    rig : dict
        The ``[rig]`` table (``name``, ``has_generator``, ``description``).
    files : dict
        Text files written beside the tests (name → content), e.g. ``truth.toml`` and
        ``README.md`` of synthetic data.
    validation : BenchSet or None
        The held-out tests of the ``validation/`` sub-directory.
    warnings : tuple of str
        What a lenient check found (signals contradicting ``bench.toml``).
    path : Path or None
        The directory it was read from (None: made in memory).
    keep : tuple of str
        Files of the target folder :meth:`save` carries over when it replaces the folder
        (EMPS keeps its ``README.md``).
    """

    tests: list[BenchTest]
    harvester: HarvesterParams | None = None
    rig: dict = field(default_factory=dict)
    files: Mapping[str, str] = field(default_factory=dict)
    validation: BenchSet | None = None
    warnings: tuple[str, ...] = ()
    path: Path | None = None
    keep: tuple[str, ...] = ()

    @property
    def data(self) -> BenchData:
        """As the :class:`BenchData` that :func:`identify` and :func:`discrepancy` take."""
        rig = self.rig or {}
        return BenchData(self.path or Path("<in memory>"), list(self.tests),
                         self.harvester or HarvesterParams(), str(rig.get("name", "")),
                         str(rig.get("description", "")),
                         bool(rig.get("has_generator", True)))

    def summary(self) -> str:
        """Tests, samples, rig and ``OK`` or the warnings (what ``ehsa-opt bench check``
        prints)."""
        return check_summary(self.data, self.warnings)

    def table(self) -> Any:
        """One row per test: file, excitation, frequency (Hz), amplitude (m), load (ohm),
        samples and duration (s)."""
        from ..utils.tables import tidy_table

        def num(v: float | None) -> float:
            return float("nan") if v is None else float(v)
        return tidy_table({
            "file": [t.file for t in self.tests],
            "excitation": [t.excitation for t in self.tests],
            "frequency_hz": [num(t.frequency_hz) for t in self.tests],
            "amplitude_m": [num(t.amplitude_m) for t in self.tests],
            "load_ohm": [num(t.load_ohm) for t in self.tests],
            "samples": [t.n_samples for t in self.tests],
            "duration_s": [float(t.time_s[-1] - t.time_s[0]) for t in self.tests]},
            {"frequency_hz": "Hz", "samples": "-", "file": "", "excitation": ""})

    def plot(self, ax: Any = None) -> Any:
        """Force against displacement of every test (one axes; drawn into ``ax`` when
        given); returns the axes."""
        import matplotlib.pyplot as plt
        if ax is None:
            _, ax = plt.subplots(figsize=(6.0, 4.0))
        for t in self.tests:
            ax.plot(1e3 * t.displacement_m, t.force_N, lw=0.6, label=t.file)
        ax.set_xlabel("displacement (mm)")
        ax.set_ylabel("force (N)")
        if len(self.tests) <= 8:
            ax.legend(fontsize="small")
        return ax

    def save(self, out_dir: str | Path, overwrite: bool = False) -> Path:
        """Write the bench data directory ``out_dir`` (``bench.toml``, one CSV per test,
        :attr:`files`, ``validation/``), atomically.  A non-empty ``out_dir`` is replaced
        only with ``overwrite`` and only when ehsa-opt wrote all of it (FileExistsError
        otherwise, nothing changed)."""
        out = Path(out_dir)
        files = dict(self.files)
        for name in self.keep:  # carried over from the folder being replaced
            f = out / name
            if name not in files and f.is_file() and not f.is_symlink():
                files[name] = f.read_text(encoding="utf-8")
        write_bench(out, list(self.tests), harvester=self.harvester, rig=self.rig or None,
                    extra_files=files or None, overwrite=overwrite)
        if self.validation is not None:
            v = self.validation
            write_bench(out / VALIDATION_DIR, list(v.tests), harvester=v.harvester,
                        rig=v.rig or None, extra_files=dict(v.files) or None, overwrite=True)
            write_marker(out)  # the validation folder is ours too
        return out

    @classmethod
    def load(cls, data_dir: str | Path, lenient: bool = False) -> BenchSet:
        """Read and check a bench data directory (:func:`check_bench`)."""
        return check_bench(data_dir, lenient=lenient)


def _rig_table(data: BenchData) -> dict:
    return {"name": data.rig_name, "has_generator": data.has_generator,
            **({"description": data.description} if data.description else {})}


def check_bench(data_dir: str | Path, *, lenient: bool = False) -> BenchSet:
    """Read and validate a bench data directory; nothing written.

    Parameters
    ----------
    data_dir : path
        A bench data directory (``bench.toml`` and the tests' CSV files).
    lenient : bool
        Signals that contradict ``bench.toml`` (frequency, amplitude, units) become
        :attr:`BenchSet.warnings` instead of errors.

    Returns
    -------
    BenchSet
        ``summary()`` is what ``ehsa-opt bench check`` prints.

    Raises
    ------
    BenchDataError
        The file, row or key that is wrong and the fix.
    """
    data, notes = load_bench_checked(data_dir, lenient=lenient)
    validation = None
    vdir = Path(data_dir) / VALIDATION_DIR
    if (vdir / "bench.toml").is_file():
        vdata, vnotes = load_bench_checked(vdir, lenient=lenient)
        validation = BenchSet(vdata.tests, vdata.harvester, _rig_table(vdata),
                              warnings=tuple(vnotes), path=vdata.path)
    return BenchSet(data.tests, data.harvester, _rig_table(data), validation=validation,
                    warnings=tuple(notes), path=data.path)


def generate_bench(spec: SyntheticSpec | None = None, *, command: str = "",
                   progress: Callable[[int, int], None] | None = None,
                   **options: Any) -> BenchSet:
    """Synthetic bench data (the paper's 21 sine tests by default), in memory.

    Parameters
    ----------
    spec : SyntheticSpec, optional
        What to generate; or give its pieces as ``options``.
    command : str
        The command that regenerates the data, written into ``README.md`` and
        ``truth.toml`` (``ehsa-opt bench generate`` gives its own).
    progress : callable, optional
        Called with the number of finished tests and the number of tests.
    **options
        Instead of ``spec``: ``effects`` (names, e.g. ``["backlash"]``),
        ``effect_params`` and ``harvester`` (mappings name → value, or ``NAME=VALUE``
        strings), ``frequencies_hz`` and ``loads_ohm`` (numbers, or a comma list),
        ``amplitudes_m``, ``protocols`` (``KIND:NAME=VALUE,...`` or Protocol objects)
        and the other :class:`SyntheticSpec` fields (``seed``, ``noise_force_N``,
        ``noise_voltage_V``, ``cycles`` …).

    Returns
    -------
    BenchSet
        The tests with ``truth.toml`` (the true parameters) and ``README.md`` in
        :attr:`BenchSet.files`; ``save(folder)`` writes them.

    Raises
    ------
    ValueError
        An option that cannot be used, named with the fix.
    """
    if spec is None:
        spec = spec_from_options(**options)
    elif options:
        raise ValueError(f"generate_bench: give a spec or its options "
                         f"({', '.join(sorted(options))}), not both")
    logger.info("bench generate: %d tests", spec.n_tests)
    tests = generate_bench_tests(spec, progress=None if progress is None else (
        lambda k: progress(k, spec.n_tests)))
    rig, files = synthetic_files(spec, command)
    return BenchSet(tests, spec.harvester, rig, files)


def convert_emps(source_dir: str | Path) -> BenchSet:
    """The raw EMPS benchmark files (``emps_estimation.csv``,
    ``emps_validation_pulses.csv``) as bench data, in memory.

    The force is g_tau × the controller voltage; the pulse test is the held-out
    :attr:`BenchSet.validation` (with ``pulses.csv``, the pulse signal).  Both files are
    validated (header, columns, rows, finite values, increasing time).

    Returns
    -------
    BenchSet
        ``save(folder)`` writes the bench directory and ``validation/``, keeping an
        existing ``README.md`` of the folder.
    """
    from ..datasets.emps import read_emps
    test, vtest, rig, pulses = read_emps(source_dir)
    validation = BenchSet([vtest], rig=rig, files={"pulses.csv": pulses})
    return BenchSet([test], rig=rig, validation=validation, keep=("README.md",))
