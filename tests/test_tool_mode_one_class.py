"""One tool-mode class (issue 17): the one-axis :class:`TcpOscillator` (``TcpOscillator.one_axis``,
``type = "tcp_mode"``) against independent references.

Tolerances asserted:

* series receptance on a very stiff base (joint stiffness x 1e6: robot modes above 15 kHz): the TCP
  receptance along the axis gains ``1 / (k - w^2 m + i w c)`` within a bound computed from the base's
  receptance (the mode's mass on the base detunes it by ``w0^2 m |H_base|``, amplified ``1 / (2 zeta)``
  at the peak), about 1.6e-4 of the peak here; across the axis it gains nothing, within the same bound;
* M, C, K against the bordered matrices of the robot without the mode (a small numpy model of a point
  mass on a prismatic joint at the TCP, taken from the payload): 1e-12 of max |M|, |C|, |K| (round-off;
  the basic variant has no gravity load to linearize);
* M, C, K against the numbers the former ``TcpMode`` class gave (tests/data/tcp_mode_before_unification.json):
  1e-12 of the largest entry (a different BLAS or pinocchio build may round differently; on the machine
  that wrote the file they are bitwise equal);
* a chain with an axis along the tool: its own M, C, K (chain_matrices) against the robot's clamped
  tool coordinates: 1e-9 relative (round-off only);
* the ``tcp_mode`` and ``tcp_oscillator`` tables, identify's two tool effects and ``--tool-modes``
  all give the same class, and equal tables give equal elements (exact);
* a cut-frame direction turned into the TCP frame: 1e-12 (round-off).
"""

import dataclasses
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from robolobes.cases import load_case
from robolobes.cases.spec import ElementSpec
from robolobes.core.errors import BadInput
from robolobes.linearize import build_model, linearize
from robolobes.linearize.extra_elements import element_from_spec, element_table
from robolobes.linearize.tool import TcpOscillator, chain_matrices, chain_receptance

CASE = load_case("tx200-aluminium")
Q = CASE.path.start_q_rad
DATA = Path(__file__).parent / "data" / "tcp_mode_before_unification.json"
OBLIQUE = (0.48, 0.6, 0.64)


def _sdof(f_hz, zeta, k, w):
    """1 / (k - w^2 m + i w c), m = k / (2 pi f)^2, c = 2 zeta sqrt(k m) (m/N)."""
    m = k / (2 * math.pi * f_hz) ** 2
    return 1.0 / (k - w ** 2 * m + 1j * w * 2 * zeta * math.sqrt(k * m))


def _stiff_robot(scale=1e6):
    joints = tuple(dataclasses.replace(j, stiffness_n_m_per_rad=j.stiffness_n_m_per_rad * scale) for j in CASE.robot.joints)
    return dataclasses.replace(CASE.robot, joints=joints)


@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), OBLIQUE, (0.0, 0.0, 1.0)], ids=["x", "oblique", "z"])
def test_one_axis_adds_the_series_receptance_on_a_stiff_base(direction):
    f0, zeta, k = 900.0, 0.03, 2.0e6          # m = 63 g against ~28 kg of robot at the TCP
    spec = _stiff_robot()
    base = linearize(build_model(spec, "basic"), Q)
    osc = TcpOscillator.one_axis(f0, zeta, k, direction)
    lin = linearize(build_model(spec, "basic", extra_elements=(osc,)), Q)
    w = 2 * math.pi * np.linspace(600.0, 1200.0, 301)
    dH = lin.frf(w).H - base.frf(w).H                          # (3, 3, F), base axes
    d = lin.R_tcp @ (np.asarray(direction) / np.linalg.norm(direction))   # the axis in base axes
    e = np.cross(d, [0.3, -0.5, 0.8])
    e /= np.linalg.norm(e)                                      # across the axis
    h = _sdof(f0, zeta, k, w)
    m = k / (2 * math.pi * f0) ** 2
    peak = abs(_sdof(f0, zeta, k, 2 * math.pi * f0))
    tol = 3 * (2 * math.pi * f0) ** 2 * m * np.abs(base.frf(w).H).max() / (2 * zeta) * peak
    assert tol < 1e-3 * peak                                    # the bound is tight enough to mean something
    assert_allclose(np.einsum("i,ijf,j->f", d, dH, d), h, rtol=0, atol=tol)
    assert_allclose(np.einsum("i,ijf,j->f", e, dH, e), 0.0, rtol=0, atol=tol)


def _bordered(base, f_hz, zeta, k, d_tcp):
    """The robot's M, C, K, J grown by the mode's coordinate u: the mass m moves with J dq + d u and
    is taken from the payload at the TCP (moving J dq), so M' = [[M, m J^T d], [m d^T J, m]],
    C' = diag(C, c), K' = diag(K, k), J' = [J, d] (d in base axes)."""
    m = k / (2 * math.pi * f_hz) ** 2
    c = 2 * zeta * math.sqrt(k * m)
    d = base.R_tcp @ (np.asarray(d_tcp, float) / np.linalg.norm(d_tcp))
    n = base.M.shape[0]
    M, C, K = (np.zeros((n + 1, n + 1)) for _ in range(3))
    M[:n, :n], C[:n, :n], K[:n, :n] = base.M, base.C, base.K
    M[:n, n] = M[n, :n] = m * (base.J.T @ d)
    M[n, n], C[n, n], K[n, n] = m, c, k
    return M, C, K, np.hstack([base.J, d[:, None]])


def _close(a, b, what):
    # round-off only: 1e-12 of the largest entry
    assert_allclose(np.asarray(a), np.asarray(b), rtol=0, atol=1e-12 * np.abs(np.asarray(b)).max(), err_msg=what)


@pytest.mark.parametrize("direction", [(1.0, 1.0, 0.0), OBLIQUE, (0.0, 0.0, 1.0)])
def test_one_axis_matrices_equal_a_small_numpy_model(tx200_robot, direction):
    f0, zeta, k = 900.0, 0.03, 2.0e7
    base = linearize(tx200_robot("basic"), Q)
    lin = linearize(build_model(CASE.robot, "basic", extra_elements=(TcpOscillator.one_axis(f0, zeta, k, direction),)), Q)
    for got, want, what in zip((lin.M, lin.C, lin.K, lin.J), _bordered(base, f0, zeta, k, direction), "MCKJ"):
        _close(got, want, what)


def test_one_axis_matrices_equal_those_of_the_former_tcp_mode_class():
    with open(DATA) as fh:
        cases = json.load(fh)["cases"]
    assert {c["variant"] for c in cases} == {"basic", "gravity"}
    for c in cases:
        osc = TcpOscillator.one_axis(c["freq_hz"], c["damping_ratio"], c["stiffness_n_per_m"], tuple(c["direction"]))
        lin = linearize(build_model(CASE.robot, c["variant"], extra_elements=(osc,)), Q)
        for got, what in zip((lin.M, lin.C, lin.K, lin.J), "MCKJ"):
            _close(got, c[what], f"{c['variant']} {what}")


def test_deprecated_tcp_mode_returns_the_one_class():
    from robolobes.linearize.extra_elements import TcpMode

    with pytest.warns(DeprecationWarning, match="one_axis"):
        old = TcpMode(900.0, 0.03, 2e7, (1.0, 1.0, 0.0))
    assert type(old) is TcpOscillator and old == TcpOscillator.one_axis(900.0, 0.03, 2e7, (1.0, 1.0, 0.0))
    m = 2e7 / (2 * math.pi * 900.0) ** 2
    assert old.mass_kg == m and old.k1_n_per_m == 2e7 and old.k2_n_per_m == math.inf and old.zeta1 == 0.03
    assert old.direction is not None
    assert_allclose(np.asarray(old.direction), np.array([1.0, 1.0, 0.0]) / math.sqrt(2), rtol=0, atol=1e-16)
    assert_allclose(old.damping, [2 * 0.03 * math.sqrt(2e7 * m)], rtol=1e-15)


TOML = """
[[elements]]
type = "tcp_mode"
freq_hz = 900.0
damping_ratio = 0.03
stiffness_n_per_m = 2.0e7
direction = [0.48, 0.6, 0.64]

[[elements]]
type = "tcp_oscillator"
mass_kg = {mass!r}
k1_n_per_m = 2.0e7
k2_n_per_m = inf
zeta1 = 0.03
zeta2 = 0.0
direction = [0.48, 0.6, 0.64]

[[elements]]
type = "tcp_oscillator"
mass_kg = 0.25
k1_n_per_m = 4.0e5
k2_n_per_m = 4.3e5
angle_rad = 0.3
zeta1 = 0.03
zeta2 = 0.02
"""


def test_tcp_mode_and_tcp_oscillator_tables_build_the_same_class():
    mass = 2.0e7 / (2 * math.pi * 900.0) ** 2
    tabs = tomllib.loads(TOML.format(mass=mass))["elements"]
    els = [element_from_spec(ElementSpec(t.pop("type"), t)) for t in tabs]
    assert all(type(e) is TcpOscillator for e in els)
    els = [e for e in els if isinstance(e, TcpOscillator)]       # (for the type checker)
    assert els[0] == els[1]                        # the same oscillator, bit for bit
    assert els[0].n_axes == 1 and els[2].n_axes == 2 and els[2].direction is None
    a, b = (linearize(build_model(CASE.robot, "basic", extra_elements=(e,)), Q) for e in els[:2])
    assert np.array_equal(a.M, b.M) and np.array_equal(a.K, b.K) and np.array_equal(a.C, b.C)
    for e in els:                                  # written and read back: equal
        t = element_table(e)
        assert t["type"] == "tcp_oscillator" and element_from_spec(ElementSpec(t.pop("type"), t)) == e


def test_identify_effects_and_tool_files_give_the_one_class(tmp_path):
    import robolobes.identify.structural
    import robolobes.identify.tool_effect  # noqa: F401 -- registers tcp_mode_xy (structural: tcp_mode)
    from robolobes.cases import load_case
    from robolobes.identify.effects import REGISTRY, ModelState
    from robolobes.lobes.tooltip import tool_from_files

    state = ModelState(case=load_case("tx200-aluminium"), variant="basic")
    (one,) = REGISTRY["tcp_mode"].element_specs(state, {"freq_hz": 230.0, "damping_ratio": 0.025,
                                                    "stiffness_n_per_m": 6.3e5, "polar_rad": 1.0, "azimuth_rad": 0.4})
    (xy,) = REGISTRY["tcp_mode_xy"].element_specs(state, {"mass_kg": 0.3, "freq1_hz": 230.0, "freq2_hz": 250.0,
                                                      "angle_rad": 0.2, "zeta1": 0.02, "zeta2": 0.03})
    assert one.type == "tcp_mode" and xy.type == "tcp_oscillator"
    for spec in (one, xy):
        assert type(element_from_spec(spec)) is TcpOscillator
    p = tmp_path / "tool.toml"
    p.write_text("[[oscillators]]\nmass_kg = 0.05\nk1_n_per_m = 1.6e6\nk2_n_per_m = inf\nzeta1 = 0.02\n"
                 "direction = [0.0, 0.6, 0.8]\n")
    tool = tool_from_files(tool_modes=str(p))
    assert tool is not None and [type(o) for o in tool.oscillators] == [TcpOscillator]
    assert_allclose(tool.oscillators[0].axes_tcp, [[0.0, 0.6, 0.8]], rtol=0, atol=1e-16)


def test_chain_with_an_axis_along_the_tool_has_the_robots_rigid_base_matrices():
    # x, then a mode tilted 53 deg from x-y towards the tool axis: the chain's mass matrix needs the
    # axes' z components (the x-y projections alone would give the second mass 0.36 of its inertia)
    x = TcpOscillator.one_axis(900.0, 0.02, 2e6, (1.0, 0.0, 0.0))
    t = TcpOscillator.one_axis(1300.0, 0.03, 1e6, (0.6, 0.0, 0.8))
    M, C, K, D = chain_matrices((x, t))
    robot = build_model(CASE.robot, "basic", extra_elements=(x, t))
    lin = linearize(robot, Q)
    tool = np.arange(int(robot.nv) - 2, int(robot.nv))
    for mine, theirs in zip((M, C, K), (lin.M, lin.C, lin.K)):
        ref = np.asarray(theirs)[tool][:, tool]
        assert_allclose(mine, ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())
    assert_allclose(D, (np.asarray(lin.R_tcp).T @ np.asarray(lin.J)[:, tool])[:2], rtol=0, atol=1e-12)
    # the chain's tip receptance along x at the x-mode's frequency: both modes' closed forms,
    # second mass m_t moving along (0.6, 0, 0.8), first body m_x - m_t (orthogonality does not hold:
    # solve the 2x2 by hand)
    w = 2 * math.pi * np.array([700.0, 900.0, 1300.0])
    mx, mt = x.mass_kg, t.mass_kg
    Mh = np.array([[mx, 0.6 * mt], [0.6 * mt, mt]])     # (mx - mt) e1 e1^T + mt [[1, .6], [.6, 1]]
    Kh, Ch = np.diag([x.k1_n_per_m, t.k1_n_per_m]), np.diag([x.damping[0], t.damping[0]])
    Dh = np.array([[1.0, 0.6], [0.0, 0.0]])
    ref = np.stack([Dh @ np.linalg.solve(Kh - v * v * Mh + 1j * v * Ch, Dh.T) for v in w], axis=-1)
    assert_allclose(chain_receptance((x, t), w), ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize("kwargs, match", [
    ({"k2_n_per_m": 4e5, "direction": (0.0, 0.0, 1.0)}, "k2_n_per_m must be inf"),
    ({"k2_n_per_m": math.inf, "angle_rad": 0.3, "direction": (0.0, 0.0, 1.0)}, "either direction or angle_rad"),
    ({"k2_n_per_m": math.inf, "direction": (0.0, 0.0, 0.0)}, "direction must be a non-zero 3-vector"),
])
def test_bad_one_axis_oscillators_are_refused_naming_the_value(kwargs, match):
    with pytest.raises(BadInput, match=match):
        TcpOscillator(0.1, 1e6, **kwargs)


def test_bad_tcp_mode_values_name_the_key():
    for (f, zeta, k, d), key in (((-1.0, 0.03, 1e6, (1, 0, 0)), "freq_hz"), ((900.0, -0.1, 1e6, (1, 0, 0)), "damping_ratio"),
                                 ((900.0, 0.03, 0.0, (1, 0, 0)), "stiffness_n_per_m"),
                                 ((900.0, 0.03, 1e6, (0, 0, 0)), "direction")):
        with pytest.raises(BadInput, match=f"tcp_mode {key}"):
            TcpOscillator.one_axis(f, zeta, k, d)


def test_model_writer_writes_a_one_axis_oscillator_table():
    # k2_n_per_m = inf is TOML's inf: the written table reads back to an equal oscillator
    from robolobes.identify.model_toml import dumps

    osc = TcpOscillator.one_axis(900.0, 0.03, 2e7, OBLIQUE)
    text = dumps({"elements": [element_table(osc)]})
    assert "k2_n_per_m = inf" in text
    t = tomllib.loads(text)["elements"][0]
    assert element_from_spec(ElementSpec(t.pop("type"), t)) == osc
    with pytest.raises(ValueError, match="nan"):
        dumps({"x": math.nan})


def test_cut_frame_direction_turns_into_the_tcp_frame(tx200_robot):
    # a set read in the cut frame (x_c the feed, z_c = -TCP z: cases.milling.cut_frame) turned to the
    # TCP frame at a pose: z_c is -z, x_c the feed seen from the TCP, and an in-plane direction turns
    # like the planar oscillator's angle (exact up to round-off: 1e-12)
    from robolobes.lobes.tooltip import ToolSet

    lin = linearize(tx200_robot("basic"), Q)
    R = np.asarray(lin.R_tcp)
    feed = np.cross(R[:, 2], [0.2, 0.9, 0.1])
    feed /= np.linalg.norm(feed)                                   # normal to the tool axis
    a = 0.7
    osc = (TcpOscillator.one_axis(900.0, 0.03, 2e6, (0.0, 0.0, 1.0)),
           TcpOscillator.one_axis(900.0, 0.03, 2e6, (1.0, 0.0, 0.0)),
           TcpOscillator.one_axis(900.0, 0.03, 2e6, (math.cos(a), math.sin(a), 0.0)),
           TcpOscillator(0.0025, 2e6, math.inf, a, 0.03))
    z, x, p, q = ToolSet(osc, "cut").in_tcp_frame(R, feed)
    assert_allclose(z.axes_tcp, [[0.0, 0.0, -1.0]], rtol=0, atol=1e-12)
    assert_allclose(x.axes_tcp, [R.T @ feed], rtol=0, atol=1e-12)
    assert_allclose(p.axes_tcp, q.axes_tcp, rtol=0, atol=1e-12)
