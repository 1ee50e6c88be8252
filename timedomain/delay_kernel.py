"""The compiled time loop of the delay-based regenerative simulator (:mod:`timedomain.delay`).

Equations (Insperger & Stepan; Schmitz & Smith, "Machining Dynamics", ch. 4)::

    M q'' + C q' + K q = P_f F_tool(t),       r = P_r q    (tool displacement, cut plane, m)
    h_e(t) = h0_j sin(phi_e) + n(phi_e) . (r(t) - r(t - tau_j)),    n = (sin phi, cos phi)
    F_tool = sum_e g(phi_e) project(phi_e, law(h_e, db))

for every edge element ``e`` (tooth ``j``, disc ``k``) at ``phi_e = Omega t + theta_j - psi(z_k)``,
``g`` the screen function of the nominal arc ``[phi_st, phi_ex]``, ``h0_j`` and ``tau_j`` the
tooth's static chip and delay (:func:`cases.milling.regeneration`: variable pitch, runout), the
law :func:`cases.milling.edge_force_law` (zero for ``h <= 0``: chip loss). With ``chip_loss``
False the law is continued linearly below ``h = 0`` inside the arc (``K_c h db + K_e db`` for every
``h``; the screen function ``g`` still applies): the exact linear model the semi-discretization
linearizes.

Time integration: average-acceleration Newmark (gamma 1/2, beta 1/4), written in its equivalent
trapezoidal form for ``(q, v)``::

    M (v1 - v0) + h/2 C (v0 + v1) + h/2 K (q0 + q1) = I_F,      q1 - q0 = h/2 (v0 + v1)

with ``I_F`` the integral of ``P_f F_tool`` over the step. Where no element enters or leaves the
arc inside the step, ``I_F = h/2 P_f (F0 + F1)``: exactly the Newmark step of
:mod:`timedomain.newmark`. An element that enters or leaves at a fraction ``[a, b]`` of the step
contributes the exact integral of its force held linear between its values at the step ends
(continued smoothly outside the arc): weights ``(b - a)(2 - a - b)`` on ``F0`` and
``(b - a)(a + b)`` on ``F1`` instead of 1 and 1. The screen function's jump then costs no order:
the scheme stays second order (the chip-loss switch ``h = 0`` is a kink, also second order).

Start: on the forced periodic response (the history before t = 0 and the state at t = 0 given by
the caller), kicked.

Delayed displacements: on the grid when ``tau_j / h`` is a whole number, else cubic Hermite
interpolation of the stored ``r`` and ``r'`` (error O(h^4), below the scheme's O(h^2)).
Newton on ``q1``: the force is linear in ``r1`` for a fixed set of cutting elements, so each
iteration is one dense solve of ``(S - P_f G P_r) q1 = rhs``, ``S = 4/h^2 M + 2/h C + K``; it stops
when the set of elements with ``h > 0`` no longer changes.
"""

from __future__ import annotations

import math

import numpy as np
import robolobes.cases.milling as _milling
from numba import njit

_edge_force_law = njit(inline="always")(_milling.edge_force_law)
_project_cut_frame = njit(inline="always")(_milling.project_cut_frame)

TWO_PI = 2.0 * math.pi


@njit(inline="always")
def _engaged_fraction(phi0, dphi, st, ex):  # pragma: no cover - numba
    """Part ``[a, b]`` of a step (fractions) in which ``phi`` (from phi0 over dphi) is in the arc."""
    p = phi0 - TWO_PI * math.floor(phi0 / TWO_PI)
    for shift in (0.0, TWO_PI):
        lo = max(p, st + shift)
        hi = min(p + dphi, ex + shift)
        if hi > lo:
            return (lo - p) / dphi, (hi - p) / dphi
    return 0.0, 0.0


@njit(inline="always")
def _delayed(r_hist, v_hist, x, k, h):  # pragma: no cover - numba
    """Displacement at row position ``x`` of the history (fractional, x <= k), cubic Hermite."""
    i = int(math.floor(x + 1e-9))
    s = x - i
    if s < 1e-9 or i >= k:
        i = min(i, k)
        return r_hist[i, 0], r_hist[i, 1]
    s2 = s * s
    s3 = s2 * s
    h00 = 2 * s3 - 3 * s2 + 1
    h10 = s3 - 2 * s2 + s
    h01 = -2 * s3 + 3 * s2
    h11 = s3 - s2
    out0 = h00 * r_hist[i, 0] + h10 * h * v_hist[i, 0] + h01 * r_hist[i + 1, 0] + h11 * h * v_hist[i + 1, 0]
    out1 = h00 * r_hist[i, 1] + h10 * h * v_hist[i, 1] + h01 * r_hist[i + 1, 1] + h11 * h * v_hist[i + 1, 1]
    return out0, out1


@njit(cache=True, nogil=True)
def run_delay_kernel(n_steps, h, omega, M, C, K, Pr, Pf, offset, tooth, h0, dsteps, st, ex, db, law,
                     kc, ke, q0, v0, r_hist, v_hist, d0, rec_f, rec_loss, max_iter, exact,
                     chip_loss):  # pragma: no cover - numba
    """Integrate ``n_steps`` steps from ``(q0, v0)`` at t = 0 (module docstring).

    r_hist, v_hist (d0 + N, 2): rows 0..d0-1 hold the history before t = 0 (grid times
    ``(i - d0) h``), row ``d0 + k`` is filled with the state at ``t = k h``.

    offset (E,) element angle offsets, rad; tooth (E,) int tooth of each element; h0, dsteps (T,)
    static chip (m) and delay in steps; kc, ke (3,) ``K_c db`` (N/m) and ``K_e db`` (N) of one
    element; law (6,) the coefficients times the element width db (then pass db = 1). Fills
    r_hist, v_hist (d0 + N + 1, 2), rec_f (N+1, 3) (force on
    the tool at each grid time, elements in the arc), rec_loss (N+1, 4) (chip-weighted lost and
    total engagement, then the count of elements with chip <= 0 and in the arc, at each grid time;
    with ``chip_loss`` False the chips are still counted, though they keep cutting). exact: False
    samples the screen function at the step ends instead (the plain Newmark step, first order at entry and exit; for comparison only).
    chip_loss: False continues the law linearly below h = 0 inside the arc (no active set).
    Returns (status, total Newton iterations, step); status 0 ok,
    1 no convergence, 2 not finite.
    """
    n = q0.shape[0]
    E = offset.shape[0]
    ktc, krc, kac, kte, kre, kae = law[0], law[1], law[2], law[3], law[4], law[5]
    S = 4.0 / (h * h) * M + 2.0 / h * C + K
    A0 = 4.0 / (h * h) * M + 2.0 / h * C - K
    B0 = 4.0 / h * M
    q = q0.copy()
    v = v0.copy()
    r0 = Pr @ q
    rv = Pr @ v
    r_hist[d0, 0], r_hist[d0, 1] = r0[0], r0[1]
    v_hist[d0, 0], v_hist[d0, 1] = rv[0], rv[1]
    rec_f[0, :] = 0.0
    rec_loss[0, :] = 0.0
    dphi = omega * h
    w1 = np.empty(E)
    hb1 = np.empty(E)
    ext1 = np.empty(E, dtype=np.bool_)
    act = np.empty(E, dtype=np.bool_)
    f0 = np.zeros(3)
    iters = 0
    for k in range(n_steps):
        t0 = k * h
        # known part: the weighted force of every element at t0 (state and delayed state known)
        f0[:] = 0.0
        cx0, cy0 = r_hist[d0 + k, 0], r_hist[d0 + k, 1]
        for e in range(E):
            phi0 = omega * t0 + offset[e]
            a, b = _engaged_fraction(phi0, dphi, st, ex)
            w1[e] = 0.0
            if b <= a:
                continue
            j = tooth[e]
            if exact:
                w0 = (b - a) * (2.0 - a - b)
                w1[e] = (b - a) * (a + b)
            else:  # the screen function sampled at the step ends (plain Newmark, for comparison)
                w0 = 1.0 if a <= 1e-12 else 0.0
                w1[e] = 1.0 if b >= 1.0 - 1e-12 else 0.0
            ext1[e] = b < 1.0 - 1e-12
            sn, cs = math.sin(phi0), math.cos(phi0)
            dx, dy = _delayed(r_hist, v_hist, d0 + k - dsteps[j], d0 + k, h)
            hh = h0[j] * sn + sn * (cx0 - dx) + cs * (cy0 - dy)
            if a > 1e-12 or not chip_loss:  # outside the arc or no chip loss: the linear element force
                et, er, ea = kc[0] * hh + ke[0], kc[1] * hh + ke[1], kc[2] * hh + ke[2]
            else:
                et, er, ea = _edge_force_law(hh, db, ktc, krc, kac, kte, kre, kae)
            fx, fy, fz = _project_cut_frame(phi0, et, er, ea)
            f0[0] += w0 * fx
            f0[1] += w0 * fy
            f0[2] += w0 * fz
            # chip at t1 without the unknown r1
            phi1 = phi0 + dphi
            sn1, cs1 = math.sin(phi1), math.cos(phi1)
            dx1, dy1 = _delayed(r_hist, v_hist, d0 + k + 1 - dsteps[j], d0 + k, h)
            hb1[e] = h0[j] * sn1 - sn1 * dx1 - cs1 * dy1
        rhs = A0 @ q + B0 @ v + Pf @ f0
        # Newton on q1: active set of the elements cutting at t1
        q1 = q + h * v
        status = 1
        for it in range(max_iter):
            iters += 1
            c1 = Pr @ q1
            G = np.zeros((3, 2))
            fc = np.zeros(3)
            changed = False
            for e in range(E):
                if w1[e] == 0.0:
                    continue
                phi1 = omega * t0 + offset[e] + dphi
                sn1, cs1 = math.sin(phi1), math.cos(phi1)
                hh = hb1[e] + sn1 * c1[0] + cs1 * c1[1]
                on = ext1[e] or hh > 0.0 or not chip_loss
                if it > 0 and on != act[e]:
                    changed = True
                act[e] = on
                if not on:
                    continue
                gx, gy, gz = _project_cut_frame(phi1, kc[0], kc[1], kc[2])
                ex_, ey_, ez_ = _project_cut_frame(phi1, kc[0] * hb1[e] + ke[0], kc[1] * hb1[e] + ke[1],
                                                   kc[2] * hb1[e] + ke[2])
                fc[0] += w1[e] * ex_
                fc[1] += w1[e] * ey_
                fc[2] += w1[e] * ez_
                G[0, 0] += w1[e] * gx * sn1
                G[0, 1] += w1[e] * gx * cs1
                G[1, 0] += w1[e] * gy * sn1
                G[1, 1] += w1[e] * gy * cs1
                G[2, 0] += w1[e] * gz * sn1
                G[2, 1] += w1[e] * gz * cs1
            if it > 0 and not changed:
                status = 0
                break
            q1 = np.linalg.solve(S - Pf @ G @ Pr, rhs + Pf @ fc)
        if status == 0:
            for i in range(n):
                if not math.isfinite(q1[i]):
                    status = 2
        if status != 0:
            return status, iters, k
        v = 2.0 / h * (q1 - q) - v
        q = q1
        r1 = Pr @ q
        rv = Pr @ v
        r_hist[d0 + k + 1, 0], r_hist[d0 + k + 1, 1] = r1[0], r1[1]
        v_hist[d0 + k + 1, 0], v_hist[d0 + k + 1, 1] = rv[0], rv[1]
        # records at t1: force of the elements in the arc, chip-weighted lost engagement
        t1 = (k + 1) * h
        fx = fy = fz = 0.0
        lost = total = n_lost = n_in = 0.0
        for e in range(E):
            phi1 = omega * t1 + offset[e]
            p = phi1 - TWO_PI * math.floor(phi1 / TWO_PI)
            if not (st <= p <= ex):
                continue
            j = tooth[e]
            sn1, cs1 = math.sin(phi1), math.cos(phi1)
            dx1, dy1 = _delayed(r_hist, v_hist, d0 + k + 1 - dsteps[j], d0 + k + 1, h)
            hh = h0[j] * sn1 + sn1 * (r1[0] - dx1) + cs1 * (r1[1] - dy1)
            wgt = h0[j] * sn1
            total += wgt
            n_in += 1.0
            if hh <= 0.0:
                lost += wgt
                n_lost += 1.0
            if chip_loss:
                et, er, ea = _edge_force_law(hh, db, ktc, krc, kac, kte, kre, kae)
            else:
                et, er, ea = kc[0] * hh + ke[0], kc[1] * hh + ke[1], kc[2] * hh + ke[2]
            px, py, pz = _project_cut_frame(phi1, et, er, ea)
            fx += px
            fy += py
            fz += pz
        rec_f[k + 1, 0], rec_f[k + 1, 1], rec_f[k + 1, 2] = fx, fy, fz
        rec_loss[k + 1, 0], rec_loss[k + 1, 1] = lost, total
        rec_loss[k + 1, 2], rec_loss[k + 1, 3] = n_lost, n_in
    return 0, iters, n_steps
