"""``robolobes map``: outputs, JSON contract, resume, and bad input (exit 2, nothing written)."""

import json
import math

import pytest

from robolobes.main import main

SMALL = ["map", "--case", "tx200-steel", "--over", "placement", "--n", "2", "--y-range-mm", "0,0",
         "--x-range-mm", "0,100", "--n-rpm", "3", "--scheduler", "serial", "--quiet"]


def test_map_cli_outputs_and_resume(tmp_path, capsys):
    out = tmp_path / "m"
    assert main(SMALL + ["--out", str(out), "--json"]) == 0
    js = json.loads(capsys.readouterr().out)
    for k in ("n_poses", "n_speeds", "n_unreachable", "min_depth_limit_m", "worst_pose_q_deg", "best_pose_q_deg",
              "computed_poses", "wall_s", "inputs_sha256"):
        assert k in js, k
    assert js["n_poses"] == 2 and js["n_speeds"] == 3 and js["computed_poses"] == 2
    assert len(js["worst_pose_q_deg"]) == 6
    for f in ("map.zarr", "map.json", "map_heatmap.png", "map_margin.png", "map_robot.png"):
        assert (out / f).exists(), f
    # the same command again: the store is complete, nothing is recomputed
    assert main(SMALL + ["--out", str(out), "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["computed_poses"] == 0 and again["min_depth_limit_m"] == js["min_depth_limit_m"]
    # the default is the full model: no truncation, so no truncation error
    assert js["method"]["reduce_max_freq_hz"] is None
    assert js["max_truncation_static_error"] is None and js["max_truncation_frf_error"] is None


def test_map_cli_truncation_is_an_opt_in(tmp_path, capsys):
    # --truncate-hz 300 reaches the method (map.json's method, the stored truncation errors), and
    # a store of the full model is not resumed by it (other inputs: refused, exit 2)
    # (the orthogonal model: the basic one has no mode above 142 Hz, so 300 Hz would drop nothing)
    out = tmp_path / "t"
    orth = SMALL + ["--variant", "orthogonal"]
    assert main(orth + ["--truncate-hz", "300", "--out", str(out), "--json"]) == 0
    js = json.loads(capsys.readouterr().out)
    assert js["method"]["reduce_max_freq_hz"] == 300.0
    # the 300 Hz truncation of the orthogonal model dropped 1.1e-3 to 1.4e-3 of the static
    # compliance at 20 other placement poses (docs/guide/workspace.md): a decade either side here
    assert 1e-4 < js["max_truncation_static_error"] < 1e-2
    assert main(orth + ["--out", str(out), "--json"]) == 2
    assert "other inputs" in capsys.readouterr().err


@pytest.mark.parametrize("bad, words", [
    (["--n", "0"], "--n must be"),
    (["--n-rpm", "100000"], "--n-rpm must be"),
    (["--x-range-mm", "5,1"], "--x-range-mm"),
    (["--yaw-range-deg", "a,b"], "--yaw-range-deg"),
    (["--scheduler", "udp://x"], "--scheduler"),
    (["--rpm-min", "-3"], "--rpm-min"),
    (["--model", "nothing.toml"], "nothing.toml"),
    (["--tool-modes", "nothing.toml"], "nothing.toml"),
    (["--truncate-hz", "0"], "--truncate-hz must be"),
    (["--truncate-hz", "nan"], "--truncate-hz must be"),
])
def test_map_cli_bad_input_exit_2_nothing_written(tmp_path, capsys, bad, words):
    out = tmp_path / "m"
    args = [a for a in SMALL]
    for i in range(0, len(bad), 2):  # replace an option already in SMALL, or append it
        if bad[i] in args:
            args[args.index(bad[i]) + 1] = bad[i + 1]
        else:
            args += bad[i:i + 2]
    if "--model" in bad and "--case" in args:   # --case with --model is refused by itself
        del args[args.index("--case"):args.index("--case") + 2]
    assert main(args + ["--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0]
    assert not out.exists()


def test_map_cli_refuses_a_users_directory(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    assert main(SMALL + ["--out", str(out)]) == 2
    assert "did not write" in capsys.readouterr().err
    assert (out / "notes.txt").read_text() == "keep me" and len(list(out.iterdir())) == 1


def test_optimize_cli_json_contract(tmp_path, capsys):
    out = tmp_path / "o"
    args = ["optimize", "--case", "tx200-steel", "--over", "tool-rotation", "--n-starts", "1", "--max-local-evals",
            "0", "--n-s", "2", "--quiet", "--json", "--out", str(out)]
    assert main(args) == 0
    js = json.loads(capsys.readouterr().out)
    for k in ("baseline_min_depth_m", "optimized_min_depth_m", "gain", "placement_offset_m", "yaw_deg",
              "tool_rotation_deg", "worst_pose_q_deg", "inputs_sha256"):
        assert k in js, k
    assert js["gain"] >= 1.0 and len(js["placement_offset_m"]) == 3
    assert js["objective_model"].startswith("full model")   # the default: search and report on one model
    assert (out / "optimize.json").exists() and (out / "optimize.png").exists()


@pytest.mark.parametrize("bad, words", [
    (["--over", "everything"], "--over"),
    (["--n-s", "1"], "--n-s"),
    (["--x-range-mm", "10,20"], "must contain 0"),
    (["--truncate-hz", "inf"], "--truncate-hz must be"),
])
def test_optimize_cli_bad_input(tmp_path, capsys, bad, words):
    out = tmp_path / "o"
    assert main(["optimize", "--case", "tx200-steel", "--quiet", "--out", str(out)] + bad) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0]
    assert not out.exists()


def test_optimize_cli_mrr_and_strict_keys(tmp_path, capsys, steel_case):
    # --objective mrr over 3 speeds, tiny budget. The printed removal rate is the printed depth
    # times a_e f_z N n (case numbers, closed form) in cm^3/min: rtol 1e-9. The paper's placement is
    # not strictly feasible: A3 2.86 deg past +145 deg (Tab. 7, NOTES.md).
    from robolobes.cases import load_case

    out = tmp_path / "o"
    args = ["optimize", "--case", "tx200-steel", "--over", "tool-rotation", "--n-starts", "1", "--max-local-evals",
            "0", "--n-s", "2", "--objective", "mrr", "--rpm-min", "2000", "--rpm-max", "6000", "--n-rpm", "3",
            "--quiet", "--json", "--out", str(out)]
    assert main(args) == 0
    js = json.loads(capsys.readouterr().out)
    for k in ("objective", "best_rpm", "baseline_mrr_cm3_per_min", "optimized_mrr_cm3_per_min", "mrr_gain",
              "objective_note", "strict_optimum", "baseline_strict_violation"):
        assert k in js, k
    assert js["objective"] == "mrr" and js["best_rpm"] in (2000.0, 4000.0, 6000.0)
    c = steel_case
    mrr = js["optimized_min_depth_m"] * c.cut.ae_m * c.cut.feed_per_tooth_m * c.tool.teeth * js["best_rpm"] / 60.0
    assert js["optimized_mrr_cm3_per_min"] == pytest.approx(mrr * 1e6 * 60.0, rel=1e-9)
    assert js["mrr_gain"] >= 1.0
    assert js["baseline_strict_ok"] is False
    assert js["baseline_strict_violation"].startswith("A3 2.86 deg past +145 deg")
    assert js["strict_optimum"]["how"] in ("tolerant optimum", "strict run")
    assert f"--rpm-min {js['best_rpm']:g}" in js["lobes_check"]
    # the optimum's case runs at the optimum's speed with the case's feed per tooth
    oc = load_case(str(out / "optimum-case.toml"))
    assert oc.cut.spindle_rpm == js["best_rpm"]
    assert oc.cut.feed_per_tooth_m == pytest.approx(c.cut.feed_per_tooth_m, rel=1e-12)


@pytest.mark.parametrize("bad, words", [
    (["--n-rpm", "5"], "--n-rpm is for --objective mrr"),
    (["--objective", "mrr", "--at-rpm", "3000"], "--at-rpm is for --objective depth"),
    (["--objective", "mrr", "--n-rpm", "0"], "--n-rpm must be from 1 to 200"),
    (["--objective", "mrr", "--rpm-min", "4000", "--rpm-max", "3000"], "--rpm-max"),
])
def test_optimize_cli_bad_speed_options(tmp_path, capsys, bad, words):
    out = tmp_path / "o"
    assert main(["optimize", "--case", "tx200-steel", "--quiet", "--out", str(out)] + bad) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0]
    assert not out.exists()


def test_map_lead_tilt_sweeps_tilt_with_lead_fixed_at_zero(tmp_path, capsys, steel_case):
    # Two tilts, -8 and +8 deg. At each pose the tool axis (TCP z from fk of the stored joints) keeps
    # the start pose's component along the feed (no lead: 2.6e-6, Tab. 7's printed angles are
    # 3.4e-5 rad off vertical) and makes the tilt angle with the start pose's axis: geometry, to
    # the IK's accuracy (1e-9).
    import numpy as np
    import xarray as xr

    from robolobes.linearize import fk

    out = tmp_path / "lt"
    args = ["map", "--case", "tx200-steel", "--over", "lead-tilt", "--n", "2", "--tilt-range-deg=-8,8",
            "--n-rpm", "2", "--scheduler", "serial", "--quiet", "--json", "--out", str(out)]
    assert main(args) == 0
    js = json.loads(capsys.readouterr().out)
    assert js["lead_deg"] == 0.0 and "perpendicular to the tool axis" in js["lead_note"]
    ds = xr.open_zarr(out / "map.zarr", consolidated=False)
    case = steel_case
    z0 = np.asarray(fk(case.robot, case.path.start_q_rad)[1])[:, 2]
    for i, tilt in enumerate(np.radians([-8.0, 8.0])):
        assert ds["reachable"].values[i]
        z = np.asarray(fk(case.robot, ds["theta_rad"].values[i])[1])[:, 2]
        feed = ds["feed_direction"].values[i]
        assert abs(z @ feed - z0 @ feed) < 1e-9
        assert math.isclose(math.acos(np.clip(z @ z0, -1, 1)), abs(tilt), abs_tol=1e-9)


def test_map_lead_angle_refused_with_its_reason(tmp_path, capsys):
    out = tmp_path / "ld"
    args = ["map", "--case", "tx200-steel", "--n", "2", "--n-rpm", "3", "--scheduler", "serial", "--quiet"]
    assert main(args + ["--over", "lead-tilt", "--lead-range-deg", "0,10", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--lead-range-deg 0,10 refused" in err[0] and "perpendicular" in err[0]
    assert not out.exists()
