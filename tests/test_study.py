"""``robolobes study --quick``: the main job on the built-in TX200 cases (issue: the main job)."""

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

import robolobes.identify.study as study
from robolobes.main import main as robolobes_main


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("study") / "robolobes-study"
    rc = robolobes_main(["study", "--quick", "--quiet", "--out", str(out)])
    assert rc == 0
    return out, json.loads((out / "results.json").read_text())


def test_aluminium_stable_and_steel_unstable_in_lobes_and_time_domain(quick):
    _, res = quick
    lob = res["lobes"]
    # the paper's observation for aluminium, and its simulations for steel (section 4)
    for variant in ("basic", "gravity", "orthogonal", "backlash"):
        assert lob["aluminium"][variant]["start"]["operating_point"]["verdict"] == "stable"
        assert lob["steel"][variant]["start"]["operating_point"]["verdict"] == "unstable"
    td = res["time_domain"]["runs"]
    for variant in ("basic", "gravity", "orthogonal", "backlash"):
        assert td[f"aluminium/{variant}"]["stable"] is True
        assert td[f"steel/{variant}"]["stable"] is False
    ex = res["explanation"]
    # computed, not asserted: tooth passing 2 x 18700/60 and 2 x 3100/60 Hz; Ktc ratio 3333/661.553
    assert_allclose(ex["aluminium"]["tooth_passing_hz"], 623.33, rtol=1e-4)
    assert_allclose(ex["steel"]["tooth_passing_hz"], 103.33, rtol=1e-4)
    assert_allclose(ex["ktc_ratio_steel_over_aluminium"], 3333 / 661.553, rtol=1e-12)
    # the two methods agree on the stabilizing damping within their bisection tolerance plus the
    # difference between a fixed pose (lobes) and the pass (time domain): 15 %
    s_l, s_t = ex["steel_stabilizing_damping_scale_lobes"], ex["steel_stabilizing_damping_scale_time_domain"]
    assert s_l is not None and s_t is not None
    assert_allclose(s_t, s_l, rtol=0.15)


def test_modes_at_the_start_pose_equal_robolobes_modes(quick, capsys):
    _, res = quick
    for variant in ("basic", "orthogonal"):
        assert robolobes_main(["modes", "--variant", variant, "--json"]) == 0
        cli = json.loads(capsys.readouterr().out)
        # the study's start pose is the pass at s = 0, which is the Tab. 7 pose as given
        assert_allclose(res["modes"][variant]["start"]["freq_hz"], cli["freq_hz"], rtol=1e-10)
        assert_allclose(res["modes"][variant]["start"]["tcp_static_stiffness_n_per_m"],
                        cli["tcp_static_stiffness_n_per_m"], rtol=1e-9)


def test_report_tables_and_figures(quick):
    out, res = quick
    report = (out / "report.md").read_text()
    for needle in ("## The explanation, in numbers", "Tab. 10", "paper experimental", "robolobes basic",
                   "Roughness", "how much joint damping"):
        assert needle in report
    for fig in ("study.png", "frf.png", "time_domain.png", "wall_aluminium.png"):
        assert (out / fig).stat().st_size > 10000
    assert set(res["tab10"]) >= {"paper experimental", "paper basic", "robolobes basic", "robolobes backlash"}
    leftovers = [p.name for p in out.parent.iterdir() if p.name != out.name]
    assert leftovers == []  # the work directory was swapped in, nothing left beside it


def test_interrupted_study_leaves_the_previous_report(tmp_path, monkeypatch):
    out = tmp_path / "robolobes-study"
    with study.study_output(out, quick=True) as previous:  # an earlier study's output (a marker lists its files)
        (previous.path / "report.md").write_text("previous report")

    def boom(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(study, "section_lobes", boom)
    rc = robolobes_main(["study", "--quick", "--quiet", "--out", str(out)])
    assert rc == 130
    assert (out / "report.md").read_text() == "previous report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["robolobes-study"]
