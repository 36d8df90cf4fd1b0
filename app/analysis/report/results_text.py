"""The results of a paired-comparison study in words: the paragraphs that open the report's
results (:func:`results_paragraphs`), placed by
:func:`app.analysis.report.document.build_document`.

They name the votes and what was skipped, the agreement test, the ballots, the sign tests and
paired t-tests that are significant after Holm's adjustment, the Thurstone Case V scale with
its intervals and the participants' consistence, with the same numbers as the tables.
"""

from __future__ import annotations

from typing import Any

from app.analysis.report.blocks import ALPHA, counted, fmt, fmt_p, judgements_per_pair


def _p_eq(p: float | None) -> str:
    text = fmt_p(p)
    return f"p {text}" if text.startswith("<") else f"p = {text}"


def results_paragraphs(r: dict[str, Any]) -> list[str]:
    """The results paragraphs of a paired-comparison study's :func:`app.analysis.analyze`
    result ``r``: the statistics in words, strongest findings first."""
    pooled, info, opts = r["pooled"], r["input"], r["options"]
    und_rule = (
        "undecided votes excluded"
        if opts["undecided"] == "exclude"
        else "undecided votes split half to each side"
    )
    n_clips = len(info["clips"])
    out = [
        f"{counted(info['participants'], 'participant')} cast "
        f"{counted(info['votes'], 'vote')} on {counted(n_clips, 'clip')} "
        f"({pooled['undecided']} undecided, "
        f"{100.0 * pooled['undecided'] / max(pooled['votes'], 1):.1f} %; "
        f"{pooled['same_condition_votes']} votes on same-condition pairs)."
        + (
            f" {info['skipped_rows']} bad rows of the votes file were skipped and are not "
            "part of any statistic."
            if info["skipped_rows"]
            else " No rows of the votes file were skipped."
        )
    ]
    ag = pooled["agreement"]
    if ag["u"] is not None:
        verdict = "agreed beyond chance" if ag["p"] < ALPHA else "did not agree beyond chance"
        spread = judgements_per_pair(pooled, opts["undecided"])
        out.append(
            f"Pooled over clips, the judgements {verdict} (Kendall & Babington Smith "
            f"u = {ag['u']:.3f}, χ²({ag['df']:.2f}) = {ag['chi2']:.2f}, {_p_eq(ag['p'])}; "
            f"continuity-corrected {_p_eq(ag['p_corrected'])}; {spread} judgements per pair, "
            f"{und_rule})."
        )
    names = sorted(r["conditions"], key=lambda c: -pooled["ballots"][c])
    listing = ", ".join(f"{c} ({pooled['ballots'][c]})" for c in names)
    out.append(f"Ballots per condition, pooled over clips, in decreasing order: {listing}.")
    signs = pooled["sign_tests"]
    if signs:
        sig = [s for s in signs if s["p_holm"] is not None and s["p_holm"] < ALPHA]
        parts = []
        for s in sig:
            better, worse = (s["a"], s["b"]) if s["wins"] > s["losses"] else (s["b"], s["a"])
            hi, lo = max(s["wins"], s["losses"]), min(s["wins"], s["losses"])
            parts.append(
                f"{better} over {worse} ({hi} vs {lo}, {s['undecided']} undecided, "
                f"Holm-adjusted {_p_eq(s['p_holm'])})"
            )
        text = (
            f"Exact sign tests (undecided votes excluded, Holm-adjusted over "
            f"{counted(len(signs), 'pair')}) found {len(sig)} of "
            f"{counted(len(signs), 'pair')} different"
        )
        out.append(text + (": " + "; ".join(parts) + "." if parts else "."))
    tt = [t for t in pooled["paired_t"] if t["p_holm"] is not None and t["p_holm"] < ALPHA]
    if pooled["paired_t"]:
        parts = [
            f"{t['a']} − {t['b']}: M = {t['mean']:.2f}, SD = {t['sd']:.2f}, "
            f"t({t['df']}) = {t['t']:.2f}, Holm {_p_eq(t['p_holm'])}, 95 % CI "
            f"[{t['ci_low']:.2f}, {t['ci_high']:.2f}]"
            for t in tt
        ]
        out.append(
            "Paired t-tests on each participant's ballots per condition "
            f"({len(tt)} of {counted(len(pooled['paired_t']), 'pair')} significant "
            "after Holm)" + (": " + "; ".join(parts) + "." if parts else ".")
        )
    scale = [s for s in pooled["scale"] if s["score"] is not None]
    if scale:
        scale.sort(key=lambda s: -s["score"])
        ci = int(round(100 * opts["confidence"]))
        listed = ", ".join(
            f"{s['condition']} {s['score']:.2f} [{fmt(s['ci_low'])}, {fmt(s['ci_high'])}]"
            for s in scale
        )
        origin = f"{opts['anchor']} fixed at 0" if opts["anchor"] else "mean fixed at 0"
        out.append(
            f"On the Thurstone Case V scale (JOD, {origin}; {ci} % bootstrap intervals "
            f"over participants, {opts['bootstrap']} replicates): {listed}."
        )
    cs = pooled.get("consistence")
    if cs and cs["median_zeta"] is not None:
        out.append(
            f"The participants' median coefficient of consistence was "
            f"ζ = {cs['median_zeta']:.2f} (mean {cs['mean_zeta']:.2f}; 1 = no circular "
            f"triad). The test of consistence could be run for {cs['tested']} of "
            f"{counted(cs['participants'], 'participant')} and rejected random choice at "
            ".05 for "
            f"{cs['significant_05']}"
            + (
                f" (with {cs['conditions']} conditions even a perfectly consistent judge "
                f"reaches only P = {cs['min_p']:.3f})"
                if cs.get("min_p", 0) >= 0.05
                else ""
            )
            + "."
        )
    return out
