"""Sentences that state a comparison, computed from the numbers they state.

Every function takes plain numbers (SI unless the name says otherwise) and returns a sentence
whose comparative words ("within", "above", "about as much", "all", "overlap", ...) follow from
those numbers by a rule stated in the function's docstring. The report and the README block use
these functions only, so no fixed wording can contradict the numbers beside it.
"""

from __future__ import annotations

import math

__all__ = ["position_in_range", "range_comparison", "times", "ratio_comparison", "modes_below",
           "limit_against_cut", "bracket_text", "brackets_relation", "bracket_width", "damping_comparison",
           "damping_cross_check",
           "relative_agreement", "limit_scaling", "tab10_identified"]

#: Two ratios are "about" equal when they differ by less than this factor (15 %): wider than the
#: discretization errors of the limits (< 1 %), narrower than the effects the study explains.
ABOUT = 1.15


def _num(v: float, digits: int) -> str:
    return f"{v:.{digits}f}"


def position_in_range(value: float, lo: float, hi: float) -> str:
    """"below", "within" or "above" the closed interval [lo, hi]."""
    if value < lo:
        return "below"
    return "above" if value > hi else "within"


def range_comparison(label: str, value: float, lo: float, hi: float, unit: str, digits: int = 1,
                     what: str = "the paper's measured") -> str:
    """E.g. ``"Rt 15.4 um, above the paper's measured 10-15 um"``; ``value`` compared unrounded."""
    return (f"{label} {_num(value, digits)} {unit}, {position_in_range(value, lo, hi)} {what} "
            f"{lo:g}-{hi:g} {unit}")


def times(a: float, b: float, digits: int = 1) -> str:
    """``a / b`` as "N times" (both > 0)."""
    return f"{a / b:.{digits}f} times"


def ratio_comparison(ratio: float, reference: float) -> str:
    """How ``ratio`` compares with ``reference``: "about as much as" within a factor ``ABOUT``,
    else "more than" or "less than"."""
    if max(ratio, reference) / min(ratio, reference) < ABOUT:
        return "about as much as"
    return "more than" if ratio > reference else "less than"


def modes_below(n_below: int, n_modes: int, model: str) -> str:
    """E.g. "all 6 modes of the 6-DOF model lie below it", "2 of the 6 modes ...", "none of the 6 ..."."""
    if n_below == n_modes:
        head = f"all {n_modes} modes"
    elif n_below == 0:
        head = f"none of the {n_modes} modes"
    else:
        head = f"{n_below} of the {n_modes} modes"
    return f"{head} of the {model} {'lies' if n_below == 1 else 'lie'} below it"


def limit_against_cut(limit_m: float, depth_m: float) -> str:
    """E.g. "5.09 mm, 3.2 times the 1.6 mm cut (deeper than the cut)"; inf: no limit found."""
    if limit_m is None or not math.isfinite(limit_m):
        return f"no limit below the search bound (the cut is {depth_m * 1e3:.1f} mm)"
    side = "deeper than" if limit_m > depth_m else "shallower than" if limit_m < depth_m else "equal to"
    return f"{limit_m * 1e3:.2f} mm, {limit_m / depth_m:.2f} times the {depth_m * 1e3:.1f} mm cut ({side} the cut)"


def bracket_text(lo: float | None, hi: float | None) -> str:
    """"[x12.19, x12.34]"; an open side is written as "not reached"."""
    def one(v):
        return "none" if v is None else f"x{v:.4g}"
    if hi is None:
        return f"above x{lo:.4g} (no stable scale tried)" if lo is not None else "not searched"
    return f"[{one(lo)}, {one(hi)}]"


def brackets_relation(a: tuple, b: tuple) -> str:
    """"overlap", "are disjoint" or "cannot be compared" for two [unstable, stable] brackets; disjoint
    brackets that share an end (one's stable side is the other's unstable side) say so."""
    (alo, ahi), (blo, bhi) = a, b
    if ahi is None or bhi is None:
        return "cannot be compared"
    alo = -math.inf if alo is None else alo
    blo = -math.inf if blo is None else blo
    if max(alo, blo) < min(ahi, bhi):
        return "overlap"
    shared = ahi if ahi == blo else bhi if bhi == alo else None
    return "are disjoint" if shared is None else \
        f"are disjoint, adjacent at x{shared:.4g} (stable by one method, unstable by the other)"


def bracket_width(lo: float | None, hi: float | None) -> float | None:
    """``hi - lo`` of a closed bracket, None when a side is open."""
    return None if lo is None or hi is None else hi - lo


def _width_text(br: tuple) -> str:
    w = bracket_width(*br)
    return "open" if w is None else f"{w:.3g} wide"


def damping_cross_check(lobes: tuple, delay: tuple, eroded: tuple, dy_m: float | None = None,
                        lobes_at_dy: tuple | None = None, orbit: tuple | None = None,
                        dy_entry_m: float | None = None) -> str:
    """Like with like. The delay-based bracket (the lobes' linear problem, fixed engagement at the
    nominal radial depth) against the lobes' ("overlap" / "are disjoint" by
    :func:`brackets_relation`), with each bracket's width; then the eroded part's bracket, whose
    engagement moves with the tool's mean normal deflection ``dy_m`` (m), against the lobes' at the
    nominal ae, given ``lobes_at_dy``, against the SDM's at ``ae - dy`` and, given ``orbit``,
    against the SDM's linearized about the eroded part's forced orbit (at ae minus ``dy_entry_m``,
    the deflection when the teeth meet the part, m; with the entry shift, the surface tilt and the
    delayed instant)."""
    out = (f"Like with like, the delay-based time domain (the lobes' linear problem: the same linearized "
           f"structure and cut, the engagement fixed at the nominal radial depth) brackets it in "
           f"{bracket_text(*delay)} ({_width_text(delay)}; the lobes' is {_width_text(lobes)}): the two "
           f"brackets {brackets_relation(lobes, delay)}. The eroded part's bracket {bracket_text(*eroded)} "
           f"({_width_text(eroded)}) and the lobes' {brackets_relation(lobes, eroded)}; its engagement moves with "
           f"the tool's deflection")
    if dy_m is None:
        return out + ", so it compares with the SDM at the radial depth ae - dy, not at the nominal ae."
    out += (f" (mean normal deflection dy = {dy_m * 1e6:+.2f} um at its bracket's ends), so it compares with "
            f"the SDM at the radial depth ae - dy, not at the nominal ae")
    if lobes_at_dy is None:
        return out + "."
    out += (f". The SDM at ae - dy brackets it in {bracket_text(*lobes_at_dy)} ({_width_text(lobes_at_dy)}); "
            f"this bracket and the eroded part's {brackets_relation(lobes_at_dy, eroded)}.")
    if orbit is None:
        return out
    at = "" if dy_entry_m is None else f" = {dy_entry_m * 1e6:+.2f} um"
    return (out + f" Linearized as the eroded part is, about its forced orbit (the radial depth ae minus the "
            f"deflection when the teeth meet the part{at}; the entry shift, the tilt of the regenerated surface "
            f"and the delayed instant), the SDM brackets it in {bracket_text(*orbit)} ({_width_text(orbit)}); "
            f"this bracket and the eroded part's {brackets_relation(orbit, eroded)}.")


def damping_comparison(lobes: tuple, time_domain: tuple, paper_scale: float, td_label: str = "the time domain") -> str:
    """The stabilizing damping of both methods as brackets, whether they overlap, and whether the
    paper's scale is enough by each (enough: at or above the bracket's stable side; not enough: at
    or below its unstable side; else inside the bracket). ``td_label``: the time-domain method's name."""
    def verdict_on_paper(br):
        lo, hi = br
        if hi is not None and paper_scale >= hi:
            return "enough"
        if lo is not None and paper_scale <= lo:
            return "not enough"
        return "inside the bracket"
    pl, pt = verdict_on_paper(lobes), verdict_on_paper(time_domain)
    both = (f"The paper's x{paper_scale:g} is not enough by either method" if pl == pt == "not enough"
            else f"The paper's x{paper_scale:g} is {pl} by both methods" if pl == pt
            else f"The paper's x{paper_scale:g} is {pl} by the lobes and {pt} by {td_label}")
    return (f"The smallest joint-damping scale that stabilizes steel lies in {bracket_text(*lobes)} by the lobes "
            f"and in {bracket_text(*time_domain)} by {td_label} ([largest unstable, smallest stable] "
            f"tried); the brackets {brackets_relation(lobes, time_domain)}. {both}.")


def relative_agreement(label: str, ours: float, reference: float, unit: str, digits: int = 1,
                       ref_label: str = "the reference") -> str:
    """E.g. "51.7 Hz, 0.2 % from the lobes' 51.6 Hz" (relative difference, unrounded)."""
    d = abs(ours - reference) / abs(reference) * 100
    return f"{label} {_num(ours, digits)} {unit}, {d:.1f} % from {ref_label} {_num(reference, digits)} {unit}"


def limit_scaling(ktc_ratio: float, lowest_ratio: float, local_ratio: float) -> str:
    """Steel's larger force coefficient against how much smaller its limits are (its lowest limit
    over a speed range, and its limit at its cut speed)."""
    ca, cl = ratio_comparison(lowest_ratio, ktc_ratio), ratio_comparison(local_ratio, ktc_ratio)
    why = ("" if ca == cl == "about as much as" else
           " (the limits also depend on Krc/Ktc, the immersion and the mode directions, not on Ktc alone)")
    return (f"Steel takes {ktc_ratio:.2f} times the tangential force per unit chip (Ktc). Its lowest "
            f"limit over 300-30000 rpm is {lowest_ratio:.1f} times smaller than aluminium's, {ca} the Ktc ratio, and its "
            f"limit at its own cut speed {local_ratio:.1f} times smaller, {cl} the Ktc ratio{why}.")


def tab10_identified(before_n: float, after_n: float, paper_basic_n: float, paper_best_n: float,
                     paper_best_name: str, aim_n: float = 5.0) -> str:
    """Fact (a) in one sentence: RMS over the 8 Tab. 10 statistics before and after identification, N.

    "below"/"above" the aim by ``after < aim``; our basic model "matches" the paper's basic row when
    they agree within 5 % (else "differs from"); the gain over the paper's best row by :func:`times`.
    """
    same = abs(before_n / paper_basic_n - 1) < 0.05
    rel = "matches" if same else "differs from"
    aim = "below" if after_n < aim_n else "above"
    return (f"Our basic model is {before_n:.1f} N RMS over the 8 statistics ({rel} the paper's basic row, "
            f"{paper_basic_n:.1f} N; the paper's best row, {paper_best_name}, is {paper_best_n:.1f} N); identification "
            f"brings it to {after_n:.1f} N, {aim} the {aim_n:g} N aim and {times(paper_best_n, after_n)} lower "
            f"than the paper's best row.")
