"""``robolobes optimize --strict`` runs for both built-in cases (tiny budget: one start, no local run).

The paper's placement is 2.86 deg past A3's +145 deg limit (Tab. 7), so under strict ranges it is
not a candidate; it stays the reference of the gain, evaluated with the tolerant ranges, and the
optimum reported must itself lie inside the strict ranges.
"""

import json
import math

import pytest

from robolobes.main import main


@pytest.mark.parametrize("case", ["tx200-aluminium", pytest.param("tx200-steel", marks=pytest.mark.slow)])
def test_optimize_strict_works_for_both_builtin_cases(tmp_path, capsys, case):
    out = tmp_path / "opt"
    rc = main(["optimize", "--case", case, "--strict", "--n-starts", "1", "--max-local-evals", "0", "--n-s", "2",
               "--out", str(out), "--quiet", "--json"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    js = json.loads(cap.out)
    assert js["strict_limits"] is True
    assert js["baseline_feasible"] and js["baseline_strict_ok"] is False
    assert "A3" in js["baseline_strict_violation"]
    assert js["optimum_feasible"] and js["optimum_strict_ok"] is True
    assert js["baseline_min_depth_m"] > 0 and math.isfinite(js["gain"]) and js["gain"] > 0
    assert (out / "optimize.png").is_file() and (out / "optimize.json").is_file()
