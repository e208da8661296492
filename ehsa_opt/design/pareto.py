"""Pareto tools on objective matrices (minimisation): non-dominated filter
(pymoo's :class:`~pymoo.util.nds.non_dominated_sorting.NonDominatedSorting`), margin
dominance, hypervolume (pymoo's exact HV) and the preferred-point pick."""

from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = ["non_dominated", "update_archive", "dominates_by", "hypervolume",
           "pick_preferred"]


def non_dominated(F: np.ndarray) -> np.ndarray:
    """Boolean mask of the non-dominated rows of F (minimisation), by pymoo's
    :class:`NonDominatedSorting`; duplicates keep their first occurrence."""
    from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting
    F = np.asarray(F, dtype=float)
    keep = np.zeros(F.shape[0], dtype=bool)
    if F.shape[0] == 0:
        return keep
    _, first = np.unique(F, axis=0, return_index=True)
    first = np.sort(first)
    front = NonDominatedSorting().do(F[first], only_non_dominated_front=True)
    keep[first[np.asarray(front, dtype=int)]] = True
    return keep


def update_archive(archive: np.ndarray, F_new: np.ndarray) -> tuple[np.ndarray, bool]:
    """Non-dominated set of ``archive`` ∪ ``F_new``, given that ``archive`` is itself
    non-dominated: only the new points are sorted (pymoo's
    :class:`NonDominatedSorting`) and then compared with the archive, so an update
    costs O(new × archive), not a sort of everything ever evaluated.

    Same result, rows and order as ``U[non_dominated(U)]`` with ``U = vstack(archive,
    F_new)``: surviving archive rows first, then surviving new rows; a new point equal
    to an archive point is a duplicate and dropped.

    Returns
    -------
    (ndarray, bool)
        The new archive and whether it changed.
    """
    A = np.asarray(archive, dtype=float)
    C = np.asarray(F_new, dtype=float)
    C = C[non_dominated(C)]
    if C.shape[0] == 0:
        return A, False
    if A.shape[0] == 0:
        return C, True

    def weakly_below(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """[i, j]: P_j <= Q_i in every objective (objective by objective: small
        temporaries)."""
        out = P[None, :, 0] <= Q[:, None, 0]
        for j in range(1, P.shape[1]):
            out &= P[None, :, j] <= Q[:, None, j]
        return out

    # a new point weakly dominated by (or equal to) an archive point is out
    keep_new = ~weakly_below(A, C).any(axis=1)
    if not keep_new.any():
        return A, False
    # an archive point weakly dominated by a kept new point (never equal to it) is out
    keep_old = ~weakly_below(C[keep_new], A).any(axis=1)
    return np.vstack([A[keep_old], C[keep_new]]), True


def dominates_by(F: np.ndarray, f_ref: np.ndarray, margin: float) -> np.ndarray:
    """Rows of F better than ``f_ref`` by more than ``margin`` (relative) in *every*
    objective: F_ij < f_ref_j (1 − margin) for all j (positive objectives)."""
    F = np.asarray(F, dtype=float)
    return np.all(F < np.asarray(f_ref, float) * (1.0 - margin), axis=1)


def hypervolume(F: np.ndarray, reference: np.ndarray) -> float:
    """Hypervolume (exact, pymoo) of points F w.r.t. a reference point; points not
    strictly better than the reference in every objective contribute nothing."""
    from pymoo.indicators.hv import HV
    F = np.asarray(F, dtype=float)
    ref = np.asarray(reference, dtype=float)
    inside = np.all(F < ref, axis=1)
    if not inside.any():
        return 0.0
    return float(HV(ref_point=ref)(F[inside]))


def pick_preferred(F: np.ndarray, method: str = "knee",
                   weights: Sequence[float] | None = None) -> int:
    """Index of the preferred point of a front (minimisation).

    The front is first normalised to [0, 1] per objective (its own ideal and nadir).

    ``knee``
        The point farthest below the hyperplane through the front's extreme points
        (Das 1999 / Deb & Gupta 2011); when that plane is degenerate, the
        compromise point.
    ``compromise``
        The point nearest (Euclidean) to the ideal point.
    ``preference``
        The point minimising the weighted Chebyshev distance max_j w_j f̃_j
        (``weights`` required, one per objective).
    """
    F = np.asarray(F, dtype=float)
    if F.ndim != 2 or F.shape[0] == 0:
        raise ValueError("pick_preferred: empty front")
    lo, hi = F.min(axis=0), F.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    Fn = (F - lo) / span
    if method == "compromise":
        return int(np.argmin(np.linalg.norm(Fn, axis=1)))
    if method == "preference":
        if weights is None or len(weights) != F.shape[1]:
            raise ValueError(f"pick_preferred: 'preference' needs {F.shape[1]} weights")
        wv = np.asarray(weights, dtype=float)
        if np.any(wv < 0) or not np.any(wv > 0):
            raise ValueError("pick_preferred: weights must be >= 0 and not all 0")
        from pymoo.decomposition.tchebicheff import Tchebicheff
        m = F.shape[1]
        return int(np.argmin(Tchebicheff().do(Fn, weights=wv, ideal_point=np.zeros(m),
                                              utopian_point=np.zeros(m))))
    if method == "knee":
        m = F.shape[1]
        ext = np.array([np.argmin(F[:, j]) for j in range(m)])
        E = Fn[ext]
        try:
            # hyperplane a·f = 1 through the extreme points
            a = np.linalg.solve(E, np.ones(m))
            if not np.all(np.isfinite(a)) or np.linalg.cond(E) > 1e10:
                raise np.linalg.LinAlgError
        except np.linalg.LinAlgError:
            return int(np.argmin(np.linalg.norm(Fn, axis=1)))
        dist = (1.0 - Fn @ a) / np.linalg.norm(a)
        return int(np.argmax(dist))
    raise ValueError(f"pick_preferred: unknown method '{method}' (valid: knee, compromise, "
                     f"preference)")
