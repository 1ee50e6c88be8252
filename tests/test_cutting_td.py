"""Cutting forces of the discretized tool on the eroded workpiece: closed forms, entry peak,
transients, runout, variable pitch, the mapping to the paper's Tab. 10, the tangent, signs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from robolobes.cases import load_case
from robolobes.cases.milling import Cut, CuttingLaw, Tool, engagement_rad, regeneration
from robolobes.timedomain.workpiece_force import MillingForce, run_prescribed, straight_path
from robolobes.timedomain.workpiece import AxialDiscs, Workpiece, WorkpieceError

R = 5e-3
LAW = CuttingLaw(ktc_pa=661.553e6, krc_pa=253.458e6)


def tool_(pitch_deg=(180, 180), runout_um=None, helix_deg=0.0):
    runout_um = (0.0,) * len(pitch_deg) if runout_um is None else runout_um
    return Tool(diameter_m=2 * R, teeth=len(pitch_deg), helix_rad=math.radians(helix_deg),
                pitch_rad=tuple(math.radians(p) for p in pitch_deg), runout_m=tuple(r * 1e-6 for r in runout_um))


def steady(tool, cut, law=LAW, discs=None, x_start=12e-3, n_rev=2, spr=360):
    """Rigid tool started inside a long part (its first revolution clears its own disc), then cut at
    constant feed for n_rev revolutions."""
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=30e-3, discs=discs)
    model = MillingForce(tool, law, cut, wp)
    t = np.arange(n_rev * spr + 1) * cut.spindle_period_s / spr
    run_prescribed(model, t, *straight_path(tool, cut, t, x_start))
    return wp, model, float(t[-1]), x_start


def one_revolution(model, tool, cut, t_now, x_start, samples=3600):
    """Forces and per-tooth chips at ``samples`` instants spread uniformly over the next revolution.

    Evaluated without committing, in windows shorter than the smallest pitch (so that the material
    every tooth meets was left by committed passes), committing between windows."""
    period = cut.spindle_period_s
    tk = t_now + period * np.arange(1, samples + 1) / samples
    window = 0.9 * min(tool.pitch_rad) / cut.omega_rad_s
    forces, chips = [], []
    start = t_now
    while start < tk[-1] - 1e-15:
        stop = min(start + window, tk[-1])
        for t in tk[(tk > start) & (tk <= stop)]:
            c, a = straight_path(tool, cut, [t], x_start)
            out = model.evaluate(a[0], c[0])
            forces.append(out.tool_n)
            chips.append(out.tooth_chip_m)
        ts = np.linspace(start, stop, 33)
        c, a = straight_path(tool, cut, ts, x_start)
        for i in range(ts.size - 1):
            model.commit(a[i], c[i], a[i + 1], c[i + 1])
        start = stop
    return tk, np.array(forces), np.array(chips)


def altintas_mean(teeth, ap, fz, law, phi_st, phi_ex):
    """Mean force on the tool per revolution for h = fz sin(phi), straight tool, no edge forces
    (Altintas, Manufacturing Automation, eq. 2.x), our sign convention."""
    def fx(p):
        return law.ktc_pa * math.cos(2 * p) - law.krc_pa * (2 * p - math.sin(2 * p))

    def fy(p):
        return law.ktc_pa * (2 * p - math.sin(2 * p)) + law.krc_pa * math.cos(2 * p)

    k = teeth * ap * fz / (8 * math.pi)
    return np.array([k * (fx(phi_ex) - fx(phi_st)), k * (fy(phi_ex) - fy(phi_st))])


@pytest.mark.parametrize("mode", ["down", "up"])
def test_mean_force_matches_closed_form(mode):
    fz = 5e-6  # fz / R = 1e-3: the exact (trochoidal) chip differs from fz sin(phi) by O(fz^2 / R)
    cut = Cut(ae_m=3e-3, ap_m=2e-3, spindle_rpm=10000, feed_per_tooth_m=fz, mode=mode)
    tool = tool_()
    wp, model, t_now, x0 = steady(tool, cut)
    _, f, _ = one_revolution(model, tool, cut, t_now, x0)
    ref = altintas_mean(tool.teeth, cut.ap_m, fz, LAW, *engagement_rad(tool, cut))
    # Relative error budget: the chip's second-order terms |h - fz sin phi| <= 0.7 fz^2 / R (a few
    # 1e-4 of the force), the entry/exit ramps where the chip switches between the block face and
    # the previous path (an angle ~fz / R, same order), and the sampling of the near-jump at the
    # down-milling entry (or up-milling exit) by 3600 samples per revolution: <= F_jump / (3600 F_mean)
    # ~ 1e-3. Hence 2e-3 of the force magnitude.
    assert_allclose(f.mean(0)[:2], ref, rtol=0, atol=2e-3 * np.abs(ref).max())
    assert_allclose(f[:, 2], 0.0, atol=0)  # Kac = 0


def test_helix_does_not_change_the_mean_force():
    """Each disc's force is the straight tool's force shifted by its helix lag: the mean per
    revolution is the same (to the sampling of the entry jump, now spread over the discs)."""
    cut = Cut(ae_m=4e-3, ap_m=1.6e-3, spindle_rpm=18700, feed_per_tooth_m=99e-6, mode="down")
    means = []
    for helix, discs in ((0.0, 1), (30.0, 22)):
        tool = tool_(helix_deg=helix)
        wp, model, t_now, x0 = steady(tool, cut, discs=AxialDiscs(cut.ap_m, discs))
        means.append(one_revolution(model, tool, cut, t_now, x0)[1].mean(0))
    assert_allclose(means[1], means[0], rtol=0, atol=2e-3 * np.abs(means[0]).max())


def second_order_chip(fz, teeth, phi):
    """Chip of a straight tool at constant feed to O(fz^2 / R) (derivation in the engine README):
    h = fz sin(phi) - (eps fz / R) sin(phi) cos(phi) + fz^2 cos(phi)^2 / (2 R), eps = fz N / 2 pi
    (the tool's advance per radian)."""
    eps = fz * teeth / (2 * math.pi)
    return fz * math.sin(phi) - eps * fz / R * math.sin(phi) * math.cos(phi) + fz**2 * math.cos(phi) ** 2 / (2 * R)


def test_entry_peak_of_down_milling(alu_case):
    """Down-milling enters with the thickest chip: the peak Fy on the tool is at entry,
    ap h(phi_st) (Ktc sin phi_st - Krc cos phi_st)."""
    case = alu_case
    cut = case.cut
    tool = tool_()  # the aluminium cut with a straight, equal-pitch tool: one force peak per tooth
    fz = cut.feed_per_tooth_m
    wp, model, t_now, x0 = steady(tool, cut, law=case.law)
    _, f, chips = one_revolution(model, tool, cut, t_now, x0)
    phi_st, _ = engagement_rad(tool, cut)
    law = case.law

    def shape(p):
        return law.ktc_pa * math.sin(p) - law.krc_pa * math.cos(p)

    # Just after phi_st the chip is bounded by the flat block face, h = R - y_e / cos(phi), which
    # rises from 0 to the previous tooth's chip within ~fz / (4.9 R) = 4e-3 rad; the peak is where
    # the two meet, phi*.
    y_e = -(R - cut.ae_m)
    phi_star = brentq(lambda p: (R - y_e / math.cos(p)) - second_order_chip(fz, 2, p), phi_st, phi_st + 0.05)
    h_star = second_order_chip(fz, 2, phi_star)
    # Fy = ap h shape is sampled every 1.7e-3 rad and drops by 0.04 /rad after phi* (1e-4 relative);
    # the second-order chip is exact to O(fz^2 / R^2) = 4e-4.
    assert_allclose(f[:, 1].max(), cut.ap_m * h_star * shape(phi_star), rtol=5e-4)
    # The brief's first-order value ap fz sin(phi_st) shape(phi_st) is within O(fz / R) = 2 %, and
    # the second-order correction is resolved.
    first = cut.ap_m * fz * math.sin(phi_st) * shape(phi_st)
    assert_allclose(f[:, 1].max(), first, rtol=0.02)
    assert abs(f[:, 1].max() / first - 1) > 1e-3
    # The chip there (the chip drops at |cot phi| = 0.2 /rad: sampling 3.5e-4, plus 4e-4)
    assert_allclose(chips.max(0), h_star, rtol=8e-4)


def test_entry_and_exit_of_the_part(alu_case):
    """Zero force before the tool reaches the entry face, zero after it has left the exit face."""
    case = alu_case
    tool, cut = case.tool, case.cut  # helix 30, pitch 170/190, 22 discs
    length = 6e-3  # longer than the engaged width R sin(phi_st) = 4.9 mm: a steady stretch exists
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=length)
    model = MillingForce(tool, case.law, cut, wp)
    spr = 180
    x0 = -R - 0.3e-3
    t_end = (length + 2 * R + 0.6e-3) / cut.feed_rate_m_per_s(tool)
    t = np.arange(int(t_end / cut.spindle_period_s * spr)) * cut.spindle_period_s / spr
    c, a = straight_path(tool, cut, t, x0)
    run = run_prescribed(model, t, c, a)
    f = np.linalg.norm(run.force_tool_n, axis=1)
    xc = c[:, 0]
    assert np.all(f[xc + R < 0.0] == 0.0)  # no tooth reaches the entry face
    assert np.all(f[xc > length + 0.1e-3] == 0.0)  # past the exit face (the exit tail near
    # phi = 180 deg lasts an angle sqrt(2 cusp / R) = 0.01 rad: 50 um of the tool)
    first = xc[np.argmax(f > 0)]
    # A tip is in the material only below the block edge, i.e. for phi >= phi_st (down-milling), so
    # the first contact is when the engagement's leading corner x_c + R sin(phi_st) reaches the face,
    # within one revolution (2 fz of travel, the tooth must come round; the helix spreads the
    # corner over 10.6 deg of lag, which only delays it)
    corner = -R * math.sin(engagement_rad(tool, cut)[0])
    assert corner - 1e-9 <= first <= corner + 2 * cut.feed_per_tooth_m + 1e-9
    # and in between the cut is established: the middle of the part sees the full steady force
    mid = (xc > 0.2e-3) & (xc + R < length)
    assert mid.any() and f[mid].max() > 50
    # The wall is finished over the whole part: y = -R (down-milling) up to the feed marks, whose
    # cusps stand fz_j^2 / (8 R_b) high for the longer mark fz_j = fz 190 / 180, R_b = R (1 - eps/R)^2
    # the trochoid's radius at the wall (see test_workpiece), plus the 1 nm chords.
    wall = wp.wall_profile().y_m
    eps = cut.feed_rate_m_per_s(tool) / cut.omega_rad_s
    rb = R * (1 - eps / R) ** 2
    fz_long = cut.feed_per_tooth_m * tool.teeth * max(tool.pitch_rad) / (2 * math.pi)
    assert_allclose(wall, -R, rtol=0, atol=fz_long**2 / (8 * rb) * (1 + 4e-4) + 1e-9)


@pytest.mark.parametrize("runout_um", [(6.929, 0.0), (60.0, 0.0)])
def test_runout_alternates_the_chips_as_regeneration_says(runout_um, steel_case):
    """Steel cut, straight tool with runout, up-milling at ae = R so that phi = 90 deg is in the cut
    (there the chip is exactly the static chip of cases.milling.regeneration, second-order terms
    vanish). With 60 um runout (> fz) the short tooth does not cut at all."""
    case = steel_case
    tool = tool_(runout_um=runout_um)
    c0 = case.cut
    cut = Cut(ae_m=R * (1 - 1e-6), ap_m=c0.ap_m, spindle_rpm=c0.spindle_rpm, feed_per_tooth_m=c0.feed_per_tooth_m,
              mode="up")
    # At phi = 90 deg the previous path has a vertical tangent: a column height field places such a
    # boundary to within one column (the chord to the next column). Columns of 0.05 um here.
    dx = 5e-8
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=18e-3, discs=1, dx_m=dx)
    model = MillingForce(tool, case.law, cut, wp)
    t = np.arange(3 * 360 + 1) * cut.spindle_period_s / 360
    run_prescribed(model, t, *straight_path(tool, cut, t, 12e-3))
    _, f, chips = one_revolution(model, tool, cut, t[-1], 12e-3)
    expected = np.array([max(0.0, r.chip_m) for r in regeneration(tool, cut)])
    # sampled every 0.1 deg: h near 90 deg is flat to (1.7e-3)^2 / 2 = 1.5e-6 relative; grid: dx
    assert_allclose(chips.max(0), expected, rtol=2e-6, atol=dx)
    assert chips.max(0)[0] > chips.max(0)[1]


def test_variable_pitch_alternates_the_force_peaks(alu_case):
    """Paper Fig. 15: with pitch 170/190 deg the teeth cut fz 190/180 and fz 170/180, and the Fy
    peaks alternate high/low in that ratio."""
    case = alu_case
    tool, cut = case.tool, case.cut
    wp, model, t_now, x0 = steady(tool, cut, law=case.law)
    tk, f, chips = one_revolution(model, tool, cut, t_now, x0, samples=1800)
    fy = f[:, 1]
    # split the revolution into the two teeth's passes (the force is zero between them)
    on = fy > 0
    starts = np.flatnonzero(on & ~np.roll(on, 1))
    assert starts.size == 2
    peaks = [fy[np.roll(np.arange(fy.size), -s)][: fy.size // 2].max() for s in starts]
    hi, lo = max(peaks), min(peaks)
    # Chips in the ratio 190/170; Fy is linear in the chip, both teeth see the same helix smoothing;
    # the second-order chip terms scale with fz^2 and shift the ratio by ~(fz_hi - fz_lo) / R = 2e-3.
    assert_allclose(hi / lo, 190 / 170, rtol=3e-3)
    regen = np.array([r.chip_m for r in regeneration(tool, cut)])
    assert_allclose(chips.max(0) / chips.max(0).max(), regen / regen.max(), rtol=3e-3)


def test_rigid_aluminium_statistics_match_the_papers_model_rows(alu_case):
    """Tab. 10 (0.4-1.4 s, steady cut): the paper's four robot models; a rigid tool is their stiff
    limit. Mapping (module docstring of timedomain.workpiece_force): paper Fx = F_tool . x_c,
    paper Fy = -F_tool . y_c. Our rigid statistics must fall within the spread of the paper's rows
    widened by 2 % (the robot models differ among themselves by 2-9 %)."""
    case = alu_case
    tool, cut = case.tool, case.cut
    wp, model, t_now, x0 = steady(tool, cut, law=case.law)
    _, f, _ = one_revolution(model, tool, cut, t_now, x0, samples=360)  # one sample per degree
    rows = np.array([  # min, max, mean, rms (N) for Fx then Fy: basic, gravity, orthogonal, backlash
        [-7.63, 38.82, 8.78, 16.28, -111.39, 0.0, -25.67, 44.42],
        [-8.53, 38.84, 8.72, 16.31, -113.4, 0.0, -26.1, 44.96],
        [-7.92, 38.98, 8.79, 16.29, -112.45, 0.0, -25.70, 44.47],
        [-8.31, 42.40, 8.92, 16.41, -117.07, 0.0, -25.43, 44.15],
    ])
    paper_fx, paper_fy = f[:, 0], -f[:, 1]
    ours = np.array([g(x) for x in (paper_fx, paper_fy) for g in (np.min, np.max, np.mean, lambda v: np.sqrt(np.mean(v**2)))])
    lo, hi = rows.min(0), rows.max(0)
    widen = 0.02 * np.maximum(np.abs(lo), np.abs(hi))
    assert np.all(ours >= lo - widen - 1e-9) and np.all(ours <= hi + widen + 1e-9), ours
    # the sign pattern itself: the force on the tool along y_c never changes sign in down-milling
    assert np.all(f[:, 1] >= 0.0)


def test_tangent_matches_finite_differences(alu_case):
    case = alu_case
    tool, cut = case.tool, case.cut
    wp, model, t_now, x0 = steady(tool, cut, law=case.law, n_rev=2, spr=180)
    checked = 0
    for dt in np.linspace(0, cut.spindle_period_s, 49)[1:]:
        c, a = straight_path(tool, cut, [t_now + dt], x0)
        out = model.evaluate(a[0], c[0])
        d = out.dtool_dcenter_n_per_m
        if not out.engaged.any():
            assert_allclose(d, 0.0, atol=0)
            continue
        # The force is piecewise linear in the centre, with kinks where an element's boundary
        # crossing passes a column node: skip states with a crossing within 1 nm of a node.
        r = model.tooth_radius_m[:, None] - out.chip_m
        u = (c[0][0] + r * np.sin(out.phi_rad) - wp.x_columns_m[0]) / wp.dx_m
        if np.any(out.engaged & (np.abs(u - np.round(u)) * wp.dx_m < 1e-9)):
            continue
        fd = np.empty((3, 2))
        for axis in (0, 1):
            e = np.zeros(2)
            e[axis] = 1e-10
            fd[:, axis] = (model.force(a[0], c[0] + e)[0] - model.force(a[0], c[0] - e)[0]) / 2e-10
        # round-off: F ~ 1e2 N to 1e-16 relative over 2e-10 m: 1e-4 N/m; d ~ 1e5-1e6 N/m
        assert_allclose(fd, d, rtol=1e-6, atol=1e-3)
        checked += 1
    assert checked >= 10


def test_directional_tangent_is_the_linear_model(alu_case):
    """The 'directional' tangent is dz * sum of cases.milling.directional_matrix over the engaged
    elements: for chips bounded by the previous tooth's arc it approximates the geometric one."""
    case = alu_case
    tool, cut = case.tool, case.cut
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=30e-3)
    geo = MillingForce(tool, case.law, cut, wp, tangent="geometric")
    lin = MillingForce(tool, case.law, cut, wp, tangent="directional")
    t = np.arange(2 * 360 + 1) * cut.spindle_period_s / 360
    run_prescribed(geo, t, *straight_path(tool, cut, t, 12e-3))
    c, a = straight_path(tool, cut, [t[-1] + 0.3 * cut.spindle_period_s], 12e-3)
    out = lin.evaluate(a[0], c[0])
    from robolobes.cases.milling import directional_matrix

    phi = out.phi_rad[out.engaged]
    assert phi.size > 0
    assert_allclose(out.dtool_dcenter_n_per_m, wp.discs.dz_m * directional_matrix(phi, case.law).sum(0), rtol=1e-12)
    g = geo.force(a[0], c[0])[1]
    # per element the geometric dh/dc = m / (m . n) differs from n by the angle between the boundary
    # normal m (previous tooth's path) and the ray n, ~fz |cos phi| / R <= fz / R = 2 %
    assert_allclose(g, out.dtool_dcenter_n_per_m, rtol=0, atol=2 * cut.feed_per_tooth_m / R * np.abs(g).max())


def test_workpiece_force_is_minus_tool_force_and_results_are_read_only(alu_case):
    case = alu_case
    wp, model, t_now, x0 = steady(case.tool, case.cut, law=case.law, n_rev=1, spr=90)
    c, a = straight_path(case.tool, case.cut, t_now + np.linspace(0, 1e-3, 11), x0)
    out = max((model.evaluate(ai, ci) for ai, ci in zip(a, c)), key=lambda o: np.abs(o.tool_n).max())
    assert np.abs(out.tool_n).max() > 1
    assert_allclose(out.workpiece_n, -out.tool_n, rtol=0, atol=0)
    for arr in (out.tool_n, out.workpiece_n, out.dtool_dcenter_n_per_m, out.chip_m, out.phi_rad):
        assert not arr.flags.writeable


def test_bad_force_input_is_named(alu_case):
    case = alu_case
    wp = Workpiece(case.tool, case.cut, x_entry_m=0.0, part_length_m=5e-3)
    model = MillingForce(case.tool, case.law, case.cut, wp)
    with pytest.raises(ValueError, match="tool centre must be a finite"):
        model.force(0.0, [0.0, float("nan")])
    with pytest.raises(ValueError, match="spindle angle must be finite"):
        model.force(float("inf"), [0.0, 0.0])
    other = Cut(ae_m=2e-3, ap_m=1.6e-3, spindle_rpm=18700, feed_per_tooth_m=1e-4)
    with pytest.raises(WorkpieceError, match="another tool or cut"):
        MillingForce(case.tool, case.law, other, wp)


# ---- coupling with the Newmark integrator (the pattern the robot coupling will follow) -------------
def _spring_mounted_tool(ap, k, fn_hz, zeta, n_rev, spr=100):
    """A tool on two orthogonal spring-damper modes (x_c, y_c) cutting the aluminium part with a
    straight 2-tooth cutter: residual M a + C v + K q - F_tool(Omega t, c_nom(t) + q), tangent
    K - dF/dc, the workpiece eroded in the step hook. Returns on-grid samples."""
    from robolobes.timedomain.newmark import NewmarkOptions, integrate

    case = load_case("tx200-aluminium")
    tool = Tool(diameter_m=2 * R, teeth=2)
    c0 = case.cut
    cut = Cut(ae_m=c0.ae_m, ap_m=ap, spindle_rpm=c0.spindle_rpm, feed_per_tooth_m=c0.feed_per_tooth_m, mode="down")
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=40e-3)
    model = MillingForce(tool, case.law, cut, wp)
    m = k / (2 * math.pi * fn_hz) ** 2
    M, K, C = m * np.eye(2), k * np.eye(2), 2 * zeta * math.sqrt(k * m) * np.eye(2)
    om, v = cut.omega_rad_s, cut.feed_rate_m_per_s(tool)

    def centre(t, q):
        return np.array([-R + v * t, 0.0]) + q

    def residual(q, vel, a, t):
        return M @ a + C @ vel + K @ q - model.force(om * t, centre(t, q))[0][:2]

    def tangent(q, vel, a, t):
        return K - model.force(om * t, centre(t, q))[1][:2], C, M

    rec = {"t": [], "q": [], "f": []}

    def on_step(s):
        if s.on_grid:  # record the force of the accepted state *before* committing the step: after
            # it, the tips sit on the surface they have just cut and see no chip
            rec["t"].append(s.t_s)
            rec["q"].append(np.array(s.q))
            rec["f"].append(np.array(model.force(om * s.t_s, centre(s.t_s, s.q))[0]))
        model.commit(om * s.t_prev_s, centre(s.t_prev_s, s.q_prev), om * s.t_s, centre(s.t_s, s.q))

    out = integrate(residual, np.zeros(2), np.zeros(2), t0_s=0.0, h_s=cut.spindle_period_s / spr,
                    n_steps=n_rev * spr, tangent=tangent, on_step=on_step, options=NewmarkOptions(atol=1e-13))
    return cut, out, np.array(rec["t"]), np.array(rec["q"]), np.array(rec["f"])


def test_coupled_stiff_tool_deflects_by_mean_force_over_k():
    """Stable cut (ap = 0.5 mm, a third of the smallest zero-order stability limit
    2 k zeta / (N Ktc) ~ 1.6 mm of this 5 kHz, 5 % mode): periodic steady state, where Newmark's
    discrete relations make the revolution sums of a and v vanish, so mean(q) = mean(F) / k exactly."""
    k = 1e7
    cut, out, t, q, f = _spring_mounted_tool(0.5e-3, k, 5000.0, 0.05, n_rev=45)
    assert out.completed and out.stats.rejected == 0
    # the tool (starting with its front at the entry face) is fully engaged once its centre has
    # passed the face: R / (2 fz) = 25 revolutions; average over the last 10 (whole revolutions)
    last = slice(-10 * 100, None)
    # the transient decays as exp(-zeta w t), e-folding in 0.2 revolution: gone; Newton atol 1e-13 m
    assert_allclose(q[last].mean(0), f[last].mean(0)[:2] / k, rtol=1e-6, atol=1e-13)
    from robolobes.timedomain.verdict import chip_scale, decide

    # the verdict over the 20 revolutions of full engagement (40 tooth periods)
    v = decide(t, q, cut.spindle_period_s / 2, chip_scale(Tool(diameter_m=2 * R, teeth=2), cut),
               t_start_s=t[-1] - 20 * cut.spindle_period_s, t_end_s=t[-1])
    assert v.verdict.status == "stable" and v.regenerative_ratio < 1e-3, v.verdict.reason


def test_coupled_soft_tool_chatters_near_its_natural_frequency():
    """ap = 3 mm is ~25 x the smallest stability limit of an 800 Hz, 2 %, 2e6 N/m mode: chatter, at
    a frequency just above the natural frequency (the cutting stiffness adds to the structure's)."""
    from robolobes.timedomain.signals import chatter_frequency
    from robolobes.timedomain.verdict import chip_scale, decide

    cut, out, t, q, f = _spring_mounted_tool(3e-3, 2e6, 800.0, 0.02, n_rev=45)
    start = t[-1] - 20 * cut.spindle_period_s
    v = decide(t, q, cut.spindle_period_s / 2, chip_scale(Tool(diameter_m=2 * R, teeth=2), cut),
               t_start_s=start, t_end_s=t[-1])
    assert v.verdict.status == "unstable", v.verdict.reason
    est = chatter_frequency(t, q, 1 / cut.spindle_period_s, t_start_s=start)
    assert 800.0 <= est.freq_hz <= 880.0 and est.ratio > 1
