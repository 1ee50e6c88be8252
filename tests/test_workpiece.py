"""Eraser-of-matter workpiece: chip thickness against the exact trochoidal geometry, removal,
wall profile, trial/commit separation, bad input."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from robolobes.cases.milling import Cut, MillingMode, Tool
from robolobes.timedomain.workpiece_force import MillingForce, run_prescribed, straight_path
from robolobes.timedomain.workpiece import (AxialDiscs, Workpiece, WorkpieceError, _chip_kernel, _chip_kernel_columnwise,
                                            default_disc_count)
from robolobes.cases.milling import CuttingLaw

LAW = CuttingLaw(ktc_pa=661.553e6, krc_pa=253.458e6)
R = 5e-3


def make_tool(pitch_deg=(180, 180), runout_um=None, helix_deg=0.0):
    runout_um = (0.0,) * len(pitch_deg) if runout_um is None else runout_um
    return Tool(diameter_m=2 * R, teeth=len(pitch_deg), helix_rad=math.radians(helix_deg),
                pitch_rad=tuple(math.radians(p) for p in pitch_deg), runout_m=tuple(r * 1e-6 for r in runout_um))


def make_cut(mode: MillingMode = "down", ae=4e-3, fz=99e-6, rpm=18700.0, ap=1.6e-3):
    return Cut(ae_m=ae, ap_m=ap, spindle_rpm=rpm, feed_per_tooth_m=fz, mode=mode)


def steady_part(tool, cut, *, n_rev=3, steps_per_rev=360, discs=None, x_start=12e-3, length=30e-3):
    """Rigid tool started inside a part (the first revolution clears the tool's disc), then cut at
    constant feed for n_rev revolutions; returns the eroded workpiece, its force model and the
    time reached (nothing committed beyond it)."""
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=length, discs=discs)
    model = MillingForce(tool, LAW, cut, wp)
    n = n_rev * steps_per_rev
    t = np.arange(n + 1) * (cut.spindle_period_s / steps_per_rev)
    c, ang = straight_path(tool, cut, t, x_start)
    run_prescribed(model, t, c, ang)
    return wp, model, t[-1], x_start


def exact_chip(tool, cut, t, j, z, x_start, y_edge, dx=1e-6):
    """Exact chip of tooth j at height z at time t, and the column-grid error allowed for it.

    The ray from the tool centre meets the block face and the tip paths (trochoids) of the
    previous passes of every tooth; the chip is the material between the tip and the innermost of
    these boundaries. Returns ``(h, tol)``: ``tol`` is 2 nm (removal chords of sagitta <= 1 nm plus
    the boundary's linear interpolation, dx^2 / 8R = 2.5e-11 m), raised near a corner of the
    boundary (two boundaries crossing the ray within 2 columns of each other): linear
    interpolation across the column holding a kink of slope jump ``dsl`` misplaces the boundary by
    up to ``dx dsl / 4`` in y, i.e. by that over ``|d(y_ray - y_b)/d rho|`` along the ray.
    """
    om = cut.omega_rad_s
    v = cut.feed_rate_m_per_s(tool)
    th = np.asarray(tool.tooth_angle_rad)
    rad = tool.radius_m + np.asarray(tool.runout_m)
    psi = float(tool.lag_rad(z))
    phi = om * t + th[j] - psi
    s, c = math.sin(phi), math.cos(phi)
    cx = x_start + v * t
    down = cut.mode == "down"
    tip_y = rad[j] * c
    if (down and tip_y > y_edge) or (not down and tip_y < y_edge):
        return 0.0, 2e-9
    cand = [(rad[j] - y_edge / c, 0.0)]  # (chip, slope dy/dx of the boundary) for the face
    n = tool.teeth
    for k in range(1, n + 1):
        i = (j - k) % n
        lag = ((th[i] - th[j]) % (2 * math.pi)) or 2 * math.pi  # tooth i passed here lag / Omega ago
        t0 = t - lag / om

        def path(tp):
            a = om * tp + th[i] - psi
            return x_start + v * tp + rad[i] * math.sin(a), rad[i] * math.cos(a)

        def cross(tp):
            px, py = path(tp)
            return (px - cx) * c - py * s

        dt = 0.3 / om
        tp = brentq(cross, t0 - dt, t0 + dt, xtol=1e-16, rtol=np.float64(1e-15))  # scipy's stub types rtol as float64
        px, py = path(tp)
        a = om * tp + th[i] - psi
        slope = -rad[i] * om * math.sin(a) / (v + rad[i] * om * math.cos(a))
        cand.append((rad[j] - ((px - cx) * s + py * c), slope))
    cand.sort()
    h = max(0.0, cand[0][0])
    tol = 2e-9
    if h > 0 and abs(cand[1][0] - cand[0][0]) * abs(s) <= 2 * dx:
        dsl = abs(cand[1][1] - cand[0][1])
        den = min(abs(c - sl * s) for _, sl in cand[:2])
        tol += dx * dsl / 4 / den
    return h, tol


CASES = {
    "down equal pitch": (make_tool(), make_cut("down")),
    "up equal pitch": (make_tool(), make_cut("up")),
    "down pitch 170/190": (make_tool(pitch_deg=(170, 190)), make_cut("down")),
    "down runout 6.9 um": (make_tool(runout_um=(6.929, 0)), make_cut("down", fz=45e-6, rpm=3100)),
    "up 3 teeth helix 30": (make_tool(pitch_deg=(110, 120, 130), helix_deg=30), make_cut("up", ae=2.5e-3, fz=60e-6)),
}


@pytest.mark.parametrize("name", list(CASES))
def test_chip_matches_exact_trochoid(name):
    tool, cut = CASES[name]
    discs = AxialDiscs(cut.ap_m, 3 if tool.helix_rad else 1)
    wp, model, t_now, x_start = steady_part(tool, cut, discs=discs)
    t0 = t_now
    y_edge = wp.edge_y_m
    # Query ahead of the committed state without committing: the chip of a tooth depends only on the
    # material left by the previous passes of the teeth, all committed as long as the query is less
    # than the smallest pitch ahead (the tooth's own sweep since then lies behind its ray). So query
    # in windows of 0.9 x the smallest pitch, committing between windows, over one revolution.
    window = 0.9 * min(tool.pitch_rad) / cut.omega_rad_s
    got, ref = [], []
    while t_now < t0 + cut.spindle_period_s:
        for dt in np.linspace(0, window, 241)[1:]:
            t = t_now + dt
            center, ang = straight_path(tool, cut, [t], x_start)
            h, _ = wp.chip(center[0], model.immersion_rad(ang[0]), model.tooth_radius_m)
            for j in range(tool.teeth):
                for k, z in enumerate(discs.z_m):
                    got.append(h[j, k])
                    ref.append(exact_chip(tool, cut, t, j, z, x_start, y_edge))
        ts = np.linspace(t_now, t_now + window, 65)
        c, ang = straight_path(tool, cut, ts, x_start)
        for i in range(ts.size - 1):
            model.commit(ang[i], c[i], ang[i + 1], c[i + 1])
        t_now = ts[-1]
    got = np.array(got)
    ref, tol = np.array(ref).T
    assert np.count_nonzero(ref > 0) > 100  # the query does sample the cut
    # elements with a tolerance above 10 nm (rays within two columns of a sharp corner) are rare
    assert np.count_nonzero(tol > 1e-8) < 0.05 * np.count_nonzero(ref > 0)
    # tolerance per element from exact_chip: 2 nm, more within two columns of a boundary corner
    bad = np.abs(got - ref) > tol
    assert not bad.any(), (np.flatnonzero(bad), got[bad], ref[bad], tol[bad])


def test_chip_on_the_own_fresh_cut_matches_exact_trochoid():
    # In a run the chip of a state is evaluated after the removal of the step that reached it: the tip
    # sits on the path it has just cut, with that cut in the column behind it. Near the down-milling
    # exit the ray crosses less than a column (h |sin(phi)| < dx, the last ~4 deg here) and the chip
    # must still be the exact one: interpolating across the tip's own cut hid up to 80 % of it
    # (0.33 um against 1.55 um at 179.8 deg), and all of the chip past 180 deg (1.1 um at 180.0 deg).
    # Tolerance per element from exact_chip (2 nm, more next to a corner of the boundary).
    tool, cut = CASES["down pitch 170/190"]
    wp, model, t_now, x_start = steady_part(tool, cut)
    y_edge = wp.edge_y_m
    steps = 720                                  # 0.5 deg steps over one revolution, all committed
    ts = t_now + np.arange(steps + 1) * (cut.spindle_period_s / steps)
    c, ang = straight_path(tool, cut, ts, x_start)
    got, ref, tol, late = [], [], [], []
    for i in range(1, steps + 1):
        model.commit(ang[i - 1], c[i - 1], ang[i], c[i])
        phi = model.immersion_rad(ang[i])
        h, _ = wp.chip(c[i], phi, model.tooth_radius_m)
        for j in range(tool.teeth):
            hr, tl = exact_chip(tool, cut, ts[i], j, 0.0, x_start, y_edge)
            got.append(h[j, 0])
            ref.append(hr)
            tol.append(tl)
            late.append(hr > 0 and math.sin(phi[j, 0]) * hr < wp.dx_m)
    got, ref, tol, late = map(np.array, (got, ref, tol, late))
    assert np.count_nonzero(late) >= 10          # the exit's last degrees are sampled
    bad = np.abs(got - ref) > tol
    assert not bad.any(), (np.flatnonzero(bad), got[bad], ref[bad], tol[bad])


@pytest.mark.parametrize("name", list(CASES))
def test_chip_walk_skipping_cleared_columns_is_bit_identical_to_the_columnwise_walk(name):
    """The chip kernel skips the column intervals an error bound clears and keeps the exact arithmetic
    where the ray leaves the material; chips and derivatives must equal the column-by-column walk
    (the kernel before the skip) bit for bit (tolerance 0: the skip is not meant to change any
    result). States: the steady part, the tool centre moved at random over and beyond the part
    (faces, padding, the untouched block edge and its ramp) and up to 0.5 mm into the material
    (buried teeth), every tooth angle of a revolution."""
    tool, cut = CASES[name]
    discs = AxialDiscs(cut.ap_m, 3 if tool.helix_rad else 1)
    wp, model, t_now, x_start = steady_part(tool, cut, discs=discs)
    wb, x0, dx, sgn = wp._kernel_state()[:4]
    radius = np.ascontiguousarray(model.tooth_radius_m)
    rng = np.random.default_rng(7)
    shape = (tool.teeth, discs.count)
    long_rays = 0
    for _ in range(3000):
        ang = rng.uniform(0.0, 2 * math.pi)
        phi = np.ascontiguousarray(model.immersion_rad(ang))
        cx = float(rng.uniform(-2 * R, 30e-3 + 2 * R)) if rng.random() < 0.3 else x_start + float(rng.normal(0, 3e-3))
        cy = float(rng.normal(0.0, 30e-6)) if rng.random() < 0.9 else -sgn * float(rng.uniform(0.0, 5e-4))
        got = (np.empty(shape), np.empty(shape + (2,)))
        ref = (np.empty(shape), np.empty(shape + (2,)))
        _chip_kernel(wb, x0, dx, cx, sgn * cy, sgn, phi, radius, *got)
        _chip_kernel_columnwise(wb, x0, dx, cx, sgn * cy, sgn, phi, radius, *ref)
        assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1]), (cx, cy, ang)
        long_rays += np.count_nonzero(got[0] * np.abs(np.sin(phi)) > 10 * dx)
    assert long_rays > 1000  # the rays that cross many columns (where the skip acts) are sampled


def test_chip_derivative_matches_finite_difference():
    tool, cut = CASES["down pitch 170/190"]
    wp, model, t_now, x_start = steady_part(tool, cut)
    checked = 0
    for dt in np.linspace(0, cut.spindle_period_s, 97)[1:]:
        center, ang = straight_path(tool, cut, [t_now + dt], x_start)
        phi = model.immersion_rad(ang[0])
        h, d = wp.chip(center[0], phi, model.tooth_radius_m)
        for axis in (0, 1):
            e = np.zeros(2)
            e[axis] = 1e-10  # far below the column spacing: h is linear in c over +-e except at a kink
            hp, _ = wp.chip(center[0] + e, phi, model.tooth_radius_m)
            hm, _ = wp.chip(center[0] - e, phi, model.tooth_radius_m)
            fd = (hp - hm) / 2e-10
            # h is piecewise linear in c, with kinks where the ray's boundary crossing passes a column
            # node: compare where the crossing is more than 1 nm from any node (+-e stays on one piece)
            xc = center[0][0] + (model.tooth_radius_m[:, None] - h) * np.sin(phi)
            u = (xc - wp.x_columns_m[0]) / wp.dx_m
            smooth = (h > 1e-7) & (np.abs(u - np.round(u)) * wp.dx_m > 1e-9)
            # precision: h ~ 1e-4 m to 1e-16 relative -> 1e-20 m over 2e-10 m: 1e-10 absolute
            assert_allclose(fd[smooth], d[..., axis][smooth], rtol=1e-6, atol=1e-9)
            checked += np.count_nonzero(smooth)
    assert checked > 50


def test_flat_face_derivative_closed_form():
    """On the untouched block edge y = y_e the chip is R - y_e / cos(phi): dh/dc = (0, 1 / cos phi)."""
    tool, cut = make_tool(), make_cut("down")
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=20e-3, discs=1)
    phi = np.array([[math.radians(120.0)], [math.radians(300.0)]])  # tooth 2 is out of the cut
    h, d = wp.chip([10e-3, 0.0], phi, [R, R])
    y_e = -(R - cut.ae_m)
    assert_allclose(h[:, 0], [R - y_e / math.cos(phi[0, 0]), 0.0], rtol=1e-12, atol=1e-18)
    assert_allclose(d[0, 0], [0.0, 1 / math.cos(phi[0, 0])], rtol=1e-9)
    assert_allclose(d[1, 0], [0.0, 0.0], atol=0)


@pytest.mark.parametrize("mode", ["down", "up"])
def test_finished_wall_has_the_trochoidal_feed_marks(mode):
    """After the pass, the wall of a rigid tool is the envelope of the tip paths: arcs of period fz
    whose radius is the trochoid's radius of curvature at the wall, R_b = R (1 -+ v / (R Omega))^2
    (down: the tip moves against the feed at the wall, up: with it), 1.3 % off R here."""
    tool, cut = make_tool(), make_cut(mode)
    length = 3e-3
    chord = 5e-11  # sagitta of the removal chords, far below the 1 nm trochoid-vs-circle difference
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=length, discs=1, chord_tol_m=chord)
    model = MillingForce(tool, LAW, cut, wp)
    spr = 720
    t_end = (length + 2 * R + 0.2e-3) / cut.feed_rate_m_per_s(tool)
    t = np.arange(int(t_end / cut.spindle_period_s * spr)) * cut.spindle_period_s / spr
    c, ang = straight_path(tool, cut, t, -R - 0.1e-3)
    run_prescribed(model, t, c, ang)
    prof = wp.wall_profile()
    side = -1.0 if mode == "down" else 1.0
    fz = cut.feed_per_tooth_m
    eps = cut.feed_rate_m_per_s(tool) / cut.omega_rad_s
    rb = R * (1 + side * eps / R) ** 2
    # 20 whole marks (fz = 99 columns exactly), away from the entry and exit faces
    i0 = int(np.searchsorted(prof.x_m, 0.5e-3))
    n_col = int(round(20 * cut.feed_per_tooth_m / wp.dx_m))
    height = R - side * prof.y_m[0][i0:i0 + n_col]  # wall height above the mark bottoms
    # The mark bottoms are at the tool radius (the tip passes through y = -+R): chord error only.
    assert_allclose(height.min(), 0.0, rtol=0, atol=chord)
    # Mean height of arcs of radius R_b between cusps fz apart: fz^2 / (24 R_b) (1 + O(fz^2 / R^2),
    # 4e-4); the mean over 99 columns per whole period is exact up to O(dx^2) at the cusps.
    # With R instead of R_b the mean would be off by 1.3 %.
    arc_mean = fz**2 / (24 * rb)
    assert_allclose(height.mean(), arc_mean, rtol=5e-4, atol=chord)
    assert abs(height.mean() - fz**2 / (24 * R)) > 5 * (5e-4 * arc_mean + chord)
    # Cusps: rb - sqrt(rb^2 - fz^2/4) (1 + O(fz^2/R^2)); the 1 um columns can miss the cusp by
    # dx / 2 where the wall slope is fz / (2 R_b): 5e-9 m (here the marks' phase is near that worst case).
    cusp = rb - math.sqrt(rb**2 - fz**2 / 4)
    assert_allclose(height.max(), cusp, rtol=0, atol=0.5 * wp.dx_m * fz / (2 * rb) + 4e-4 * cusp + chord)
    # The marks repeat every fz: the wall's spectrum peaks at 1 / fz (within one frequency bin)
    z = height - height.mean()
    f = np.fft.rfftfreq(z.size, wp.dx_m)
    peak = f[np.argmax(np.abs(np.fft.rfft(z))[1:]) + 1]
    assert_allclose(peak, 1 / fz, rtol=0, atol=f[1])


def test_removed_area_is_ae_times_length_minus_marks():
    """Material conservation: a full pass removes ae x L per slice, less the feed-mark area
    (parabolic cusps: mean height cusp / 3)."""
    tool, cut = make_tool(), make_cut("down")
    length = 3e-3
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=length, discs=1)
    model = MillingForce(tool, LAW, cut, wp)
    spr = 360
    t_end = (length + 2 * R + 0.2e-3) / cut.feed_rate_m_per_s(tool)
    t = np.arange(int(t_end / cut.spindle_period_s * spr)) * cut.spindle_period_s / spr
    c, ang = straight_path(tool, cut, t, -R - 0.1e-3)
    run_prescribed(model, t, c, ang)
    cusp = cut.feed_per_tooth_m**2 / (8 * R)
    # 1 % of the mark area (its cusp/3 approximation, the trochoid) plus one column of edge (dx ae)
    assert_allclose(wp.removed_area_m2()[0], length * (cut.ae_m - cusp / 3), rtol=0,
                    atol=0.01 * length * cusp + wp.dx_m * cut.ae_m)


def test_wall_does_not_depend_on_the_commit_step():
    """Removal follows the tip path between accepted states, sub-sampled to the chord tolerance, so
    a coarse step (20 deg of spindle per step) leaves the same wall as a fine one (0.5 deg)."""
    walls = []
    for spr in (18, 720):
        tool, cut = make_tool(), make_cut("down")
        wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=2e-3, discs=1)
        model = MillingForce(tool, LAW, cut, wp)
        n_rev = int((2e-3 + 2 * R + 0.2e-3) / (cut.feed_per_tooth_m * 2)) + 1
        t = np.arange(n_rev * spr + 1) * cut.spindle_period_s / spr
        c, ang = straight_path(tool, cut, t, -R - 0.1e-3)
        for i in range(t.size - 1):
            model.commit(ang[i], c[i], ang[i + 1], c[i + 1])
        walls.append(wp.wall_profile().y_m[0])
    # both are chord approximations of the same paths, each within 1 nm of the path
    assert_allclose(walls[0], walls[1], rtol=0, atol=2e-9)


def test_trial_queries_do_not_modify_the_part():
    tool, cut = CASES["down pitch 170/190"]
    wp, model, t_now, x_start = steady_part(tool, cut, n_rev=2)
    before = wp.boundary_y_m()
    for dt in np.linspace(0, 2 * cut.spindle_period_s, 50):
        center, ang = straight_path(tool, cut, [t_now + dt], x_start)
        model.force(ang[0], center[0] + [0.0, -20e-6])  # even a tool pushed into the wall
        model.evaluate(ang[0], center[0])
    assert np.array_equal(wp.boundary_y_m(), before)
    assert not wp.boundary_y_m().flags.writeable


def test_default_disc_count_from_the_helix_lag():
    tool = make_tool(helix_deg=30)
    # psi(ap) = 2 ap tan(30 deg) / D = 0.185 rad = 10.59 deg over 1.6 mm -> 22 discs of <= 0.5 deg
    assert default_disc_count(tool, 1.6e-3) == 22
    # 45 deg over 2 mm: 2 x 2 mm x 1 / 10 mm = 0.4 rad = 22.92 deg -> 46 discs
    assert default_disc_count(make_tool(helix_deg=45), 2e-3) == 46
    assert default_disc_count(make_tool(), 1.6e-3) == 1
    d = AxialDiscs(1.6e-3, 4)
    assert_allclose(d.z_m, [0.2e-3, 0.6e-3, 1.0e-3, 1.4e-3], rtol=1e-12)


def test_geometry_of_the_block():
    tool = make_tool()
    sides: tuple[tuple[MillingMode, int], ...] = (("down", -1), ("up", 1))
    for mode, sign in sides:
        wp = Workpiece(tool, make_cut(mode), x_entry_m=1e-3, part_length_m=5e-3, discs=2)
        assert_allclose(wp.edge_y_m, sign * (R - 4e-3), rtol=1e-12)
        assert_allclose(wp.nominal_wall_y_m, sign * R, rtol=1e-12)
        prof = wp.wall_profile()
        assert_allclose(prof.x_m[[0, -1]], [1e-3, 6e-3], rtol=0, atol=1e-12)
        assert np.all(prof.y_m == wp.edge_y_m)  # nothing cut yet


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(part_length_m=0.0), "part_length_m must be > 0, got 0.0"),
        (dict(part_length_m=-1.0), "part_length_m must be > 0, got -1.0"),
        (dict(x_entry_m=float("nan")), "x_entry_m must be finite, got nan"),
        (dict(dx_m=0.0), "dx_m must be > 0, got 0.0"),
        (dict(dx_m=1e-3), "too coarse"),
        (dict(discs=0), "disc count must be an integer >= 1, got 0"),
    ],
)
def test_bad_workpiece_input_is_named(kw, match):
    args: dict[str, Any] = dict(x_entry_m=0.0, part_length_m=10e-3)
    args.update(kw)
    with pytest.raises(WorkpieceError, match=match):
        Workpiece(make_tool(), make_cut(), **args)


def test_ae_beyond_the_radius_is_refused():
    with pytest.raises(WorkpieceError, match=r"ae = 6 mm exceeds the tool radius 5 mm"):
        Workpiece(make_tool(), make_cut(ae=6e-3), x_entry_m=0.0, part_length_m=10e-3)


def test_bad_query_is_named():
    wp = Workpiece(make_tool(), make_cut(), x_entry_m=0.0, part_length_m=10e-3, discs=1)
    with pytest.raises(WorkpieceError, match="tool centre must be a finite"):
        wp.chip([float("nan"), 0.0], np.zeros((2, 1)), [R, R])
    with pytest.raises(WorkpieceError, match=r"shape \(teeth, 1 discs\)"):
        wp.chip([0.0, 0.0], np.zeros((2, 3)), [R, R])
    with pytest.raises(WorkpieceError, match="tooth radii"):
        wp.chip([0.0, 0.0], np.zeros((2, 1)), [R, -R])
