"""``ftin evaluate`` on walks whose truth is waypoints (an ILC trace), alone and beside dense-truth
walks: its own table and JSON, no crash."""

from __future__ import annotations

import json

from ftin.cli import app
from tests.utils.cli import runner
from tests.utils.ilc import write_trace


def test_evaluate_scores_waypoint_walks_alone_and_beside_dense_ones(trained, data_dir, tmp_path):
    trace = write_trace(tmp_path, seconds=40.0)
    checkpoint = ["--checkpoint", str(trained / "ronin_tcn.safetensors")]
    out = tmp_path / "sparse.json"
    alone = runner.invoke(app, ["evaluate", *checkpoint, "--data", str(trace), "--json", str(out)])
    assert alone.exit_code == 0, alone.output
    assert "walk(s) with waypoints" in alone.stdout and "median path ratio" in alone.stdout
    report = json.loads(out.read_text())
    (walk,) = report["sequences"]
    assert report["truth"] == "waypoints" and walk["floor"] == "F1" and walk["marks"] == 8
    assert walk["path_ratio"] > 0 and walk["ate_at_waypoints_m"] >= 0 and walk["truth_path_m"] > 10
    assert report["summary"]["walks"] == 1

    both = tmp_path / "both.json"
    mixed = runner.invoke(
        app, ["evaluate", *checkpoint, "--data", str(data_dir), "--data", str(trace), "--json", str(both)]
    )
    assert mixed.exit_code == 0, mixed.output
    found = json.loads(both.read_text())
    assert len(found["sequences"]) == 3 and len(found["waypoints"]["sequences"]) == 1
