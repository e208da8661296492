"""NSGA-II checkpoints as data, not code: the population, the archive, the history,
the generation counter and the random generator's state in one ``.npz`` file (read
with ``allow_pickle=False``) with a JSON header and a SHA-256 over header and arrays.

Loading such a file cannot execute anything; a truncated, altered or foreign file is
refused with a :class:`~ehsa_opt.physics.params.ParameterError` that names the file
and the fix, never used.  The digest catches corruption and edits by hand, not a
forger who recomputes it; such a file can still only feed numbers, checked for
shape and range here, into a run of the same problem (fingerprint, pop, seed).

What pymoo's NSGA-II needs to continue *exactly* (pymoo 0.6.2): the population's
X, F, G, H and the survival's ``rank`` / ``crowding`` (read by the binary
tournament), the individuals' ``n_gen`` / ``n_iter``, the iteration counter, the
evaluation count and the state of ``algorithm.random_state`` (a
``numpy.random.Generator`` seeded from ``seed``, which every operator draws from).
"""

from __future__ import annotations

import hashlib
import io
import json
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..physics.params import ParameterError
from ..utils.io import atomic_write_bytes
from ..utils.limits import parse_json

__all__ = ["CHECKPOINT_FILE", "MAX_CHECKPOINT_BYTES", "NSGA2State", "capture", "load_state",
           "restore", "save_state", "verify_designs"]

#: File name of the checkpoint inside the checkpoint directory.
CHECKPOINT_FILE = "nsga2_checkpoint.npz"
_FORMAT = "ehsa_opt NSGA-II checkpoint"
_VERSION = 1
_ARRAYS = ("pop_X", "pop_F", "pop_G", "pop_H", "pop_rank", "pop_crowding", "pop_n_gen",
           "pop_n_iter", "archive_F")
_LEGACY = "algorithm.pkl"


@dataclass
class NSGA2State:
    """Everything a run needs to continue: see the module docstring."""

    fingerprint: str
    pop_size: int
    seed: int
    n_iter: int
    n_eval: int
    rng_state: dict
    history: list[dict]
    arrays: dict[str, np.ndarray]


def _pymoo_version() -> str:
    import pymoo
    return str(getattr(pymoo, "__version__", "unknown"))


def _digest(header: dict, arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    h.update(json.dumps({k: v for k, v in header.items() if k != "sha256"},
                        sort_keys=True).encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"|{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _rng_to_json(state: dict) -> dict:
    """A bit generator's state with its (128-bit) integers as decimal strings."""
    def conv(v: Any) -> Any:
        if isinstance(v, dict):
            return {k: conv(x) for k, x in v.items()}
        if isinstance(v, (int, np.integer)) and not isinstance(v, bool):
            return str(int(v))
        return v
    return conv(state)


def _rng_from_json(state: dict) -> dict:
    def conv(v: Any) -> Any:
        if isinstance(v, dict):
            return {k: conv(x) for k, x in v.items()}
        if isinstance(v, str) and v.lstrip("-").isdigit():
            return int(v)
        return v
    return conv(state)


def capture(algorithm: Any, history: list[dict], archive: np.ndarray, fingerprint: str,
            pop_size: int, seed: int) -> NSGA2State:
    """The state of a pymoo NSGA-II ``algorithm`` after a generation."""
    pop = algorithm.pop
    n = len(pop)
    arrays = {
        "pop_X": np.asarray(pop.get("X"), dtype=float).reshape(n, -1),
        "pop_F": np.asarray(pop.get("F"), dtype=float).reshape(n, -1),
        "pop_G": np.asarray(pop.get("G"), dtype=float).reshape(n, -1),
        "pop_H": np.asarray(pop.get("H"), dtype=float).reshape(n, -1),
        # infeasible members (constrained problems) have no rank / crowding: -1 / nan
        "pop_rank": np.array([-1 if r is None else r for r in pop.get("rank")],
                             dtype=np.int64).reshape(n),
        "pop_crowding": np.array([np.nan if c is None else c for c in pop.get("crowding")],
                                 dtype=float).reshape(n),
        "pop_n_gen": np.asarray(pop.get("n_gen"), dtype=np.int64).reshape(n),
        "pop_n_iter": np.asarray(pop.get("n_iter"), dtype=np.int64).reshape(n),
        "archive_F": np.asarray(archive, dtype=float),
    }
    return NSGA2State(fingerprint=fingerprint, pop_size=int(pop_size), seed=int(seed),
                      n_iter=int(algorithm.n_iter), n_eval=int(algorithm.evaluator.n_eval),
                      rng_state=algorithm.random_state.bit_generator.state,
                      history=[dict(h) for h in history], arrays=arrays)


def restore(state: NSGA2State, problem: Any, n_gen: int) -> Any:
    """A pymoo NSGA-II on ``problem`` that continues exactly where ``state`` stopped."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.population import Population

    a = state.arrays
    algorithm = NSGA2(pop_size=state.pop_size, seed=state.seed, eliminate_duplicates=True)
    algorithm.setup(problem, termination=("n_gen", n_gen), verbose=False)
    pop = Population.new("X", a["pop_X"])
    pop.set("F", a["pop_F"], "G", a["pop_G"], "H", a["pop_H"])
    for ind, rank, crowd, gen, it in zip(pop, a["pop_rank"], a["pop_crowding"],
                                         a["pop_n_gen"], a["pop_n_iter"]):
        ind.evaluated.update(("F", "G", "H"))
        ind.set("rank", None if rank < 0 else int(rank))
        ind.set("crowding", None if np.isnan(crowd) else np.float64(crowd))
        ind.set("n_gen", int(gen))
        ind.set("n_iter", int(it))
    algorithm.pop = pop
    algorithm.n_iter = state.n_iter
    algorithm.is_initialized = True
    algorithm.start_time = time.time()  # wall clock of pymoo's Result only
    algorithm.evaluator.n_eval = state.n_eval
    algorithm.random_state.bit_generator.state = state.rng_state
    algorithm._set_optimum()
    return algorithm


def save_state(directory: str | Path, state: NSGA2State) -> Path:
    """Write ``directory/nsga2_checkpoint.npz`` atomically; returns its path."""
    header = {"format": _FORMAT, "version": _VERSION, "pymoo": _pymoo_version(),
              "fingerprint": state.fingerprint, "pop_size": state.pop_size,
              "seed": state.seed, "n_iter": state.n_iter, "n_eval": state.n_eval,
              "rng": _rng_to_json(state.rng_state), "history": state.history}
    header["sha256"] = _digest(header, state.arrays)
    buf = io.BytesIO()
    np.savez(buf, header=np.frombuffer(json.dumps(header).encode(), dtype=np.uint8),
             **state.arrays)
    path = Path(directory) / CHECKPOINT_FILE
    atomic_write_bytes(path, buf.getvalue())
    return path


def _refuse(path: Path, what: str) -> ParameterError:
    return ParameterError(
        f"--resume {path.parent}: {path} {what}; it is not used. Delete it (or point "
        f"--resume at the directory of an intact checkpoint) and start the run again with "
        f"--checkpoint {path.parent}")


def load_state(directory: str | Path) -> NSGA2State:
    """Read and verify the checkpoint in ``directory`` (see the module docstring).

    Raises
    ------
    ParameterError
        Missing, truncated, altered, foreign or inconsistent file (the message names
        the file and the fix).
    """
    d = Path(directory)
    path = d / CHECKPOINT_FILE
    if not path.is_file():
        if (d / _LEGACY).is_file():
            raise ParameterError(
                f"--resume {d}: {d / _LEGACY} is a checkpoint in the old pickle format, "
                f"which is no longer read (loading a pickle can run code); start a new run "
                f"with --checkpoint {d}")
        raise ParameterError(f"--resume {d}: no checkpoint ({CHECKPOINT_FILE}) there; run "
                             f"with --checkpoint {d} first")
    try:
        _check_declared_sizes(path)
        with np.load(path, allow_pickle=False) as z:
            names = set(z.files)
            missing = [k for k in ("header",) + _ARRAYS if k not in names]
            if missing:
                raise _refuse(path, f"is not an NSGA-II checkpoint of ehsa_opt (no "
                                    f"{', '.join(missing)})")
            header = parse_json(bytes(z["header"].astype(np.uint8)), "its header",
                                lambda m: _refuse(path, f"has a bad header ({m})"),
                                standard=False)
            arrays = {k: z[k] for k in _ARRAYS}
    except ParameterError:
        raise
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile,
            UnicodeDecodeError) as exc:
        raise _refuse(path, f"is truncated, corrupted or not an NSGA-II checkpoint "
                            f"({type(exc).__name__}: {exc})") from None
    if not isinstance(header, dict) or header.get("format") != _FORMAT:
        raise _refuse(path, "is not an NSGA-II checkpoint of ehsa_opt (foreign header)")
    if header.get("version") != _VERSION:
        raise _refuse(path, f"has format version {header.get('version')!r}; this ehsa_opt "
                            f"reads version {_VERSION}")
    if header.get("sha256") != _digest(header, arrays):
        raise _refuse(path, "does not match its SHA-256 digest: it was altered or "
                            "corrupted")
    if header.get("pymoo") != _pymoo_version():
        raise ParameterError(
            f"--resume {d}: {path} was made with pymoo {header.get('pymoo')}, this is pymoo "
            f"{_pymoo_version()}; an exact continuation needs the same pymoo: install "
            f"that version or start a new run with --checkpoint {d}")
    try:
        state = NSGA2State(
            fingerprint=str(header["fingerprint"]), pop_size=int(header["pop_size"]),
            seed=int(header["seed"]), n_iter=int(header["n_iter"]),
            n_eval=int(header["n_eval"]), rng_state=_rng_from_json(header["rng"]),
            history=list(header["history"]), arrays=arrays)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise _refuse(path, f"has an incomplete header ({exc})") from None
    _check_header(path, state)
    _check_arrays(path, state)
    return state


#: Largest checkpoint content accepted (declared uncompressed bytes of all members).
MAX_CHECKPOINT_BYTES = 2 * 2 ** 30


def _check_declared_sizes(path: Path) -> None:
    """Refuse, from the zip directory alone, members that would inflate far beyond the file
    (a deflate bomb) or whose arrays declare more bytes than their member holds — before
    any member is read.  ``np.savez`` stores members uncompressed, so an honest
    checkpoint's content is about its file size."""
    from numpy.lib import format as npy
    size = path.stat().st_size
    with zipfile.ZipFile(path) as zf:
        infos = zf.infolist()
        declared = sum(i.file_size for i in infos)
        if declared > min(MAX_CHECKPOINT_BYTES, 4 * size + 2 ** 20):
            raise _refuse(path, f"declares {declared / 2 ** 20:.3g} MiB of uncompressed content "
                                f"in a {size / 2 ** 20:.3g} MiB file (a compressed archive, not a "
                                f"checkpoint ehsa-opt writes)")
        for info in infos:
            with zf.open(info) as fh:
                try:
                    version = npy.read_magic(fh)
                    shape, _, dtype = (npy.read_array_header_1_0(fh) if version == (1, 0)
                                       else npy.read_array_header_2_0(fh))
                except (ValueError, EOFError, SyntaxError, TypeError) as exc:
                    raise _refuse(path, f"member {info.filename} is not a numpy array "
                                        f"({exc})") from None
                if dtype.hasobject:
                    raise _refuse(path, f"member {info.filename} holds Python objects")
                need = int(np.prod(shape, dtype=object)) * dtype.itemsize
                if need > info.file_size:
                    raise _refuse(path, f"member {info.filename} declares {need} bytes of "
                                        f"array in {info.file_size} bytes")


_HISTORY_KEYS = ("gen", "n_eval", "hv", "n_front", "hv_archive", "n_archive")


def _check_header(path: Path, state: NSGA2State) -> None:
    """History rows and the random generator's state, validated as data."""
    for k, row in enumerate(state.history):
        if not (isinstance(row, dict) and all(
                isinstance(row.get(key), (int, float)) and not isinstance(row.get(key), bool)
                for key in _HISTORY_KEYS)):
            raise _refuse(path, f"has a malformed history (entry {k} is {str(row)[:60]!r}, "
                                f"expected numbers {', '.join(_HISTORY_KEYS)})")
    try:
        want = type(np.random.default_rng(0).bit_generator).__name__  # pymoo's generator
        if state.rng_state.get("bit_generator") != want:
            raise ValueError(f"bit generator {state.rng_state.get('bit_generator')!r}, "
                             f"expected {want!r}")
        bg = getattr(np.random, want)()
        bg.state = state.rng_state
    except (AttributeError, TypeError, ValueError, KeyError, OverflowError) as exc:
        raise _refuse(path, f"has a malformed rng state ({type(exc).__name__}: "
                            f"{str(exc)[:80]})") from None


def verify_designs(directory: str | Path, state: NSGA2State, problem: Any,
                   n_check: int = 3) -> None:
    """Re-evaluate a sample of the checkpoint's designs (first, middle, last) and refuse
    the checkpoint when their objectives differ from the recorded ones: a file whose
    designs or objectives were changed (and its digest recomputed) cannot steer a run."""
    X, F = state.arrays["pop_X"], state.arrays["pop_F"]
    idx = np.unique(np.linspace(0, X.shape[0] - 1, min(n_check, X.shape[0])).round()
                    ).astype(int)
    got = np.asarray(problem.evaluate(X[idx], return_values_of=["F"]), dtype=float)
    want = F[idx]
    scale = np.maximum(np.abs(want), 1e-12)
    bad = ~(np.abs(got - want) <= 1e-6 * scale)
    if bad.any():
        k = int(idx[np.argwhere(bad)[0][0]])
        raise _refuse(Path(directory) / CHECKPOINT_FILE,
                      f"does not hold what it claims: design {k} re-evaluated gives objectives "
                      f"{np.array2string(got[list(idx).index(k)], precision=4)}, the file "
                      f"records {np.array2string(F[k], precision=4)} (altered, or made by "
                      f"another version of the model)")


def _check_arrays(path: Path, state: NSGA2State) -> None:
    """Shapes, dtypes and ranges consistent with a run of this kind."""
    a = state.arrays
    n = a["pop_X"].shape[0] if a["pop_X"].ndim == 2 else -1
    problems = []
    if not (1 <= n <= state.pop_size):
        problems.append(f"population of {n} rows for pop {state.pop_size}")
    for k in ("pop_X", "pop_F", "pop_G", "pop_H", "archive_F"):
        if a[k].ndim != 2 or a[k].dtype != np.float64:
            problems.append(f"{k} is not a float64 matrix")
    for k in ("pop_rank", "pop_crowding", "pop_n_gen", "pop_n_iter"):
        if a[k].shape != (n,):
            problems.append(f"{k} has shape {a[k].shape}, expected ({n},)")
    if not problems:
        m = a["pop_F"].shape[1]
        if a["pop_F"].shape[0] != n or a["archive_F"].shape[1] != m:
            problems.append("objective matrices of inconsistent sizes")
        if not (np.all(np.isfinite(a["pop_X"])) and np.all((a["pop_X"] >= 0)
                                                              & (a["pop_X"] <= 1))):
            problems.append("designs outside the unit cube")
        if not (np.all(np.isfinite(a["pop_F"])) and np.all(np.isfinite(a["archive_F"]))):
            problems.append("non-finite objectives")
        if len(state.history) < 1 or state.n_iter < 1 or state.n_eval < n:
            problems.append("no finished generation")
    if problems:
        raise _refuse(path, "is inconsistent (" + "; ".join(problems) + ")")
