"""The candidates ranked by the residual signatures they explain (:mod:`identify.signatures`), and
the result annotated with the ranking (each selected effect's rank in its evidence)."""

from __future__ import annotations

import math
from dataclasses import replace

__all__ = ["rank_candidates", "annotate", "diagnosis_markdown"]


def rank_candidates(detected: dict, effects, heldout: dict, error_before: float) -> list[dict]:
    """The candidates ranked by the evidence: first those that explain at least one detected signature,
    then the rest; within each, by the held-out error their fit removes (untried last).

    The signatures narrow the candidates to the types the residual points to; which of those the data
    favour is what each fit removes, not how many other types share a signature. So adding an effect
    type to the library never reorders the others (a rule that shared each signature's credit among
    the types that show it did: a new type sharing a signature demoted every type beside it).
    ``score`` is the number of detected signatures the effect explains (information, not the order).

    ``detected``: name -> :class:`Signature`; ``effects``: the candidate Effect objects;
    ``heldout``: name -> held-out error with the effect added (first selection step), missing if untried.
    Returns JSON-ready rows, best first, each with ``why``.
    """
    present = [k for k, s in detected.items() if s.present]
    rows = []
    for e in effects:
        explains = [k for k in e.signatures if k in present]
        err = heldout.get(e.name)
        gain = (error_before - err) if err is not None and math.isfinite(err) else -math.inf
        rows.append({"name": e.name, "explains": explains, "score": float(len(explains)),
                     "heldout_error_with": err, "explained_error": gain if math.isfinite(gain) else None})
    rows.sort(key=lambda r: (not r["explains"], -(r["explained_error"] if r["explained_error"] is not None
                                                   else -math.inf)))
    for i, r in enumerate(rows):
        sig = ", ".join(r["explains"]) or "none of the detected signatures"
        gain = "untried" if r["explained_error"] is None else f"lowers the held-out error by {r['explained_error']:.4g}"
        r["rank"] = i + 1
        r["why"] = f"explains {sig} ({len(r['explains'])} of {len(present)} detected); {gain}"
    return rows


def annotate(result, detected: dict, effects):
    """``result`` (an :class:`Identification`) with the detected signatures, the ranking and each
    selected effect's rank and explained signatures in its ``evidence``."""
    heldout = result.steps[0].candidates if result.steps else {}
    ranking = rank_candidates(detected, effects, heldout, result.error_before)
    by_name = {r["name"]: r for r in ranking}
    fits = tuple(replace(f, evidence={**f.evidence, "rank": by_name[f.name]["rank"] if f.name in by_name else None,
                                      "signatures_explained": by_name.get(f.name, {}).get("explains", []),
                                      "why_ranked": by_name.get(f.name, {}).get("why")})
                 for f in result.effects)
    extra = {**result.extra, "signatures": {k: s.to_json() for k, s in detected.items()},
             "signatures_detected": [k for k, s in detected.items() if s.present], "ranking": ranking}
    return replace(result, effects=fits, extra=extra)


def diagnosis_markdown(extra: dict) -> list[str]:
    """Markdown lines: the signature tests and the ranking of an annotated result's ``extra``."""
    sigs = extra.get("signatures")
    if not sigs:
        return []
    out = ["## Diagnosis: residual signatures (before)", "",
           "| signature | present | statistic | threshold | rule |", "|---|---|---|---|---|"]
    for k, s in sigs.items():
        out.append(f"| {k} | {'yes' if s['present'] else 'no'} | {s['statistic']:.4g} | {s['threshold']:.4g} | "
                   f"{s['rule']} |")
    out += ["", "Candidates ranked: those that explain a detected signature first, each group by the held-out "
                "error its fit removes (the selection rule decides; the ranking orders and explains):", ""]
    out += [f"{r['rank']}. **{r['name']}**: {r['why']}" for r in extra.get("ranking", [])]
    return out + [""]
