"""The workpiece as an "eraser of matter" (Huynh et al., section 2.2): axial slices whose material
boundary the teeth erode.

Frame and geometry
------------------
Everything is in the cut frame of :mod:`cases.milling` (``x_c`` along the feed, ``y_c`` normal,
``z_c`` along the spindle, up). ``y_c = 0`` is the *nominal* tool-centre path; the caller chooses
the origin of ``x_c`` and says where the part starts (``x_entry_m``). The part is a block:

* along ``x_c``: ``[x_entry, x_entry + part_length]`` (vertical entry and exit faces);
* along ``y_c``: on the material side of the path -- ``-y_c`` for down-milling, ``+y_c`` for
  up-milling (M03, :func:`cases.milling.engagement_rad`) -- with its free edge ``ae`` into the
  tool from the nominal tool radius ``R = D/2``: at ``y = -(R - ae)`` (down) or ``+(R - ae)`` (up);
* along ``z_c``: from the tool tip (``z = 0``) up over ``ap``, cut into ``K`` slices of height
  ``dz = ap / K``, one per tool disc (:class:`AxialDiscs`). The tool's axial motion is ignored
  (2.5-D model, as in the paper).

Representation (why columns)
----------------------------
Per slice, a uniform grid of columns along ``x_c`` (spacing ``dx``, default 1 um) stores the
material boundary ``y_b(x)``: material is ``y <= y_b`` (down-milling) or ``y >= y_b`` (up), i.e.
one interval per column. Internally a side-free coordinate ``w = s y`` is used (``s = +1`` down,
``-1`` up) so that material is always ``w <= w_b(x)`` and the block edge is always
``w = -(R - ae)``. Between columns the boundary is linear. A column grid makes the two hot
operations O(number of columns touched) with no geometry bookkeeping: the chip thickness is an
exact root of a piecewise-linear function along a ray, and the removal is a running minimum.
A height field holds as long as every column meets the material in one interval, which is true
when the tool centre stays on the non-material side of the block edge: ``ae <= R`` (radial
immersion <= 50 %, the paper's 40 % cases). For ``ae > R`` the front of the tool would leave
material on both sides of the tool disc in one column, so it is refused with an error.

Chip thickness (:meth:`Workpiece.chip`)
---------------------------------------
For an edge element at immersion angle ``phi`` on a tooth of radius ``R_j`` whose tool centre is
at ``c``: along the ray ``p(rho) = c + rho (sin phi, cos phi)``, ``h = R_j - rho_b`` where
``rho_b`` is where the ray, going inwards from the tooth tip, leaves the material (the
contiguous material at the tip, left there by earlier teeth). When the tip is not in material,
``h = 0``: teeth lose contact with no screen function. The root is found exactly: the ray is
walked from the tip inwards one column interval at a time, and inside the interval where the
sign changes the (linear) equation is solved in closed form (the intervals that an error bound
shows the ray still in the material are skipped with a cheaper test, and the exact arithmetic is
kept where the sign changes: the result is that of the plain walk bit for bit,
:func:`_chip_one`). There is no iteration tolerance; the
only error is the linear interpolation of the boundary between columns, ``dx^2 / (8 R)`` for an
arc of radius R (2.5e-11 m for dx = 1 um, R = 5 mm), growing where the boundary is steep in
``x`` (near ``phi = 90 deg``; still ~1e-9 m at the 101.5 deg entry of the paper's cut). In the
tip's own column interval the line is the one through the two columns on the side the tip moves
towards (the unswept material), extended to the tip: in a run the column behind the tip holds the
cut the tooth has just made, and interpolating across that step lost most of the chip where the
ray crosses less than a column (the last ~4 deg before a down-milling exit at dx = 1 um). The walk
also gives the exact derivative of ``h`` with respect to the tool centre (the local boundary is a
line ``w - sl x = const``): ``dh/dc_x = -sl / (c_w - sl s_n)``, ``dh/dc_w = 1 / (c_w - sl s_n)``
with ``(s_n, c_w)`` the ray direction in ``(x, w)``.

Removal (:meth:`Workpiece.remove`)
----------------------------------
Only the tooth tips remove material, along their swept arcs between two *accepted* states (tool
centre moved linearly, tooth rotated from ``phi0`` to ``phi1``): the path is cut into chords of
angle at most ``sqrt(8 chord_tol / R)`` (sagitta <= ``chord_tol``, default 1 nm, against a
feed-mark scallop ``fz^2 / (8 R)`` of 50-250 nm in the paper's cuts; the chord vertices are turned
from one to the next by a rotation, off by ~1e-16 m) and every column a chord
crosses is lowered to the chord (``w_b = min(w_b, w_chord)``): the material between the tip and
the column's boundary point B is inside the tool disc (this is where ``ae <= R`` is needed) and is
gone -- but only once the tooth has turned past B. In down-milling B always lies behind the tip
(the tooth has already swept it); in up-milling (and when a deflected tool back-cuts the wall) B
lies *ahead*, and lowering the column at once would thin the tooth's own chip a moment later. Such
updates are kept pending, per tooth and disc, and applied at the first commit where
``sin(phi_tooth - angle(B)) > 0`` (or half a revolution later at the latest). Trial evaluations
(:meth:`chip`) never modify the part; only :meth:`remove` does.

The heavy loops are compiled with numba when it is installed (``HAVE_NUMBA``); without it the
same code runs as plain Python (correct, ~100x slower).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import Literal

import numpy as np

from robolobes.core.validate import shown
from robolobes.cases.milling import Cut, MillingError, Tool, check_cut
from robolobes.core.errors import BadInput
from robolobes.core.validate import finite, readonly

try:  # numba is optional: the kernels are plain Python without it.
    from numba import njit

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only without numba
    HAVE_NUMBA = False

    def njit(*args, **kwargs):
        if args and callable(args[0]):
            return args[0]
        return lambda f: f


__all__ = [
    "WorkpieceError",
    "AxialDiscs",
    "default_disc_count",
    "WallProfile",
    "Workpiece",
    "HAVE_NUMBA",
]

#: Internal ``w`` of a column without material: 1 m below the block edge, out of reach of any tool.
_NO_MATERIAL_M = -1.0
#: Columns without material padded on each side of the part, so that rays and chords see the faces.
_PAD_COLUMNS = 2
#: Chord vertices of a tip path between direct evaluations of their sine and cosine in the removal
#: (in between they are turned by a rotation; the error grows by a few eps per vertex, so by at most
#: ~1e-14 relative, 1e-16 m on a 5 mm tooth, far below the chords' 1 nm sagitta).
_ROTATION_RESTART = 32
#: Largest grid accepted (slices x columns), to fail early instead of exhausting memory.
_MAX_CELLS = 200_000_000


class WorkpieceError(BadInput):
    """A workpiece that cannot be built or a query with impossible arguments."""


_finite = partial(finite, error=WorkpieceError)  # core.validate.finite raising WorkpieceError


@dataclass(frozen=True)
class AxialDiscs:
    """Axial discretization shared by the tool (discs) and the part (slices).

    Parameters
    ----------
    ap_m : float
        Axial depth of cut in m (> 0); the discs cover ``z in [0, ap]`` above the tool tip.
    count : int
        Number of discs K (>= 1), all of height ``dz = ap / K``.
    """

    ap_m: float
    count: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "ap_m", _finite("axial depth ap_m", self.ap_m, positive=True))
        if isinstance(self.count, bool) or not isinstance(self.count, (int, np.integer)) or self.count < 1:
            raise WorkpieceError(f"disc count must be an integer >= 1, got {self.count!r}")
        object.__setattr__(self, "count", int(self.count))

    @property
    def dz_m(self) -> float:
        """Disc height ``ap / K`` in m."""
        return self.ap_m / self.count

    @property
    def z_m(self) -> np.ndarray:
        """Disc mid-heights above the tool tip, shape (K,), m."""
        z = (np.arange(self.count) + 0.5) * self.dz_m
        z.setflags(write=False)
        return z


def default_disc_count(tool: Tool, ap_m: float, max_lag_deg: float = 0.5) -> int:
    """Discs needed so that the helix lag between neighbouring discs is at most ``max_lag_deg``.

    A straight tool (helix 0) needs one disc: all slices see the same edge angle.

    Parameters
    ----------
    tool : Tool
    ap_m : float
        Axial depth of cut, m.
    max_lag_deg : float
        Largest helix lag between two neighbouring discs, deg (> 0). An edge at a disc boundary
        enters or leaves the cut at most ``max_lag_deg`` of spindle rotation away from its disc's
        representative angle.

    Returns
    -------
    int
    """
    ap = _finite("axial depth ap_m", ap_m, positive=True)
    lag = _finite("max_lag_deg", max_lag_deg, positive=True)
    total = math.degrees(float(tool.lag_rad(ap)))
    return max(1, int(math.ceil(total / lag - 1e-9)))


@dataclass(frozen=True)
class WallProfile:
    """The machined lateral wall: boundary of the remaining material per slice.

    Attributes
    ----------
    x_m : array (n,)
        Column positions along the feed, inside the part, m.
    y_m : array (K, n)
        ``y_c`` of the wall in each slice, m (nominally ``-R`` for down-milling, ``+R`` for up;
        still at the block edge where the tool has not passed).
    z_m : array (K,)
        Slice mid-heights above the tool tip, m.
    """

    x_m: np.ndarray
    y_m: np.ndarray
    z_m: np.ndarray


# --------------------------------------------------------------------------------------------
# kernels (numba)


@njit(inline="always")
def _tip_interval(wb, sgn, i, k):  # pragma: no cover - numba
    """Boundary values ``(w_i, w_i+1)`` of the line the chip uses in the tip's column interval ``i``: the
    line through the two columns on the side the tip moves towards, extended to the tip, where that
    side has them; else the plain interpolation.

    The chip is the material on the tooth's edge line that no edge has swept yet. In a run the tip
    sits on the path it has just cut (the force of a state is evaluated after the removal of the
    step that reached it), so the column behind the tip holds that cut, while the unswept material
    lies on the side the tip moves towards: ``-x_c`` in down-milling (``cos(phi) < 0``, the tip's speed
    ``R Omega`` against the feed), ``+x_c`` in up-milling (where the tooth's own removal is pending
    anyway). Interpolating across the tip would put a ramp of one column width in place of that
    step and hide part of a chip whose ray crosses less than a column, ``h |sin(phi)| < dx``: the last
    degrees before a down-milling exit, where up to 80 % of a 1.5 um chip was lost at ``dx = 1 um``,
    and the chip just past 180 deg (to ``180 deg + fz / (2 R)``), which was lost entirely. Next to a
    column without material (a face of the part) the plain interpolation is kept."""
    n = wb.shape[1]
    empty = 0.5 * _NO_MATERIAL_M  # columns at or below this hold no material (part faces, padding)
    if sgn > 0.0:
        if i >= 1 and wb[k, i - 1] > empty and wb[k, i] > empty:
            return wb[k, i], 2.0 * wb[k, i] - wb[k, i - 1]
    elif i + 2 <= n - 1 and wb[k, i + 1] > empty and wb[k, i + 2] > empty:
        return 2.0 * wb[k, i + 1] - wb[k, i + 2], wb[k, i + 1]
    return wb[k, i], wb[k, i + 1]


#: Unit round-off of float64.
_EPS = 2.0 ** -52


@njit(inline="always")
def _interval_exit(x0, dx, cx, cw, sn, cs, i, wi, wj, rho_hi):  # pragma: no cover - numba
    """Where the ray, going inwards, leaves column interval ``i`` (boundary ``wi`` -> ``wj``):
    ``(rho_lo, g_lo, last)``, m, m, bool; ``g`` is the material's boundary minus the ray's ``w``
    (``< 0``: out of the material); ``last`` where the interval holds the tool centre (rho reaches 0)."""
    last = False
    if sn > 1e-15:
        rho_lo = (x0 + i * dx - cx) / sn
    elif sn < -1e-15:
        rho_lo = (x0 + (i + 1) * dx - cx) / sn
    else:
        rho_lo = 0.0
    if rho_lo <= 0.0:
        rho_lo = 0.0
        last = True
    if rho_lo > rho_hi:
        rho_lo = rho_hi
    fl = (cx + rho_lo * sn - x0) / dx - i
    if fl < 0.0:
        fl = 0.0
    elif fl > 1.0:
        fl = 1.0
    return rho_lo, wi + (wj - wi) * fl - (cw + rho_lo * cs), last


@njit(inline="always")
def _crossing_chip(r, rho_lo, rho_hi, g_lo, g_hi, wi, wj, dx, sn, cs, sgn):  # pragma: no cover - numba
    """Chip and derivatives ``(h, dh/dc_x, dh/dc_y)`` where the ray leaves the material inside the
    interval ``[rho_lo, rho_hi]`` (``g_lo < 0 <= g_hi``; module docstring, "Chip thickness")."""
    rho_b = rho_lo + (rho_hi - rho_lo) * (-g_lo) / (g_hi - g_lo)
    sl = (wj - wi) / dx
    den = cs - sl * sn
    if den != 0.0:
        return r - rho_b, -sl / den, sgn / den  # d/dc_y = s d/dc_w
    return r - rho_b, 0.0, 0.0


@njit(inline="always")
def _first_uncleared(wb, x0, dx, cx, cw, sn, cs, r, k, i, step, delta, tol0):  # pragma: no cover - numba
    """The first column interval from ``i`` on (in steps of ``step``, -1 or +1, the ray's direction
    inwards) that an error bound does not clear, or the first index off the grid.

    An interval is cleared when the exact walk (:func:`_interval_exit`) provably finds the ray still
    in the material at its inner end (``g_lo >= 0``) and the tool centre not yet reached
    (``0 < rho_lo < r``). The test evaluates ``g`` at the column of that end without the division
    and the interpolation of the exact walk: ``rho~ = (x_c - cx) fl(1/sn)`` is within ``3 eps rho``
    of the exact ``rho_lo`` (one more rounding than the division), and the exact walk's fraction
    ``fl`` at that end is within ``delta`` of 0 (``sn > 0``) or 1 (``sn < 0``), so its boundary value
    is within ``delta |wj - wi|`` of the column's; with the round-off of the sums of ``g``
    (``tol0 + 64 eps (|wi| + |wj|)``) the bounds are applied with margins (see :func:`_chip_one`),
    so the skip changes no bit of the result."""
    ncol = wb.shape[1]
    inv = 1.0 / sn
    rho_min = 8.0 * _EPS * r
    rho_max = r * (1.0 - 16.0 * _EPS)
    off = 0 if step < 0 else 1  # column at the interval's inner end: i (ray towards -x) or i + 1
    while 0 <= i < ncol - 1:
        c = i + off
        rho = (x0 + c * dx - cx) * inv
        if not (rho > rho_min and rho < rho_max):
            return i
        wi = wb[k, i]
        wj = wb[k, i + 1]
        if wb[k, c] - (cw + rho * cs) <= tol0 + delta * abs(wj - wi) + 64.0 * _EPS * (abs(wi) + abs(wj)):
            return i
        i += step
    return i


@njit(inline="always")
def _chip_one(wb, x0, dx, cx, cw, sgn, phi, r, k):  # pragma: no cover - numba
    """Chip of one edge element (tip radius ``r``, angle ``phi``, disc ``k``) and its derivatives:
    ``(h, dh/dc_x, dh/dc_y)`` (m, 1, 1; module docstring, "Chip thickness"); ``(0, 0, 0)`` out of
    the material.

    The walk over the column intervals skips those an error bound clears
    (:func:`_first_uncleared`) and takes the exact arithmetic of the column-by-column walk
    (:func:`_chip_one_columnwise`) at the tip's interval, at the interval where the ray leaves the
    material and at the one before it, so the result is the reference's, bit for bit
    (``tests/test_workpiece.py``). Bounds (eps = 2**-52): the exact walk's fraction at an interval's
    end, ``(cx + rho sn - x0) / dx - i``, reconstructs ``x0 + i dx`` from sums and products of
    numbers of size at most ``X = |x0| + |cx| + r + ncol dx``, each off by at most a few eps of
    ``X``, so it is within ``8 eps (X / dx + ncol)`` of 0 or 1; ``delta`` is 8 times that. The two
    evaluations of ``g`` (exact and cleared test) round off by at most ``10 eps (|wi| + |wj| + |cw|
    + r)`` together, with ``|rho| <= r`` and ``|cs| <= 1``; the test allows ``64 eps`` times that
    (``tol0 = 64 eps (|cw| + r)``)."""
    ncol = wb.shape[1]
    sn = math.sin(phi)
    cs = sgn * math.cos(phi)
    xt = cx + r * sn
    u = (xt - x0) / dx
    if not (u >= 0.0 and u < ncol - 1):
        return 0.0, 0.0, 0.0
    i = int(math.floor(u))
    f = u - i
    wi, wj = _tip_interval(wb, sgn, i, k)
    g_hi = wi + (wj - wi) * f - (cw + r * cs)
    if g_hi < 0.0:
        return 0.0, 0.0, 0.0  # tip out of the material
    step = -1 if sn > 0.0 else 1
    delta = 64.0 * _EPS * ((abs(x0) + abs(cx) + r + ncol * dx) / dx + ncol)
    tol0 = 64.0 * _EPS * (abs(cw) + r)
    rho_hi = r
    rho_lo, g_lo, last = _interval_exit(x0, dx, cx, cw, sn, cs, i, wi, wj, rho_hi)
    while True:
        if g_lo < 0.0:
            return _crossing_chip(r, rho_lo, rho_hi, g_lo, g_hi, wi, wj, dx, sn, cs, sgn)
        if last:
            return r, 0.0, 0.0  # tool centre inside the material: the tooth is buried
        rho_hi = rho_lo
        g_hi = g_lo
        i += step
        if i < 0 or i >= ncol - 1:
            return r - rho_hi, 0.0, 0.0  # left the grid: beyond it there is no material
        j = _first_uncleared(wb, x0, dx, cx, cw, sn, cs, r, k, i, step, delta, tol0)
        if j != i:  # i .. j - step cleared: the exact walk's values at the inner end of the last of them
            p = j - step
            rho_hi, g_hi, _ = _interval_exit(x0, dx, cx, cw, sn, cs, p, wb[k, p], wb[k, p + 1], r)
            i = j
            if i < 0 or i >= ncol - 1:
                return r - rho_hi, 0.0, 0.0
        wi = wb[k, i]
        wj = wb[k, i + 1]
        rho_lo, g_lo, last = _interval_exit(x0, dx, cx, cw, sn, cs, i, wi, wj, rho_hi)


@njit(inline="always")
def _chip_one_columnwise(wb, x0, dx, cx, cw, sgn, phi, r, k):  # pragma: no cover - numba
    """The reference of :func:`_chip_one`: the same chip and derivatives ``(h, dh/dc_x, dh/dc_y)`` (m,
    1, 1) by the walk of every column interval with the exact arithmetic (the kernel before the
    cleared columns were skipped; kept for the tests and the benchmark of the skip)."""
    ncol = wb.shape[1]
    sn = math.sin(phi)
    cs = sgn * math.cos(phi)
    xt = cx + r * sn
    u = (xt - x0) / dx
    if not (u >= 0.0 and u < ncol - 1):
        return 0.0, 0.0, 0.0
    i = int(math.floor(u))
    f = u - i
    wi, wj = _tip_interval(wb, sgn, i, k)
    g_hi = wi + (wj - wi) * f - (cw + r * cs)
    if g_hi < 0.0:
        return 0.0, 0.0, 0.0  # tip out of the material
    rho_hi = r
    first = True
    while True:
        if not first:
            wi = wb[k, i]
            wj = wb[k, i + 1]
        first = False
        last = False
        # rho where the ray, going inwards, leaves column interval i
        if sn > 1e-15:
            rho_lo = (x0 + i * dx - cx) / sn
        elif sn < -1e-15:
            rho_lo = (x0 + (i + 1) * dx - cx) / sn
        else:
            rho_lo = 0.0
        if rho_lo <= 0.0:
            rho_lo = 0.0
            last = True
        if rho_lo > rho_hi:
            rho_lo = rho_hi
        fl = (cx + rho_lo * sn - x0) / dx - i
        if fl < 0.0:
            fl = 0.0
        elif fl > 1.0:
            fl = 1.0
        g_lo = wi + (wj - wi) * fl - (cw + rho_lo * cs)
        if g_lo < 0.0:
            rho_b = rho_lo + (rho_hi - rho_lo) * (-g_lo) / (g_hi - g_lo)
            sl = (wj - wi) / dx
            den = cs - sl * sn
            if den != 0.0:
                return r - rho_b, -sl / den, sgn / den  # d/dc_y = s d/dc_w
            return r - rho_b, 0.0, 0.0
        if last:
            return r, 0.0, 0.0  # tool centre inside the material: the tooth is buried
        rho_hi = rho_lo
        g_hi = g_lo
        if sn > 0.0:
            i -= 1
        else:
            i += 1
        if i < 0 or i >= ncol - 1:
            return r - rho_hi, 0.0, 0.0  # left the grid: beyond it there is no material


@njit(inline="always")
def _tip_in_material(wb, x0, dx, cx, cw, sgn, phi, r, k):  # pragma: no cover - numba
    """Whether the tip of an edge element is in the material (the test that makes its chip > 0)."""
    ncol = wb.shape[1]
    u = (cx + r * math.sin(phi) - x0) / dx
    if not (u >= 0.0 and u < ncol - 1):
        return False
    i = int(math.floor(u))
    f = u - i
    wi, wj = _tip_interval(wb, sgn, i, k)
    return wi + (wj - wi) * f - (cw + r * sgn * math.cos(phi)) >= 0.0


@njit(cache=True, nogil=True)
def _chip_kernel(wb, x0, dx, cx, cw, sgn, phi, radius, h, d):  # pragma: no cover - numba
    n_teeth, n_discs = phi.shape
    for j in range(n_teeth):
        for k in range(n_discs):
            h[j, k], d[j, k, 0], d[j, k, 1] = _chip_one(wb, x0, dx, cx, cw, sgn, phi[j, k], radius[j], k)


@njit(cache=True, nogil=True)
def _chip_kernel_columnwise(wb, x0, dx, cx, cw, sgn, phi, radius, h, d):  # pragma: no cover - numba
    """:func:`_chip_kernel` with the reference walk :func:`_chip_one_columnwise` (tests, benchmark)."""
    n_teeth, n_discs = phi.shape
    for j in range(n_teeth):
        for k in range(n_discs):
            h[j, k], d[j, k, 0], d[j, k, 1] = _chip_one_columnwise(wb, x0, dx, cx, cw, sgn, phi[j, k], radius[j], k)


@njit(cache=True, nogil=True)
def _remove_kernel(wb, x0, dx, cx0, cw0, cx1, cw1, sgn, phi0, phi1, radius, dtheta_max, w_top,
                   pend_i, pend_w, pend_a, pend_n, cull=True):  # pragma: no cover - numba
    # cull: skip the chords of a tip path that provably cannot reach the part (every chord vertex
    # above the block edge, or left or right of the column grid), from bounds of the path: the
    # centre moves linearly and |d^2 (sin, cos) / d ang^2| <= 1, so between its ends a path
    # coordinate deviates from its chord by at most r da^2 / 8. Such chords change nothing (the
    # vertex test and the column range below skip them), so culling gives identical results; it
    # saves the sines and cosines of the ~55 % of the revolution a tooth spends out of the part.
    n_teeth, n_discs = phi0.shape
    ncol = wb.shape[1]
    x_lo = x0 - 0.5 * dx
    x_hi = x0 + (ncol - 0.5) * dx
    cwmin = min(cw0, cw1)
    cxmin = min(cx0, cx1)
    cxmax = max(cx0, cx1)
    cap = pend_i.shape[2]
    touched = 0
    overflow = 0
    for j in range(n_teeth):
        r = radius[j]
        for k in range(n_discs):
            a1 = phi1[j, k]
            s1 = math.sin(a1)
            c1 = sgn * math.cos(a1)
            # 1. pending updates whose column the tooth has now swept down to the boundary
            m = 0
            for e in range(pend_n[j, k]):
                i = pend_i[j, k, e]
                w = pend_w[j, k, e]
                if w >= wb[k, i]:
                    continue
                dxb = x0 + i * dx - cx1
                dwb = wb[k, i] - cw1
                if sgn * (s1 * dwb - c1 * dxb) > 0.0 or a1 - pend_a[j, k, e] > math.pi:
                    wb[k, i] = w
                    touched += 1
                else:
                    pend_i[j, k, m] = i
                    pend_w[j, k, m] = w
                    pend_a[j, k, m] = pend_a[j, k, e]
                    m += 1
            pend_n[j, k] = m
            # 2. the new stretch of tip path, as chords
            a0 = phi0[j, k]
            da = a1 - a0
            if cull:
                sag = r * (da * da / 8.0) + 1e-12
                s0 = math.sin(a0)
                c0 = sgn * math.cos(a0)
                if (cwmin + r * min(c0, c1) - sag > w_top or cxmax + r * max(s0, s1) + sag < x_lo
                        or cxmin + r * min(s0, s1) - sag > x_hi):
                    continue
            nsub = int(math.ceil(abs(da) / dtheta_max))
            if nsub < 1:
                nsub = 1
            # the chord vertices' sines and cosines by turning the previous vertex's through da / nsub
            # (four products instead of a sine and a cosine), recomputed directly every
            # _ROTATION_RESTART vertices: each turn adds at most a few eps to their error
            sa = math.sin(a0)
            ca = math.cos(a0)
            sd = math.sin(da / nsub)
            cd = math.cos(da / nsub)
            xa = cx0 + r * sa
            wa = cw0 + sgn * r * ca
            for q in range(1, nsub + 1):
                s = q / nsub
                ang = a0 + s * da
                if q % _ROTATION_RESTART == 0:
                    sa, ca = math.sin(ang), math.cos(ang)
                else:
                    sa, ca = sa * cd + ca * sd, ca * cd - sa * sd
                xb = cx0 + s * (cx1 - cx0) + r * sa
                wbv = cw0 + s * (cw1 - cw0) + sgn * r * ca
                if wa <= w_top or wbv <= w_top:
                    if xa <= xb:
                        xl, wl, xr, wr = xa, wa, xb, wbv
                    else:
                        xl, wl, xr, wr = xb, wbv, xa, wa
                    il = int(math.ceil((xl - x0) / dx))
                    ir = int(math.floor((xr - x0) / dx))
                    if il < 0:
                        il = 0
                    if ir > ncol - 1:
                        ir = ncol - 1
                    span = xr - xl
                    amid = ang - 0.5 * da / nsub
                    for i in range(il, ir + 1):
                        if span > 0.0:
                            w = wl + (wr - wl) * ((x0 + i * dx - xl) / span)
                        else:
                            w = min(wl, wr)
                        if w < wb[k, i]:
                            # The material between the tip and the boundary point B of this column
                            # is gone only once the tooth has turned past B (always so for
                            # down-milling; in up-milling B lies ahead of the tip): else pend.
                            dxb = x0 + i * dx - cx1
                            dwb = wb[k, i] - cw1
                            if sgn * (s1 * dwb - c1 * dxb) > 0.0:
                                wb[k, i] = w
                                touched += 1
                            elif pend_n[j, k] < cap:
                                e = pend_n[j, k]
                                pend_i[j, k, e] = i
                                pend_w[j, k, e] = w
                                pend_a[j, k, e] = amid
                                pend_n[j, k] = e + 1
                            else:
                                wb[k, i] = w
                                touched += 1
                                overflow += 1
                xa = xb
                wa = wbv
    return touched, overflow


@njit(cache=True, nogil=True)
def _settle_kernel(wb, pend_i, pend_w, pend_n):  # pragma: no cover - numba
    n_teeth, n_discs = pend_n.shape
    for j in range(n_teeth):
        for k in range(n_discs):
            for e in range(pend_n[j, k]):
                i = pend_i[j, k, e]
                if pend_w[j, k, e] < wb[k, i]:
                    wb[k, i] = pend_w[j, k, e]


# --------------------------------------------------------------------------------------------


class Workpiece:
    """A block of material eroded by the tooth tips, one slice per tool disc.

    Parameters
    ----------
    tool : Tool
        The end mill (its nominal radius ``D/2`` places the block edge).
    cut : Cut
        Gives ``ae``, ``ap`` and the milling mode (material side).
    x_entry_m : float
        ``x_c`` of the part's entry face, m (the caller's origin of ``x_c``).
    part_length_m : float
        Part length along the feed, m (> 0).
    discs : AxialDiscs or int, optional
        Axial slices (or their number) over ``ap``. Default :func:`default_disc_count`.
    dx_m : float
        Column spacing along ``x_c``, m (> 0, default 1 um). Memory: ``8 K L / dx`` bytes for the
        boundary plus ``96 T K (D/2) / dx`` for the pending-update buffers.
    chord_tol_m : float
        Largest sagitta of the chords that approximate the tooth-tip paths in :meth:`remove`, m
        (> 0, default 1 nm).

    Raises
    ------
    WorkpieceError
        Non-finite or non-positive sizes, ``ae > D/2`` (see the module docstring), or a grid too
        large for memory.
    """

    def __init__(
        self,
        tool: Tool,
        cut: Cut,
        *,
        x_entry_m: float,
        part_length_m: float,
        discs: AxialDiscs | int | None = None,
        dx_m: float = 1e-6,
        chord_tol_m: float = 1e-9,
    ) -> None:
        if not isinstance(tool, Tool):
            raise WorkpieceError(f"tool must be a cases.milling.Tool, got {type(tool).__name__}")
        if not isinstance(cut, Cut):
            raise WorkpieceError(f"cut must be a cases.milling.Cut, got {type(cut).__name__}")
        try:
            check_cut(tool, cut)
        except MillingError as e:
            raise WorkpieceError(str(e)) from None
        radius = tool.radius_m
        if cut.ae_m > radius * (1 + 1e-12):
            raise WorkpieceError(
                f"radial depth ae = {cut.ae_m * 1e3:.6g} mm exceeds the tool radius {radius * 1e3:.6g} mm: the "
                f"column (height-field) workpiece needs ae <= D/2 (radial immersion <= 50 %)"
            )
        self._x_entry = _finite("x_entry_m", x_entry_m)
        self._length = _finite("part_length_m", part_length_m, positive=True)
        self._dx = _finite("dx_m", dx_m, positive=True)
        if self._dx > 1e-4:
            raise WorkpieceError(
                f"column spacing dx_m = {self._dx:.6g} m is too coarse to resolve a chip; valid: 0 < dx <= 1e-4 m"
                f" (1-2 um recommended)"
            )
        self._chord_tol = _finite("chord_tol_m", chord_tol_m, positive=True)
        if discs is None:
            discs = AxialDiscs(cut.ap_m, default_disc_count(tool, cut.ap_m))
        elif not isinstance(discs, AxialDiscs):
            discs = AxialDiscs(cut.ap_m, discs)
        elif abs(discs.ap_m - cut.ap_m) > 1e-12 * cut.ap_m:
            raise WorkpieceError(f"discs cover ap = {discs.ap_m} m but the cut has ap = {cut.ap_m} m")
        self._discs = discs
        self._tool = tool
        self._cut = cut
        self._sgn = 1.0 if cut.mode == "down" else -1.0
        self._w_edge = -(radius - cut.ae_m)
        n_part = int(math.floor(self._length / self._dx + 1e-9)) + 1
        ncol = n_part + 2 * _PAD_COLUMNS
        if ncol * discs.count > _MAX_CELLS:
            raise WorkpieceError(
                f"workpiece grid of {discs.count} slices x {ncol} columns is too large; raise dx_m "
                f"(now {self._dx:.3g} m) or use fewer discs"
            )
        self._x0 = self._x_entry - _PAD_COLUMNS * self._dx
        self._ncol = ncol
        self._wb = np.full((discs.count, ncol), _NO_MATERIAL_M)
        self._part_cols = slice(_PAD_COLUMNS, _PAD_COLUMNS + n_part)
        self._wb[:, self._part_cols] = self._w_edge
        self._dtheta_max = math.sqrt(8.0 * self._chord_tol / radius)
        # Pending column updates (see remove()): per tooth and disc, at most two per column in reach.
        reach = radius + max(abs(r) for r in tool.runout_m) + 1e-4
        cap = 2 * int(math.ceil(2 * reach / self._dx)) + 64
        shape = (tool.teeth, discs.count)
        self._pend_i = np.zeros(shape + (cap,), dtype=np.int64)
        self._pend_w = np.zeros(shape + (cap,))
        self._pend_a = np.zeros(shape + (cap,))
        self._pend_n = np.zeros(shape, dtype=np.int64)
        self._revision = 0

    # ---- geometry -------------------------------------------------------------------------
    @property
    def tool(self) -> Tool:
        return self._tool

    @property
    def cut(self) -> Cut:
        return self._cut

    @property
    def discs(self) -> AxialDiscs:
        """The axial slices (one per tool disc)."""
        return self._discs

    @property
    def mode(self) -> Literal["up", "down"]:
        return self._cut.mode

    @property
    def revision(self) -> int:
        """Number of :meth:`remove` calls so far (a cache key for results that depend on the part)."""
        return self._revision

    @property
    def x_entry_m(self) -> float:
        return self._x_entry

    @property
    def x_exit_m(self) -> float:
        return self._x_entry + self._length

    @property
    def part_length_m(self) -> float:
        return self._length

    @property
    def dx_m(self) -> float:
        return self._dx

    @property
    def edge_y_m(self) -> float:
        """``y_c`` of the block's free edge before cutting, m."""
        return self._sgn * self._w_edge

    @property
    def nominal_wall_y_m(self) -> float:
        """``y_c`` of the finished wall for a rigid tool on the nominal path, ``-+R``, m."""
        return -self._sgn * self._tool.radius_m

    @property
    def x_columns_m(self) -> np.ndarray:
        """Positions of all columns (part and padding), shape (n_columns,), m."""
        x = self._x0 + self._dx * np.arange(self._ncol)
        x.setflags(write=False)
        return x

    def boundary_y_m(self) -> np.ndarray:
        """Material boundary ``y_b`` the chips are computed on, every slice and column, (K, n_columns), m.

        A copy, without the pending updates (see :meth:`remove`; :meth:`wall_profile` includes them).

        Columns without material (outside the part) hold ``y = -+1 m`` (1 m beyond the edge).
        """
        return readonly(self._sgn * self._wb)

    def removed_area_m2(self) -> np.ndarray:
        """Area removed from each slice so far (trapezoid rule over the columns, pending updates
        included), shape (K,), m^2."""
        depth = self._w_edge - self._settled()[:, self._part_cols]
        return readonly(np.trapezoid(depth, dx=self._dx, axis=1))

    def copy(self) -> "Workpiece":
        """An independent copy (same geometry, same eroded state)."""
        new = object.__new__(Workpiece)
        new.__dict__.update(self.__dict__)
        for name in ("_wb", "_pend_i", "_pend_w", "_pend_a", "_pend_n"):
            setattr(new, name, getattr(self, name).copy())
        return new

    def _settled(self) -> np.ndarray:
        """Boundary with every pending update applied (a copy), internal w, (K, n_columns)."""
        wb = self._wb.copy()
        _settle_kernel(wb, self._pend_i, self._pend_w, self._pend_n)
        return wb

    # ---- queries ----------------------------------------------------------------------------
    def _check_state(self, center_m, phi_rad, radius_m):
        c = np.asarray(center_m, dtype=float)
        if c.shape != (2,) or not np.all(np.isfinite(c)):
            raise WorkpieceError(f"tool centre must be a finite (x_c, y_c) pair in m, got {shown(center_m)}")
        phi = np.ascontiguousarray(phi_rad, dtype=float)
        if phi.ndim != 2 or phi.shape[1] != self._discs.count:
            raise WorkpieceError(
                f"immersion angles must have shape (teeth, {self._discs.count} discs), got {phi.shape}"
            )
        if not np.all(np.isfinite(phi)):
            raise WorkpieceError("immersion angles must be finite")
        r = np.ascontiguousarray(radius_m, dtype=float)
        if r.shape != (phi.shape[0],) or not np.all(r > 0) or not np.all(np.isfinite(r)):
            raise WorkpieceError(f"tooth radii must be {phi.shape[0]} finite values > 0 m, got {shown(radius_m)}")
        return c, phi, r

    def chip(self, center_m, phi_rad, radius_m) -> tuple[np.ndarray, np.ndarray]:
        """Chip thickness of every edge element and its derivative with respect to the tool centre.

        Does not modify the part.

        Parameters
        ----------
        center_m : array (2,)
            Tool centre ``(x_c, y_c)``, m.
        phi_rad : array (T, K)
            Immersion angle of tooth j on disc k, rad (``cases.milling`` convention).
        radius_m : array (T,)
            Tooth tip radii ``R + runout_j``, m.

        Returns
        -------
        h_m : array (T, K)
            Chip thickness, m (0 where the tip is out of the material).
        dh_dcenter : array (T, K, 2)
            ``d h / d (x_c, y_c)`` of the tool centre, dimensionless (0 where h = 0).
        """
        c, phi, r = self._check_state(center_m, phi_rad, radius_m)
        return self._chip(c[0], c[1], phi, r)

    def _chip(self, cx: float, cy: float, phi: np.ndarray, r: np.ndarray):
        """Unchecked :meth:`chip` (phi C-contiguous float (T, K), r float (T,)); fresh arrays."""
        h = np.empty(phi.shape)
        d = np.empty(phi.shape + (2,))
        _chip_kernel(self._wb, self._x0, self._dx, cx, self._sgn * cy, self._sgn, phi, r, h, d)
        return h, d

    def remove(self, center0_m, center1_m, phi0_rad, phi1_rad, radius_m) -> int:
        """Erode the part along the tooth-tip paths of one accepted step.

        The tool centre moves linearly from ``center0_m`` to ``center1_m`` while every edge turns
        from ``phi0_rad`` to ``phi1_rad``; each tip lowers the boundary of the columns its path
        crosses, at once where the tooth has already swept the column down to its boundary, else
        when it has (pending updates; module docstring). Call it once per accepted step, in order,
        with unwrapped (increasing) angles.

        Parameters
        ----------
        center0_m, center1_m : array (2,)
            Tool centre at the start and end of the step, m.
        phi0_rad, phi1_rad : array (T, K)
            Immersion angles at the start and end of the step, rad.
        radius_m : array (T,)
            Tooth tip radii, m.

        Returns
        -------
        int
            Number of column updates (cells whose boundary moved).
        """
        c0, phi0, r = self._check_state(center0_m, phi0_rad, radius_m)
        c1, phi1, _ = self._check_state(center1_m, phi1_rad, radius_m)
        if phi0.shape != phi1.shape:
            raise WorkpieceError(f"phi0 {phi0.shape} and phi1 {phi1.shape} must have the same shape")
        return self._remove(c0[0], c0[1], c1[0], c1[1], phi0, phi1, r)

    def _remove(self, cx0, cy0, cx1, cy1, phi0, phi1, r) -> int:
        if phi0.shape != self._pend_n.shape:
            raise WorkpieceError(f"immersion angles {phi0.shape} must be (teeth, discs) = {self._pend_n.shape}")
        n, over = _remove_kernel(
            self._wb, self._x0, self._dx, cx0, self._sgn * cy0, cx1, self._sgn * cy1, self._sgn,
            phi0, phi1, r, self._dtheta_max, self._w_edge, self._pend_i, self._pend_w, self._pend_a, self._pend_n,
        )
        self._account_removal(1, n, over)
        return int(n)

    # ---- access for compiled callers (timedomain.fastpath) ----------------------------------
    def _kernel_state(self) -> tuple:
        """The live arrays and scalars the kernels take, for callers compiled with numba.

        Returns ``(wb, x0, dx, sgn, dtheta_max, w_top, pend_i, pend_w, pend_a, pend_n)``, passed
        exactly as :meth:`_chip` and :meth:`_remove` pass them:
        ``_chip_kernel(wb, x0, dx, cx, sgn * cy, sgn, phi, radius, h, d)`` and
        ``_remove_kernel(wb, x0, dx, cx0, sgn * cy0, cx1, sgn * cy1, sgn, phi0, phi1, radius,
        dtheta_max, w_top, pend_i, pend_w, pend_a, pend_n)``. The arrays are the part itself, not
        copies: a caller that runs ``_remove_kernel`` on them must report its steps with
        :meth:`_account_removal`.
        """
        return (self._wb, self._x0, self._dx, self._sgn, self._dtheta_max, self._w_edge,
                self._pend_i, self._pend_w, self._pend_a, self._pend_n)

    def _account_removal(self, commits: int, touched: int, overflow: int) -> None:
        """Count ``commits`` removal steps (``_remove_kernel`` calls): bumps :attr:`revision`.
        ``touched`` (column updates) and ``overflow`` (those forced by a full pending buffer) are
        what the kernels report; nothing reads them."""
        self._revision += int(commits)

    # ---- results ------------------------------------------------------------------------------
    def wall_profile(self) -> WallProfile:
        """The lateral wall left in every slice, over the part's columns (copies, read-only).

        Includes the updates still pending (tip paths whose column the tooth has not yet swept to
        the boundary), i.e. everything the tips have reached so far.
        """
        x = self.x_columns_m[self._part_cols]
        wb = self._settled()
        return WallProfile(x_m=readonly(x), y_m=readonly(self._sgn * wb[:, self._part_cols]), z_m=self._discs.z_m)

    def roughness(self, disc: int | None = None, *, x_range_m: tuple[float, float] | None = None, **kwargs):
        """ISO 4287 roughness of the lateral wall of one slice (see :func:`timedomain.signals.roughness`).

        Parameters
        ----------
        disc : int, optional
            Slice index (0 = at the tool tip). Default: the middle slice.
        x_range_m : (float, float), optional
            Part of the wall to evaluate, ``x_c`` in m. Default: the whole part length.
        **kwargs
            Passed to :func:`timedomain.signals.roughness` (``form``, ``cutoff_m``).

        Returns
        -------
        timedomain.signals.Roughness
        """
        from .signals import roughness

        k = self._discs.count // 2 if disc is None else int(disc)
        if not 0 <= k < self._discs.count:
            raise WorkpieceError(f"disc index {disc} out of range 0..{self._discs.count - 1}")
        prof = self.wall_profile()
        x, y = prof.x_m, prof.y_m[k]
        if x_range_m is not None:
            lo, hi = (_finite("x_range_m", v) for v in x_range_m)
            if not (self.x_entry_m - self._dx <= lo < hi <= self.x_exit_m + self._dx):
                raise WorkpieceError(
                    f"x_range_m {x_range_m} must be increasing and inside the part [{self.x_entry_m}, {self.x_exit_m}] m"
                )
            sel = (x >= lo) & (x <= hi)
            x, y = x[sel], y[sel]
        return roughness(x, y, **kwargs)
