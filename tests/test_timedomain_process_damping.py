"""Process damping in the time domain at a low speed: the steel cut at 300 rpm, 0.150 mm deep, with
the flank damper of Ksp L^2 = 8.1e6 N/m (the identification's synthetic steel case: no runout,
0.1355 mm per tooth). The SDM decays there at about -2.47 1/s; a rate fitted to the eroded part's
steady window is flat (about 0), because that window holds no regenerative transient, only the
non-synchronous motion forced by the part's column grid (docs/guide/timedomain-convergence.md,
"Process damping at 300 rpm")."""

import math
from dataclasses import replace

import numpy as np
import pytest

from robolobes.cases import load_case
from robolobes.identify.cutting_effects import ProcessDamping
from robolobes.linearize import build_model, linearize
from robolobes.linearize.extra_elements import TipDamper
from robolobes.linearize.path import Pass
from robolobes.lobes import LobeProblem, PhysicalStructure
from robolobes.lobes.exponent import floquet_exponent
from robolobes.lobes.sdm import SemiDiscretization
from robolobes.timedomain import DelayNewmark, LinearizedNewmark, SimulationProblem, simulate
from robolobes.timedomain.summary import principal_period

pytestmark = [pytest.mark.filterwarnings("ignore:joint A3"), pytest.mark.slow]

KSP_L2_N_PER_M = 8.1e6


@pytest.fixture(scope="module")
def point(tmp_path_factory):
    """(case at 300 rpm and 0.150 mm, robot with the damper, its SDM exponent 1/s and error)."""
    from robolobes.cases.loader import _data_dir

    text = (_data_dir() / "tx200-steel.toml").read_text()
    text = text.replace("runout_um = [6.929, 0]", "runout_um = [0, 0]").replace("feed_mm_per_min = 280",
                                                                                 "feed_mm_per_min = 840")
    text = text.replace('name = "tx200-steel"', 'name = "steel-synthetic"')
    path = tmp_path_factory.mktemp("case") / "steel-synthetic.toml"
    path.write_text(text)
    base = load_case(path)
    case = replace(base, cut=replace(base.cut, spindle_rpm=300.0, ap_m=0.15e-3))
    t = ProcessDamping().element_table(KSP_L2_N_PER_M, case.tool, case.cut, case.cut.feed_direction)
    t.pop("type")
    robot = build_model(case.robot, "basic", extra_elements=(TipDamper(**t),))
    st = PhysicalStructure.from_linear(linearize(robot, Pass.from_case(case).theta_at_s(0.0)),
                                       case.cut.feed_direction)
    fe = floquet_exponent(LobeProblem(st, case.tool, case.cut, case.law), SemiDiscretization(m=40))
    return case, robot, fe.value_per_s, fe.error_per_s


def test_delay_based_rate_at_300_rpm_equals_the_floquet_exponent(point):
    # the kicked delay-based run (the lobes' linear problem) decays at the SDM's exponent, within two
    # standard errors of its gated fit (several modes decay in the window, hence ~0.3 1/s) and the
    # SDM's own error; and clearly decays (the eroded part's flat 0 is more than 8 SE away)
    case, robot, sigma, err = point
    assert -2.6 < sigma < -2.3  # 300 rpm with the damper: -2.468 (m = 40 / 80)
    r = simulate(SimulationProblem(robot, case, t_end_s=6.0), DelayNewmark(kick_m=3e-4, deg_per_step=1.0))
    rate, se = r.rate.rate_per_s, r.rate.se_per_s
    assert r.rate.n_gated >= 20
    assert abs(rate - sigma) <= 2 * se + err, (rate, se, sigma)
    assert rate < -1.5


def test_eroded_flat_rate_at_300_rpm_is_the_column_grid_forcing(point):
    # whole pass, 1 deg per step. After full engagement (8.2 s) the regenerative transient has decayed
    # (e^-20 at -2.47 1/s); the non-synchronous motion left, second differences of the sections at
    # the tooth period, is flat over the ~59 s steady window (no rate but 0) and below the verdict's
    # 2 nm resolution. Its source is the part's column grid: 0.1355 mm per tooth is 135.48 columns of
    # 1 um, so the sampled surface shifts by about half a column from tooth to tooth; with a column
    # spacing of fz / 135 (a whole number of columns per tooth) the floor is several times lower.
    case, robot, _, _ = point
    tp = principal_period(case.tool, case.cut)[0]

    def floor(dx_m):
        r = simulate(SimulationProblem(robot, case), LinearizedNewmark(deg_per_step=1.0, dx_m=dx_m))
        t0, t1 = r.steady_window_s
        t, y = np.asarray(r.t_s), np.asarray(r.tcp_deviation_m)[:, :2]
        ks = np.arange(math.ceil(t0 / tp), int(min(t1, t[-1]) / tp))
        sec = y[np.searchsorted(t, ks * tp - 1e-12)]
        d = np.linalg.norm(np.diff(sec, axis=0), axis=1)
        q = len(d) // 10
        assert t1 - t0 > 40.0
        assert r.summary is not None and r.summary.verdict.status == "stable"
        return float(np.median(d[:q])), float(np.median(d[-q:]))

    first, last = floor(1e-6)
    assert 0.9 < last / first < 1.1, (first, last)  # flat: |rate| < 0.002 1/s over the window
    assert 1e-9 < first < 2e-9
    first_c, last_c = floor(case.cut.feed_per_tooth_m / 135)
    assert max(first_c, last_c) < first / 4, (first_c, last_c, first)
