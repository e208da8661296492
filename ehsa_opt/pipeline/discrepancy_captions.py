"""Captions of the model-discrepancy figures, written from the run's numbers (the
residual maps, the ranking of the candidates, the error per test and the zoom)."""

from __future__ import annotations

import math

from ..estimation.discrepancy import DiscrepancyResult

__all__ = ["residual_caption", "ranking_caption", "per_test_caption", "zoom_caption"]


def _named(res: DiscrepancyResult) -> str:
    return (" + ".join(f"`{e}`" for e in res.effects) if getattr(res, "effects", None)
            else f"`{res.effect}`")


def residual_caption(res: DiscrepancyResult) -> str:
    """The residual maps' caption: the channel most structured and its strongest
    coordinate, before and (where an effect was added) after."""
    chans = list(res.loc_before.channels.values())
    ch = max(chans, key=lambda c: c.structured_fraction)
    top = [c for c in ch.ranking() if c.structured][:1]
    where = (f"most along {top[0].coordinate} (R² {top[0].r2:.2f} against a noise floor of "
             f"{top[0].floor:.3f})" if top else "no coordinate beyond the noise floor")
    text = (f"Binned mean residual (measured − simulated, in noise units) of the baseline "
            f"against each coordinate, per channel. The {ch.channel} residual is "
            f"{ch.rms_normalised:.2f} × the noise, {100 * ch.structured_fraction:.0f} % of it "
            f"structured, {where}")
    if res.loc_after is not None and ch.channel in res.loc_after.channels:
        after = res.loc_after.channels[ch.channel]
        text += (f"; with {_named(res)}: {after.rms_normalised:.2f} × the noise, "
                 f"{100 * after.structured_fraction:.0f} % structured")
    return text


def ranking_caption(res: DiscrepancyResult) -> str:
    """The ranking figure's caption: candidates, rounds and what earned."""
    cs = [c for c in res.candidates if c.applicable]
    fitted = [c for c in cs if c.fitted]
    earned = sorted({c.effect for c in cs if c.earns})
    rounds = len({c.round for c in res.candidates})
    best = min(fitted, key=lambda c: c.delta_bic_heldout if math.isfinite(
        c.delta_bic_heldout) else math.inf) if fitted else None
    return (f"Signature score (left) and ΔBIC on the fit and held-out tests (right) of the "
            f"{len(cs)} applicable candidate evaluations over {rounds} round(s), "
            f"{len(fitted)} refitted; "
            + (f"earning the rule: {', '.join(f'`{e}`' for e in earned)}" if earned
               else "none earns the rule")
            + (f"; lowest held-out ΔBIC `{best.effect}` ({best.delta_bic_heldout:.1f})"
               if best is not None and math.isfinite(best.delta_bic_heldout) else ""))


def per_test_caption(res: DiscrepancyResult, rows: list[dict]) -> str:
    """The per-test figure's caption: median and worst test, fit and held-out."""
    import numpy as np
    if not rows:
        return "No test to show."
    b = np.array([r["error_before"] for r in rows])
    a = np.array([r["error_after"] for r in rows])
    worst = rows[int(np.argmax(b))]
    held = [r for r in rows if r["set"] == "held-out"]
    text = (f"Relative force error of each of {len(rows)} tests ({len(held)} held out) with "
            f"the baseline and with {_named(res)}: median {np.median(b):.3f} % → "
            f"{np.median(a):.3f} %; the baseline's worst test {worst['test']} "
            f"({worst['set']}) {worst['error_before']:.3f} % → {worst['error_after']:.3f} %")
    if held:
        hb = np.median([r["error_before"] for r in held])
        ha = np.median([r["error_after"] for r in held])
        text += f"; held-out median {hb:.3f} % → {ha:.3f} %"
    return text


def zoom_caption(res: DiscrepancyResult, rows: list[dict]) -> str:
    """The zoom figure's caption: the tests shown and their errors."""
    import numpy as np
    allp = res.fit_tests + res.heldout_tests
    if not allp:
        return "No test to show."
    order = sorted(range(len(allp)), key=lambda k: -float(np.max(np.abs(
        (allp[k].y[0] - res.baseline_pred[k][0]) * allp[k].wnorm[0]))))[:2]
    shown = "; ".join(f"{rows[k]['test']} ({rows[k]['set']}: {rows[k]['error_before']:.3f} % "
                      f"→ {rows[k]['error_after']:.3f} %)" for k in order if k < len(rows))
    return (f"Measured force (and voltage) against the baseline and {_named(res)} around the "
            f"sample where the baseline misses most, on the two tests with the largest miss: "
            f"{shown}; grey: windows left out of the fit (not resolved)")
