"""``ftin predict`` prints the plausibility figures, the GPS comparison and the standing-still verdict."""

from __future__ import annotations

import shutil
from pathlib import Path

from ftin.cli import app
from ftin.data.readers.generic_csv import write_csv
from tests.utils.cli import runner
from tests.utils.gps import northward_fixes, twenty_steps_export


def test_predict_prints_plausibility_and_the_standing_still_verdict(
    trained, data_dir, sim_sequences, tmp_path
):
    checkpoint = ["--checkpoint", str(trained / "ronin_tcn.json")]
    recording = str(data_dir / f"{sim_sequences[0].name}.csv")
    result = runner.invoke(app, ["predict", *checkpoint, recording, "--out", str(tmp_path / "t.csv")])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    [plausible] = [line for line in lines if line.startswith("plausibility: ")]
    for name in ("path length", "duration 20 s", "moving speed", "step count", "cadence", "step length"):
        assert name in plausible
    assert any(line.startswith(("Worse than standing still", "Better than standing still")) for line in lines)
    assert any("too short for ATE" in line for line in lines)  # a 20 s walk

    no_gt = tmp_path / "no_gt.csv"
    write_csv(sim_sequences[0].with_(gt=None), no_gt)
    result = runner.invoke(app, ["predict", *checkpoint, str(no_gt), "--out", str(tmp_path / "t.csv")])
    assert result.exit_code == 0 and "plausibility: path length" in result.stdout
    assert "standing still" not in result.stdout and "GPS:" not in result.stdout


def test_predict_on_a_phone_export_with_gps(trained, shared_data: Path, tmp_path):
    source = twenty_steps_export(shared_data)
    export = tmp_path / "walk"
    shutil.copytree(source, export)
    (export / "Location.csv").write_bytes(northward_fixes(source, seconds=21, speed_m_s=0.6))
    checkpoint = ["--checkpoint", str(trained / "ronin_tcn.json")]
    result = runner.invoke(app, ["predict", *checkpoint, str(export), "--out", str(tmp_path / "t.csv")])
    assert result.exit_code == 0, result.output
    [gps] = [line for line in result.stdout.splitlines() if line.startswith("GPS: ")]
    assert "gps fixes 21 fixes" in gps and "gps median accuracy 3.00 m" in gps and "gps distance rms" in gps
    [plausible] = [line for line in result.stdout.splitlines() if line.startswith("plausibility: ")]
    steps = int(plausible.split("step count ")[1].split()[0])
    assert 18 <= steps <= 22  # 20 steps recorded
    [verdict] = [line for line in result.stdout.splitlines() if line.startswith("verdict: ")]  # as the API's
    assert verdict.startswith(("verdict: Looks like a walk", "verdict: Check", "verdict: Implausible"))
    assert "gps" in verdict.lower() or "steps" in verdict.lower()  # it judged the walk by what the export has
