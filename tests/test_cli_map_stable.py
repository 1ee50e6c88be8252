"""A pose stable at every speed up to the depth searched is not written as "unreachable".

The store holds ``inf`` for such a limit and NaN for an unreachable pose; ``map.json`` cannot
write infinity, so it writes the string ``"inf"`` (``float("inf")`` reads it back) and keeps
``null`` for "no reachable pose". The case: the TX200 in aluminium at its pass start, one speed,
13 500 rpm, where no limit lies below the 10 mm searched (checked below by ``robolobes lobes`` at
the same pose and speed, a separate code path from the map's chunked solver).
"""

import json

import numpy as np
import pytest
import xarray as xr

from robolobes.main import main

RPM = ["--rpm-min", "13500", "--rpm-max", "13500", "--n-rpm", "1"]
MAP = ["map", "--over", "pass", "--n", "1", "--case", "tx200-aluminium", "--at-rpm", "13500", *RPM,
       "--scheduler", "serial", "--quiet"]


@pytest.fixture(scope="module")
def stable_map(tmp_path_factory):
    out = tmp_path_factory.mktemp("map") / "m"
    assert main(MAP + ["--out", str(out)]) == 0
    return out


def test_lobes_agree_that_the_pose_is_stable_up_to_10_mm(stable_map, capsys):
    capsys.readouterr()
    q = json.loads((stable_map / "map.json").read_text())["worst_pose_q_deg"]
    assert main(["lobes", "--case", "tx200-aluminium", "--q-deg=" + ",".join(map(str, q)), *RPM,
                 "--no-refine", "--quiet", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["depth_limit_m"] == [None]   # lobes: null = none below


def test_stable_limit_is_inf_in_the_store_and_in_map_json(stable_map):
    ds = xr.open_zarr(stable_map / "map.zarr", consolidated=False).load()
    assert np.isposinf(ds["depth_limit_m"].values).all() and bool(ds["reachable"].values.all())
    js = json.loads((stable_map / "map.json").read_text())
    for k in ("min_depth_limit_m", "best_pose_min_depth_limit_m", "op_min_depth_limit_m", "op_max_depth_limit_m"):
        assert js[k] == "inf", (k, js[k])
        assert float(js[k]) == np.inf
    assert js["depth_max_m"] == 0.01 and '"inf"' in js["limit_note"] and "null" in js["limit_note"]
    assert js["worst_pose"] == 0 and js["n_unreachable"] == 0


def test_stable_limit_printed_as_none_below_the_depth(stable_map, capsys):
    capsys.readouterr()
    assert main(MAP + ["--out", str(stable_map)]) == 0      # resumes the finished map: nothing computed
    out = capsys.readouterr().out
    assert "lowest limit none below 10 mm at pose 0" in out and "inf mm" not in out, out
