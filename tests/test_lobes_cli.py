"""``robolobes lobes``: modal TOML input, JSON output, PNG written atomically, robot pose input."""

import argparse
import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes.lobes import LobeError
from robolobes.lobes.cli import read_modal_toml, register, run

from lobes_benchmark import MODAL, TOOLARGS


def parser():
    p = argparse.ArgumentParser(prog="robolobes")
    sub = p.add_subparsers(dest="command")
    register(sub)
    return p


def test_modal_json_and_png(tmp_path, capsys):
    f = tmp_path / "modes.toml"
    f.write_text(MODAL)
    png = tmp_path / "lobes.png"
    args = parser().parse_args(["lobes", "--modal", str(f), *TOOLARGS, "--rpm-min", "18000", "--rpm-max", "19000",
                                "--n-rpm", "11", "--at-rpm", "10000", "--at-depth-mm", "1", "--json", "--out",
                                str(png), "--quiet"])
    assert args.run(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert_allclose(out["rpm"], np.linspace(18000, 19000, 11))
    assert len(out["depth_limit_m"]) == 11 and len(out["chatter_freq_hz"]) == 11 and len(out["bifurcation"]) == 11
    # the symmetric 2-DOF benchmark: converged flip minimum 0.8315 mm at 18 702 rpm (test_lobes; one
    # level m = 40 gives 0.8493 mm, 2.1 % above); the default refines to an estimate <= 1 %
    j = int(np.argmin(out["depth_limit_m"]))
    assert out["bifurcation"][j] == "flip" and abs(out["rpm"][j] - 18700) <= 100
    assert_allclose(out["depth_limit_m"][j], 0.8315e-3, rtol=1e-2)
    assert abs(out["depth_limit_m"][j] / 0.8493e-3 - 1) > 0.015
    assert out["tol"] == 0.01 and out["status"] == ["converged"] * 11 and len(out["m_final"]) == 11
    assert all(e <= 0.01 * d for e, d in zip(out["depth_error_m"], out["depth_limit_m"]))
    op = out["operating_point"]
    assert set(op) >= {"rpm", "depth_m", "spectral_radius", "stable", "verdict", "verdict_reason", "margin"}
    assert op["verdict"] == {True: "stable", False: "unstable"}[op["stable"]]
    assert op["rpm"] == 10000 and op["depth_m"] == pytest.approx(1e-3) and isinstance(op["stable"], bool)
    assert op["stable"] == (op["margin"] > 0)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(x.name for x in tmp_path.iterdir()) == ["lobes.png", "modes.toml"]  # no temp file left


def test_default_method_is_the_library_default():
    # `robolobes lobes` with no method flag solves with RefinedSDM(), the library's default (its
    # coarser free-exact prescan included); --m 20 has no coarser prescan (20 is not below 20)
    from robolobes.lobes import RefinedSDM
    from robolobes.lobes.cli import _method

    args = parser().parse_args(["lobes", "--case", "tx200-steel"])
    assert _method(args) == RefinedSDM()
    low = _method(parser().parse_args(["lobes", "--case", "tx200-steel", "--m", "20"]))
    assert isinstance(low, RefinedSDM) and low.base.m == 20 and low.base.prescan_m is None


def test_interrupted_plot_leaves_no_file(tmp_path, monkeypatch):
    f = tmp_path / "modes.toml"
    f.write_text(MODAL)
    png = tmp_path / "lobes.png"
    import matplotlib.figure

    def boom(self, fname, *a, **k):
        with open(fname, "wb") as fh:
            fh.write(b"\x89PNG partial")
        raise KeyboardInterrupt

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", boom)
    args = parser().parse_args(["lobes", "--modal", str(f), *TOOLARGS, "--n-rpm", "3", "--out", str(png), "--quiet"])
    with pytest.raises(KeyboardInterrupt):
        run(args)
    assert list(tmp_path.iterdir()) == [f]


def test_modal_file_errors(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text(MODAL.replace("direction = [1, 0]", "direction = [1, 1]"))
    with pytest.raises(LobeError, match=r"bad.toml: modes\[0\].*unit vector"):
        read_modal_toml(f)
    f.write_text(MODAL.replace("damping_ratio = 0.011\nstiffness_n_per_m = 1.34003e6\ndirection = [0, 1]",
                               "damping_ratio = 0.011\ndirection = [0, 1]"))
    with pytest.raises(LobeError, match=r"modes\[1\] is missing stiffness_n_per_m"):
        read_modal_toml(f)
    f.write_text("x = 1\n")
    with pytest.raises(LobeError, match=r"at least one \[\[modes\]\]"):
        read_modal_toml(f)
    g = tmp_path / "ok.toml"
    g.write_text(MODAL)
    with pytest.raises(LobeError, match="missing --teeth"):
        run(parser().parse_args(["lobes", "--modal", str(g), "--diameter-mm", "10", "--ae-mm", "1",
                                 "--ktc-mpa", "600", "--krc-mpa", "200"]))
    with pytest.raises(LobeError, match="--rpm-max"):
        run(parser().parse_args(["lobes", "--modal", str(g), *TOOLARGS, "--rpm-min", "9000", "--rpm-max", "8000"]))
    with pytest.raises(ValueError, match="exceeds the tool diameter"):
        run(parser().parse_args(["lobes", "--modal", str(g), "--teeth", "2", "--diameter-mm", "10", "--ae-mm", "12",
                                 "--ktc-mpa", "600", "--krc-mpa", "200", "--n-rpm", "2"]))


def test_dispatcher_reports_bad_input(tmp_path, capsys):
    from robolobes.main import main as robolobes_main
    g = tmp_path / "ok.toml"
    g.write_text(MODAL)
    rc = robolobes_main(["lobes", "--modal", str(g), *TOOLARGS, "--m", "1", "--n-rpm", "2"])
    assert rc == 2
    assert "--m must be an integer from 2 to 400" in capsys.readouterr().err


def test_robot_pose_operating_point(capsys):
    args = parser().parse_args(["lobes", "--case", "tx200-aluminium", "--variant", "basic", "--pose", "tab7",
                                "--rpm-min", "18000", "--rpm-max", "19000", "--n-rpm", "3", "--json", "--quiet"])
    assert run(args) == 0
    out = json.loads(capsys.readouterr().out)
    op = out["operating_point"]
    # the case's own cut: 18 700 rpm, 1.6 mm, stable with margin 2.18 (test_lobes_robot)
    assert op["rpm"] == 18700 and op["depth_m"] == pytest.approx(1.6e-3)
    assert op["stable"] is True and op["verdict"] == "stable"
    assert_allclose(op["margin"], 2.1824, atol=5e-3)
    assert math.isclose(op["spectral_radius"], 0.99525, abs_tol=1e-4)


@pytest.mark.parametrize("extra, match", [
    (["--tol-pct", "0"], r"--tol-pct must be from 0.1 to 20"),
    (["--tol-pct", "50"], r"--tol-pct must be from 0.1 to 20"),
    (["--tol-pct", "1", "--no-refine"], r"--tol-pct has no effect with --no-refine"),
    (["--method", "zoa", "--tol-pct", "1"], r"--tol-pct applies only to --method sdm"),
])
def test_refinement_options_are_checked_before_any_work(tmp_path, extra, match):
    f = tmp_path / "modes.toml"
    f.write_text(MODAL)
    args = parser().parse_args(["lobes", "--modal", str(f), *TOOLARGS, "--n-rpm", "3", "--quiet", *extra])
    with pytest.raises(LobeError, match=match):
        args.run(args)


def test_zoa_operating_point_says_it_has_no_error_estimate(tmp_path, capsys):
    # the ZOA's limit is that of the time-averaged model: its distance to the milling model's limit
    # is not estimated, so the errors are NaN (null in the JSON), never 0, and the text says so
    from robolobes.lobes import ZeroOrder, stability
    from test_lobes_accuracy import lobe_problem

    pt = stability(lobe_problem("1dof-aD0.05-down"), ZeroOrder())
    assert math.isnan(pt.margin_error) and math.isnan(pt.depth_limit_error_m) and pt.limit_status == "no-estimate"
    assert "its error is not estimated" in pt.verdict.reason
    f = tmp_path / "modes.toml"
    f.write_text(MODAL)
    common = ["lobes", "--modal", str(f), *TOOLARGS, "--method", "zoa", "--rpm-min", "18000", "--rpm-max", "19000",
              "--n-rpm", "5", "--at-rpm", "10000", "--at-depth-mm", "1"]
    assert run(parser().parse_args([*common, "--json", "--quiet"])) == 0
    op = json.loads(capsys.readouterr().out)["operating_point"]
    assert op["margin_error"] is None and op["depth_limit_error_m"] is None and op["limit_status"] == "no-estimate"
    assert run(parser().parse_args([*common, "--quiet"])) == 0
    text = capsys.readouterr().out
    assert "(no error estimate)" in text and "+-0" not in text and "|mu|" not in text
    assert "no error estimate: the zero-order approximation" in text
