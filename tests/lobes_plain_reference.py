"""An independent, plain first-order semi-discretization of the milling benchmark (test-only).

Written from Insperger & Stepan (2004, Int. J. Numer. Meth. Eng. 61:117-141) and Insperger, Mann,
Stepan & Bayly (2003, Int. J. Mach. Tools Manuf. 43:25-34) for structures made of modes along the
feed ``x`` and the normal ``y``; it imports nothing from ``robolobes``. What differs from
``robolobes.lobes`` on purpose:

* original (physical) coordinates ``q = (x[, y])``, the state ``(q, q')`` and the FULL delayed
  history ``q_{i-1} .. q_{i-m}`` (no reduced history, no merged free steps);
* the step averages of the directional coefficients by their closed-form integrals (trig
  polynomials of degree 2), not by quadrature;
* the step propagators by the inverse-A formulas of the paper (``P1 = A^-1 (e^{A dt} - I)``), not a
  Van Loan exponential or a Taylor sum;
* the monodromy built by applying the steps to its rows (``O(m N)`` per step) and its spectral
  radius by LAPACK's dense eigenvalues;
* the critical depth by a scan of 48 quadratically spaced depths (each finer level walks from the
  coarser level's bracket to its own sign change) and plain bisection.

Converged values: the Richardson extrapolation (second order, ``b_2m + (b_2m - b_m) / 3``) of the
levels m = 160 and 320, with the difference to the extrapolation of 80 and 160 as its error
estimate (:func:`converged_depth`). The tests use the speeds where that estimate is below
``REF_TOL`` of the value.

Run ``.venv/bin/python tests/lobes_plain_reference.py --write`` to regenerate
``tests/data/lobes_accuracy_reference.json`` (1-2 CPU s per speed, 10-15 CPU minutes in all; the
committed file keeps 5 significant digits).
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.linalg import expm

DATA = Path(__file__).resolve().parent / "data" / "lobes_accuracy_reference.json"
TEETH = 2
KT, KN = 6e8, 2e8            # N/m^2
DIAM = 0.01                   # m
DEPTH_MAX = 0.01              # m: the searched depth (limits above it are inf)
M0 = 80                       # coarsest level of the reference (then 2 M0, 4 M0)
REF_TOL = 2e-3                # reference usable where its error estimate <= REF_TOL * value
SPEEDS = np.linspace(5000.0, 25000.0, 101)

#: modes (freq_hz, zeta, k_n_per_m) along x (feed) and y (normal); None: rigid
CASES = {
    "1dof-aD0.05-down": dict(x=(922.0, 0.011, 1.340049648e6), y=None, aD=0.05, mode="down"),
    "1dof-slot": dict(x=(922.0, 0.011, 1.340049648e6), y=None, aD=1.0, mode="down"),
    "2dof-sym-aD0.05-down": dict(x=(922.0, 0.011, 1.340049648e6), y=(922.0, 0.011, 1.340049648e6), aD=0.05,
                                 mode="down"),
    "2dof-asym-aD0.5-up": dict(x=(922.0, 0.011, 1.340049648e6), y=(1100.0, 0.02, 2e6), aD=0.5, mode="up"),
}


def engagement(aD: float, mode: str) -> tuple[float, float]:
    """Entry and exit angles (rad), measured from the normal y as in the papers."""
    if mode == "up":
        return 0.0, math.acos(1.0 - 2.0 * aD)
    return math.acos(2.0 * aD - 1.0), math.pi


def _antiderivative(phi: float) -> np.ndarray:
    """Integral of H(phi) = [[(Kt c + Kn s) s, (Kt c + Kn s) c], [(-Kt s + Kn c) s, (-Kt s + Kn c) c]]."""
    s2, c2 = math.sin(2 * phi), math.cos(2 * phi)
    # s c = s2/2, s^2 = (1 - c2)/2, c^2 = (1 + c2)/2 ; int s2 = -c2/2, int c2 = s2/2
    i_sc = -c2 / 4
    i_ss = phi / 2 - s2 / 4
    i_cc = phi / 2 + s2 / 4
    return np.array([[KT * i_sc + KN * i_ss, KT * i_cc + KN * i_sc],
                     [-KT * i_ss + KN * i_sc, -KT * i_sc + KN * i_cc]])


def step_averages(m: int, aD: float, mode: str) -> np.ndarray:
    """Average of sum_teeth g(phi_j) H(phi_j) over each of the m steps of one tooth period, (m, 2, 2)."""
    st, ex = engagement(aD, mode)
    dphi = 2 * math.pi / TEETH / m
    out = np.zeros((m, 2, 2))
    for i in range(m):
        a, b = i * dphi, (i + 1) * dphi
        for j in range(TEETH):
            off = j * 2 * math.pi / TEETH
            for turn in (-1, 0, 1):  # tooth angle phi = phi_rot + off, engaged on [st, ex] mod 2 pi
                lo = max(a + off, st + 2 * math.pi * turn)
                hi = min(b + off, ex + 2 * math.pi * turn)
                if hi > lo:
                    out[i] += _antiderivative(hi) - _antiderivative(lo)
        out[i] /= dphi
    return out


def spectral_radius(case: dict, rpm: float, depth: float, m: int, hbar: np.ndarray | None = None) -> float:
    """Spectral radius of the plain SDM monodromy (dense eigenvalues)."""
    dofs = [(i, c) for i, c in enumerate((case["x"], case["y"])) if c is not None]
    n = len(dofs)
    sel = [i for i, _ in dofs]
    mass = np.array([k / (2 * math.pi * f) ** 2 for _, (f, z, k) in dofs])
    kk = np.array([k for _, (f, z, k) in dofs])
    cc = np.array([2 * z * math.sqrt(k * mm) for (_, (f, z, k)), mm in zip(dofs, mass)])
    hbar = step_averages(m, case["aD"], case["mode"]) if hbar is None else hbar
    T = 60.0 / rpm / TEETH
    dt = T / m
    ns = 2 * n
    N = ns + n * m
    Y = np.zeros((ns, N))
    Y[:, :ns] = np.eye(ns)
    R = []  # R[j] = rows of q_{i-1-j}, j = 0..m-1
    for j in range(m):
        r = np.zeros((n, N))
        r[:, ns + n * j:ns + n * (j + 1)] = np.eye(n)
        R.append(r)
    Sq = np.zeros((n, ns))
    Sq[:, :n] = np.eye(n)
    Minv = np.diag(1.0 / mass)
    for i in range(m):
        H = depth * hbar[i][np.ix_(sel, sel)]
        A = np.zeros((ns, ns))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -Minv @ (np.diag(kk) + H)
        A[n:, n:] = -Minv @ np.diag(cc)
        B = np.zeros((ns, n))
        B[n:] = Minv @ H
        P0 = expm(A * dt)
        Ai = np.linalg.inv(A)
        P1 = Ai @ (P0 - np.eye(ns))
        Q0 = Ai @ (P0 - P1 / dt)     # weight of q_{i-m} (the older node)
        Q1 = P1 - Q0                 # weight of q_{i-m+1}
        q_old = R[m - 1]             # q_{i-m}
        q_new = R[m - 2] if m >= 2 else Sq @ Y
        Ynew = P0 @ Y + (Q0 @ B) @ q_old + (Q1 @ B) @ q_new
        R = [Sq @ Y] + R[:-1]
        Y = Ynew
    U = np.vstack([Y] + R)
    return float(np.max(np.abs(np.linalg.eigvals(U))))


def _grid() -> np.ndarray:
    return DEPTH_MAX * (np.arange(1, 49) / 48) ** 2


def critical_depth(case: dict, rpm: float, m: int, start: int | None = None, rtol: float = 1e-5) -> tuple[float, int]:
    """Smallest unstable depth (m) up to DEPTH_MAX (inf if none) and the index of the first unstable
    depth of the 48-point quadratic grid (48 if none).

    Without ``start``: the grid is scanned from its first depth up. With ``start`` (the grid index a
    coarser level found): the walk goes up from there while stable, or down while the depth below
    is unstable, to this level's own sign change. Then bisection to ``rtol``.
    """
    hbar = step_averages(m, case["aD"], case["mode"])
    grid = _grid()
    unstable = lambda d: spectral_radius(case, rpm, d, m, hbar) >= 1.0
    j = 0 if start is None else min(start, len(grid) - 1)
    if start is not None and j > 0 and unstable(grid[j - 1]):
        j -= 1
        while j > 0 and unstable(grid[j - 1]):
            j -= 1
    else:
        while j < len(grid) and not unstable(grid[j]):
            j += 1
    if j >= len(grid):
        return math.inf, len(grid)
    lo, hi = (grid[j - 1] if j > 0 else 0.0), grid[j]
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        if unstable(mid):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi), j


def _extrapolate(b1: float, b2: float) -> float:
    """Richardson value of levels m and 2 m for a second-order method (inf if either is inf)."""
    if math.isinf(b1) or math.isinf(b2):
        return math.inf if (math.isinf(b1) and math.isinf(b2)) else math.nan
    return b2 + (b2 - b1) / 3.0


def converged_depth(case: dict, rpm: float) -> dict:
    """Converged critical depth at one speed from the levels m = 80, 160, 320.

    ``depth_m`` is the Richardson value of 160/320; ``error_m`` the difference between the
    Richardson values of 80/160 and 160/320 (an estimate of the error of the coarser of the two
    extrapolations, so a conservative one of the finer). NaN where the levels disagree on whether a
    limit exists below DEPTH_MAX; both inf where none does.
    """
    levels = {}
    j = None
    for m in (M0, 2 * M0, 4 * M0):
        levels[m], j = critical_depth(case, rpm, m, start=j)
    r1 = _extrapolate(levels[M0], levels[2 * M0])
    r2 = _extrapolate(levels[2 * M0], levels[4 * M0])
    if math.isinf(r1) and math.isinf(r2):
        value, err = math.inf, 0.0
    elif not (math.isfinite(r1) and math.isfinite(r2)):
        value, err = math.nan, math.nan
    else:
        value, err = r2, abs(r2 - r1)
    return {"rpm": rpm, "depth_m": value, "error_m": err, "levels": {str(k): v for k, v in levels.items()}}


def compute(names=None, speeds=SPEEDS) -> dict:
    out: dict = {"note": ("independent plain first-order SDM (tests/lobes_plain_reference.py), Richardson of "
                          f"m = {M0}/{2 * M0}/{4 * M0}; depths in m (null: stable up to {DEPTH_MAX} m), speeds in rpm"),
                 "depth_max_m": DEPTH_MAX, "ref_tol": REF_TOL, "cases": {}}
    for name in names or CASES:
        rows = []
        for s in speeds:
            rows.append(converged_depth(CASES[name], float(s)))
            print(f"{name} {s:.0f} rpm: {rows[-1]['depth_m'] * 1e3:.5g} mm +- {rows[-1]['error_m'] * 1e3:.2g}",
                  file=sys.stderr, flush=True)
        out["cases"][name] = rows
    return out


def _jsonable(x):
    if isinstance(x, (float, np.floating)) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_jsonable(v) for v in x]
    return float(x) if isinstance(x, np.floating) else x


def load() -> dict:
    """The stored reference, with null depths/errors back to inf."""
    data = json.loads(DATA.read_text())
    for rows in data["cases"].values():
        for r in rows:
            r["depth_m"] = math.inf if r["depth_m"] is None else r["depth_m"]
            r["error_m"] = math.inf if r["error_m"] is None else r["error_m"]  # null error: levels disagree
    return data


if __name__ == "__main__":
    if "--write" in sys.argv:
        names = [a for a in sys.argv[1:] if a in CASES] or None
        data = compute(names)
        if names and DATA.exists():
            old = json.loads(DATA.read_text())
            old["cases"].update(data["cases"])
            data = old
        fd, tmp = tempfile.mkstemp(dir=DATA.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as fh:
            json.dump(_jsonable(data), fh, indent=1)
        os.replace(tmp, DATA)
        print(f"wrote {DATA}")


# ---------------------------------------------------------------------------------------------
# the accuracy criterion of the tests and of bench/bench_lobes_accuracy.py
SHIFT = 0.002      # speeds n' within 0.2 % of n
SHIFT_SAMPLES = 9  # n' = n (1 + k SHIFT / 4), k = -4..4
TOL = 0.01         # |b(n') - b_ref(n)| <= 1 % of b_ref(n)


def shifted_speeds(rpm: np.ndarray) -> np.ndarray:
    """(S, 9) speeds n' = n (1 + k 0.0005), k = -4..4, around each reference speed n."""
    k = np.linspace(-1.0, 1.0, SHIFT_SAMPLES)
    return np.asarray(rpm, dtype=float)[:, None] * (1.0 + SHIFT * k[None, :])


def usable(rows: list) -> np.ndarray:
    """Reference speeds whose own error estimate is at most REF_TOL of the value (or both inf)."""
    d = np.array([r["depth_m"] for r in rows], dtype=float)
    e = np.array([r["error_m"] for r in rows], dtype=float)
    return (np.isinf(d) & (e == 0)) | (np.isfinite(d) & (e <= REF_TOL * d))


def shifted_error(b_shifted: np.ndarray, b_ref: np.ndarray, depth_max: float = DEPTH_MAX) -> np.ndarray:
    """Relative error of the criterion per reference speed (S,): ``min_k |b(n'_k) - b_ref| / b_ref``,
    and 0 where two neighbouring samples ``b(n'_k), b(n'_k+1)`` bracket ``b_ref`` (the limit curve is
    continuous between them, so some n' in between meets it exactly). Both capped at ``depth_max``.
    ``b_shifted`` (S, 9), m; ``b_ref`` (S,), m."""
    b = np.minimum(np.asarray(b_shifted, dtype=float), depth_max)
    ref = np.minimum(np.asarray(b_ref, dtype=float), depth_max)[:, None]
    rel = np.abs(b - ref) / ref
    d = b - ref
    bracket = np.any(d[:, :-1] * d[:, 1:] <= 0, axis=1)
    return np.where(bracket, 0.0, rel.min(axis=1))
