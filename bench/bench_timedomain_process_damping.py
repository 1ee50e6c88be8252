"""Process damping at a low speed: where does the eroded part's flat rate come from?

The identification's synthetic steel case (no runout, 0.1355 mm per tooth), 300 rpm, 0.150 mm
deep, with the flank damper of ``Ksp L^2`` (default 8.1e6 N/m; ``tip_damper`` of
:class:`identify.cutting_effects.ProcessDamping`). Prints the SDM exponent (m = 40 / 80,
Richardson) at the pass start, the delay-based gated rate for each kick (1 deg per step, 6 s), and
for each column spacing of the eroded part (whole pass, 1 deg per step; ``comm``: fz / 135, a whole
number of columns per tooth) its verdict, the median second difference of the sections at the
tooth period and at the revolution over the first, middle and last tenth of the steady window, and
the mean normal deflection at the window's first and last tenth.

    python bench/bench_timedomain_process_damping.py [--ksp-l2 8.1e6] [--kick 2e-5,5e-5,1e-4,3e-4]
        [--dx comm,1e-6,0.5e-6]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from robolobes.cases import load_case
from robolobes.identify.cutting_effects import ProcessDamping
from robolobes.linearize import build_model, linearize
from robolobes.linearize.extra_elements import TipDamper
from robolobes.linearize.path import Pass
from robolobes.lobes import LobeProblem, PhysicalStructure
from robolobes.lobes.exponent import floquet_exponent
from robolobes.lobes.sdm import SemiDiscretization
from robolobes.timedomain import DelayNewmark, LinearizedNewmark, SimulationProblem, simulate
from robolobes.timedomain.problem import pass_duration_s
from robolobes.timedomain.summary import principal_period


def _case(tmp: Path):
    """The identification tests' synthetic steel case (tests/test_identify_process_damping.py) at the
    300 rpm, 0.150 mm point."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from test_identify_process_damping import _case_file

    base = load_case(_case_file(tmp))
    return replace(base, cut=replace(base.cut, spindle_rpm=300.0, ap_m=0.15e-3))


def _tenths(d):
    n = len(d)
    q = max(n // 10, 1)
    return (np.median(d[:q]), np.median(d[n // 2 - q // 2:n // 2 + q // 2 + 1]), np.median(d[-q:]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--ksp-l2", type=float, default=8.1e6, help="Ksp L^2, N/m")
    ap.add_argument("--kick", default="2e-5,5e-5,1e-4,3e-4", help="delay-based kicks, m (comma-separated)")
    ap.add_argument("--dx", default="comm,1e-6,0.5e-6", help="eroded column spacings, m, or comm (fz / 135)")
    a = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    with tempfile.TemporaryDirectory() as tmp:
        c = _case(Path(tmp))
    t = ProcessDamping().element_table(a.ksp_l2, c.tool, c.cut, c.cut.feed_direction)
    t.pop("type")
    robot = build_model(c.robot, "basic", extra_elements=(TipDamper(**t),) if a.ksp_l2 > 0 else ())
    st = PhysicalStructure.from_linear(linearize(robot, Pass.from_case(c).theta_at_s(0.0)), c.cut.feed_direction)
    fe = floquet_exponent(LobeProblem(st, c.tool, c.cut, c.law), SemiDiscretization(m=40))
    print(f"Ksp L2 {a.ksp_l2:.3g} N/m, fz {c.cut.feed_per_tooth_m * 1e3:.4f} mm, pass {pass_duration_s(c):.2f} s; "
          f"SDM exponent {fe.value_per_s:+.4f} 1/s (error {fe.error_per_s:.4f})", flush=True)
    for kick in (float(k) for k in a.kick.split(",")):
        c0 = time.process_time()
        r = simulate(SimulationProblem(robot, c, t_end_s=6.0), DelayNewmark(kick_m=kick, deg_per_step=1.0))
        print(f"delay-based, kick {kick:g} m: gated rate {r.rate.rate_per_s:+.4f} ± {2 * r.rate.se_per_s:.4f} 1/s "
              f"(2 SE, {r.rate.n_gated} periods, window {r.rate.window_s}), verdict {r.verdict.verdict.status}; "
              f"cpu {time.process_time() - c0:.1f} s", flush=True)
    tp = principal_period(c.tool, c.cut)[0]
    for v in a.dx.split(","):
        dx = c.cut.feed_per_tooth_m / 135 if v == "comm" else float(v)
        c0 = time.process_time()
        r = simulate(SimulationProblem(robot, c), LinearizedNewmark(deg_per_step=1.0, dx_m=dx))
        assert r.summary is not None
        t0, t1 = r.steady_window_s
        tt, y = np.asarray(r.t_s), np.asarray(r.tcp_deviation_m)[:, :2]
        ks = np.arange(math.ceil(t0 / tp), int(min(t1, tt[-1]) / tp))
        sec = y[np.searchsorted(tt, ks * tp - 1e-12)]
        d1 = np.linalg.norm(np.diff(sec, axis=0), axis=1)
        d2 = np.linalg.norm(sec[2:] - sec[:-2], axis=1)
        q = max(len(sec) // 10, 1)
        print(f"eroded, dx {dx * 1e6:.5g} um (fz / dx {c.cut.feed_per_tooth_m / dx:.4f}): steady window {t0:.2f}-{t1:.2f} s, "
              f"verdict {r.summary.verdict.status}; section differences, nm, first / middle / last tenth: tooth period "
              + " / ".join(f"{x * 1e9:.3f}" for x in _tenths(d1)) + ", revolution "
              + " / ".join(f"{x * 1e9:.3f}" for x in _tenths(d2))
              + f"; mean normal deflection first / last tenth {np.mean(sec[:q, 1]) * 1e6:.4f} / "
              f"{np.mean(sec[-q:, 1]) * 1e6:.4f} um; cpu {time.process_time() - c0:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
