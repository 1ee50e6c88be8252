"""The tilt of the regenerated surface (lobes/chip_direction.py) against the eroded part's excess.

Two parts. (1) The eroded part's chip derivative in the tool centre (``Workpiece.chip``, its exact ray
walk) after a vibration-free straight cut (1 deg steps, three revolutions in the part), against the ray
``u`` of the linear model and against ``u + alpha du/dphi`` (the closed form of the module), for both
teeth of the TX200 aluminium tool at 105-175 deg. (2) At the aluminium cut near its limit (basic model,
straight tool and, at 0.8x, the helical one, ap = factor x 5.09 mm) and the radial depth narrowed by the eroded runs' mean normal
deflection dy, the SDM exponent (m = 40 / 80, Richardson) without and with the entry shift and the
tilt, next to the eroded rates; dy and the eroded rates are those printed by
``bench/bench_timedomain_entry_feed.py`` (docs/guide/timedomain-convergence.md, straight tool tables).
Also printed: the estimate of the other fz / R term, the delayed instant (the regenerative difference
scaled by ``1 - (fz N / (2 pi R)) cos(phi)``, valid when the chatter frequency is well below the tooth
frequency, as here: 24.7 Hz against 623 Hz). ``--delay-time``: also the SDM with both terms and the
delayed instant itself (``entry_shift_exponent(..., delay_time=True)``), and the eroded rate minus that;
``--feeds 0.03`` keeps only the rows of those feeds (mm).

    python bench/bench_timedomain_chip_direction.py [--skip-jacobian] [--skip-sdm] [--delay-time] [--feeds 0.03]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import robolobes.linearize as L
from robolobes import cases
from robolobes.cases.milling import directional_matrix
from robolobes.lobes import DirectionalPlan, LobeProblem, PhysicalStructure, SemiDiscretization
from robolobes.lobes.chip_direction import feed_per_radian_m, surface_rotation_rad
from robolobes.lobes.entry_shift import entry_shift_exponent
from robolobes.lobes.exponent import floquet_exponent, two_level_exponent

ALU_LIMIT_M = 5.09e-3
# (factor, fz mm) -> (dy um, eroded rate 1/s, its SE), bench_timedomain_entry_feed.py (docs tables)
ERODED = {(0.8, 0.015): (10.47, -0.2183, 0.0087), (0.8, 0.03): (20.93, -0.1814, 0.0155),
          (0.8, 0.06): (41.76, -0.0956, 0.0197), (0.8, 0.12): (83.02, +0.0993, 0.0306),
          (1.1, 0.015): (14.49, +0.1629, 0.0082), (1.1, 0.03): (28.90, +0.2399, 0.0131),
          (1.1, 0.06): (57.46, +0.3990, 0.0117)}
# the helical tool (30 deg), 0.8x, same source
ERODED_HELIX = {(0.8, 0.03): (20.92, -0.1795, 0.0155), (0.8, 0.06): (41.77, -0.0955, 0.0199)}


def jacobian_part(base, tool):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from generators.ideal_cut import chip_jacobians

    for fz_mm in (0.015, 0.03, 0.06):
        cut = replace(base.cut, feed_per_tooth_m=fz_mm * 1e-3, ap_m=4e-3)
        jac = chip_jacobians(tool, cut, {105, 120, 135, 150, 165, 175})
        worst_u = worst_g = 0.0
        for (j, deg), (h, d) in sorted(jac.items()):
            phi = math.radians(deg)
            u = np.array([math.sin(phi), math.cos(phi)])
            hj = h / math.sin(phi)  # this tooth's static chip (its pitch's feed)
            a = float(surface_rotation_rad(phi, hj, tool.radius_m, feed_per_radian_m(tool, cut)))
            g = u + a * np.array([math.cos(phi), -math.sin(phi)])
            worst_u, worst_g = max(worst_u, float(np.linalg.norm(d - u))), max(worst_g, float(np.linalg.norm(d - g)))
            print(f"  fz {fz_mm} mm tooth {j} at {deg} deg: h {h * 1e6:7.3f} um, turn of dh/dc from u "
                  f"{math.atan2(d[0], d[1]) - phi:+.5f} rad, alpha {a:+.5f} rad")
        print(f"fz {fz_mm} mm: max |dh/dc - u| {worst_u:.2e}, max |dh/dc - (u + alpha du/dphi)| {worst_g:.2e}", flush=True)


class _DelayScaled(DirectionalPlan):
    """The plan with the tilt and the regenerative difference scaled by ``1 - (fz N / 2 pi R) cos(phi)``
    (the low-frequency form of the delayed instant's shift; an estimate, not a model of the lobes)."""

    def _directional(self, phi, chip_m, delay_shift=False):
        rot = surface_rotation_rad(phi, chip_m, self.tool.radius_m, feed_per_radian_m(self.tool, self.cut))
        scale = 1 - feed_per_radian_m(self.tool, self.cut) / self.tool.radius_m * np.cos(phi)
        return directional_matrix(phi, self.law, rot)[..., :self.k_force, :] * scale[..., None, None]


def _delay_estimate(problem, method):
    def radius(engine, rpm, depth):
        engine.plan = _DelayScaled(**{f.name: getattr(engine.plan, f.name) for f in fields(engine.plan)})
        return float(np.max(np.abs(np.linalg.eigvals(engine.monodromy_dense(rpm, depth)))))
    return two_level_exponent(problem, method, radius, surface_tilt=True).value_per_s


def sdm_part(base, tool, structure, eroded, delay_time=False):
    sdm = SemiDiscretization(m=40, axial_slices=32)
    print("factor, fz mm, dy um: eroded +- SE; SDM at ae - dy: plain, +entry shift, +tilt, +both; eroded minus "
          "+both; the tilt's effect, with the delayed instant's estimate", flush=True)
    print(f"tool: helix {math.degrees(tool.helix_rad):g} deg", flush=True)
    for (factor, fz_mm), (dy_um, rate, se) in eroded.items():
        cut = replace(base.cut, feed_per_tooth_m=fz_mm * 1e-3, ap_m=factor * ALU_LIMIT_M,
                      ae_m=base.cut.ae_m - dy_um * 1e-6)
        p = LobeProblem(structure, tool, cut, base.law)
        plain = floquet_exponent(p, sdm).value_per_s
        entry = entry_shift_exponent(p, sdm).value_per_s
        tilt = floquet_exponent(p, sdm, surface_tilt=True).value_per_s
        both = entry_shift_exponent(p, sdm, surface_tilt=True).value_per_s
        delay = _delay_estimate(p, sdm)
        print(f"{factor:g}x {fz_mm:g} mm dy {dy_um:.2f}: eroded {rate:+.4f} +- {se:.4f}; SDM {plain:+.4f}, "
              f"{entry:+.4f}, {tilt:+.4f}, {both:+.4f}; eroded - both {rate - both:+.4f}; tilt {tilt - plain:+.4f} "
              f"({(tilt - plain) / fz_mm:.2f} 1/s per mm), with the delayed instant {delay - plain:+.4f}", flush=True)
        if delay_time:
            dt = entry_shift_exponent(p, sdm, surface_tilt=True, delay_time=True).value_per_s
            print(f"    both + delayed instant (SDM term) {dt:+.4f} (moves both by {dt - both:+.4f}); eroded minus that "
                  f"{rate - dt:+.4f}; the estimate's move of the tilt-only SDM {delay - tilt:+.4f}", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--skip-jacobian", action="store_true")
    ap.add_argument("--skip-sdm", action="store_true")
    ap.add_argument("--delay-time", action="store_true", help="also the SDM with the delayed instant")
    ap.add_argument("--feeds", default=None, help="comma-separated feeds (mm) to keep; default all")
    a = ap.parse_args(argv)
    warnings.filterwarnings("ignore", category=L.JointLimitWarning)
    base = cases.load_case("tx200-aluminium")
    tool = replace(base.tool, helix_rad=0.0)
    c0 = time.process_time()
    if not a.skip_jacobian:
        jacobian_part(base, tool)
    if not a.skip_sdm:
        robot = L.build_model(base.robot, "basic")
        structure = PhysicalStructure.from_linear(L.linearize(robot, base.path.start_q_rad), base.cut.feed_direction)
        keep = None if a.feeds is None else {float(v) for v in a.feeds.split(",")}

        def rows(d):
            return {k: v for k, v in d.items() if keep is None or k[1] in keep}
        sdm_part(base, tool, structure, rows(ERODED), a.delay_time)
        sdm_part(base, base.tool, structure, rows(ERODED_HELIX), a.delay_time)
    print(f"CPU {time.process_time() - c0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
