"""``robolobes map --model FILE`` with a real ``robolobes identify`` output, and ``--tool-modes
FILE`` with a ``[[modes]]`` file: the map's limit at a pose against ``lobes.solve`` on a robot
built independently (the element made here from the file's numbers, the full untruncated
structure). The map keeps the full model (its default, no modal truncation), so the two differ
only by the refinement's error estimate (<= 1 %) and, for ``--tool-modes``, by the mode's mass
loading the robot (0.34 %, below): rtol 1 %, the issue's bound for a map against ``solve``."""

import io
import json
import math
import tomllib
from contextlib import redirect_stdout

import numpy as np
import pytest
import xarray as xr

from robolobes.cases import load_case
from robolobes.identify.synthetic import synthetic_frf_set
from robolobes.linearize import build_model, fk, linearize
from robolobes.linearize.tool import TcpOscillator
from robolobes.lobes import LobeProblem, PhysicalStructure, RefinedSDM, solve
from robolobes.main import main

CASE = load_case("tx200-aluminium")
SPEEDS = (6000.0, 12000.0, 18000.0)
MAP = ["map", "--over", "pass", "--n", "1", "--rpm-min", "6000", "--rpm-max", "18000", "--n-rpm", "3",
       "--scheduler", "serial", "--quiet", "--json"]


def _main_json(args) -> dict:
    buf = io.StringIO()
    with redirect_stdout(buf):
        assert main(args) == 0
    return json.loads(buf.getvalue())


def _map_limits(args, out) -> np.ndarray:
    _main_json(MAP + args + ["--out", str(out)])
    ds = xr.open_zarr(out / "map.zarr", consolidated=False)
    return np.asarray(ds["depth_limit_m"].values)[0]        # (3,) m, the one pose (Tab. 7)


def _solve_with(element) -> np.ndarray:
    """Limits (3,) m at Tab. 7 of the basic robot plus ``element`` (full structure, the default
    refined lobes: the rule the map uses by default)."""
    robot = build_model(CASE.robot, "basic", extra_elements=(element,))
    lin = linearize(robot, CASE.path.start_q_rad)
    p = LobeProblem(PhysicalStructure.from_linear(lin, CASE.cut.feed_direction), CASE.tool, CASE.cut, CASE.law)
    return solve(p, RefinedSDM(), list(SPEEDS), depth_max_m=0.01, rtol=1e-3).depth_limit_m


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """identify's ``model`` TOML of a synthetic FRF set with a tool-holder mode at the TCP (200 Hz,
    zeta 0.03, modal mass 0.2 kg along TCP x), 2 poses, 1 % noise, seed 5."""
    d = tmp_path_factory.mktemp("ident")
    mode = TcpOscillator.one_axis(200.0, 0.03, 0.2 * (2 * math.pi * 200.0) ** 2, (1.0, 0.0, 0.0))
    synthetic_frf_set(d / "set", CASE, elements=(mode,), n_poses=2, f_hz=np.linspace(2, 300, 300), rel_noise=0.01,
                      add_noise=0.01, seed=5)
    res = _main_json(["identify", "--measured", str(d / "set"), "--json", "--quiet", "--no-poles"])
    assert [e["name"] for e in res["effects"]] == ["tcp_mode"]
    path = d / "model.toml"
    path.write_text(res["model"])
    return path


def test_map_with_an_identified_model_equals_solve_on_its_elements(identified, tmp_path):
    got = _map_limits(["--model", str(identified)], tmp_path / "with")
    # the robot built here from the TOML's [[elements]] numbers, not through the case loader
    el = tomllib.loads(identified.read_text())["elements"]
    assert len(el) == 1 and el[0]["type"] == "tcp_mode"
    mode = TcpOscillator.one_axis(el[0]["freq_hz"], el[0]["damping_ratio"], el[0]["stiffness_n_per_m"], tuple(el[0]["direction"]))
    want = _solve_with(mode)
    assert np.all(np.isfinite(want)) and np.all(want < 0.01)
    np.testing.assert_allclose(got, want, rtol=0.01)
    # and the model matters: without it the limits differ by more than 10 % at every speed
    without = _map_limits(["--case", "tx200-aluminium"], tmp_path / "without")
    assert np.all(np.abs(np.minimum(without, 0.01) / got - 1) > 0.1), (without, got)


def test_map_with_tool_modes_file_equals_solve_with_the_mode_in_the_robot(tmp_path):
    # A tool-tip mode of the [[modes]] file (cut frame x_c = the feed, base +x here), 600 Hz,
    # zeta 0.03, modal mass 1 g. Second method: the same mode as a mass on a spring at the TCP inside
    # the multibody robot (TcpOscillator.one_axis, TCP frame). The two differ by the mode's mass loading the robot,
    # first order in m: the robot's apparent mass at the TCP along the feed at 600 Hz is only about
    # 2.1 kg (-1 / (w^2 Re H), H = -3.4e-8 m/N). Observed: 25 % apart at 0.1 kg, 1.7 % at 5 g,
    # 0.34 % at 1 g; so 1 g, where the loading is below the 1 % asserted.
    k = 0.001 * (2 * math.pi * 600.0) ** 2
    f = tmp_path / "modes.toml"
    f.write_text(f"[[modes]]\nfreq_hz = 600.0\ndamping_ratio = 0.03\nstiffness_n_per_m = {k!r}\ndirection = [1.0, 0.0]\n")
    got = _map_limits(["--case", "tx200-aluminium", "--tool-modes", str(f)], tmp_path / "m")
    _, R = fk(CASE.robot, CASE.path.start_q_rad)
    d_tcp = np.asarray(R).T @ np.asarray(CASE.cut.feed_direction)   # the feed in the TCP frame
    want = _solve_with(TcpOscillator.one_axis(600.0, 0.03, k, tuple(d_tcp)))
    assert np.all(np.isfinite(want)) and np.all(want < 0.01)
    np.testing.assert_allclose(got, want, rtol=0.01)
