"""``ftin predict`` through typer's CliRunner on a tiny trained run: CSV output in both frames, errors."""

from __future__ import annotations

import numpy as np

from ftin.cli import app
from ftin.data.readers.generic_csv import write_csv
from tests.utils.cli import fails_cleanly, runner


def test_predict_writes_a_trajectory_csv(trained, data_dir, sim_sequences, tmp_path):
    seq = sim_sequences[0]
    out = tmp_path / "traj.csv"
    checkpoint = ["--checkpoint", str(trained / "ronin_tcn.json")]
    recording = str(data_dir / f"{seq.name}.csv")
    result = runner.invoke(app, ["predict", *checkpoint, recording, "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "ATE" in result.stdout and "ground truth frame" in result.stdout
    assert "precision: " in result.stdout and "(auto: " in result.stdout  # --precision auto by default
    text = out.read_text()
    comments = [line for line in text.splitlines() if line.startswith("#")]
    assert any("frame: ground-truth world frame" in line for line in comments)
    rows = np.loadtxt(out, delimiter=",", comments="#", skiprows=len(comments) + 1)
    assert text.splitlines()[len(comments)] == "t,x,y,z"
    assert rows.shape == (len(seq), 4)
    np.testing.assert_allclose(rows[0, 1:], seq.gt.p_world_m[0], atol=1e-6)

    no_gt = tmp_path / "no_gt.csv"
    write_csv(seq.with_(gt=None), no_gt)
    result = runner.invoke(
        app, ["predict", "--checkpoint", str(trained / "ronin_tcn"), str(no_gt), "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert "# frame: device world frame" in out.read_text() and "ATE" not in result.stdout
    np.testing.assert_allclose(np.loadtxt(out, delimiter=",", comments="#", skiprows=4)[0, 1:], 0.0)


def test_predict_in_bf16_stays_close_to_fp32(trained, data_dir, sim_sequences, tmp_path):
    recording = str(data_dir / f"{sim_sequences[0].name}.csv")
    rows = {}
    for precision in ("fp32", "bf16"):
        out = tmp_path / f"{precision}.csv"
        args = ["predict", "--checkpoint", str(trained / "ronin_tcn"), recording, "--out", str(out)]
        result = runner.invoke(app, [*args, "--precision", precision])
        assert result.exit_code == 0, result.output
        assert f"precision: {precision} ({precision} as asked)" in result.stdout
        rows[precision] = np.loadtxt(out, delimiter=",", comments="#", skiprows=4)
    np.testing.assert_allclose(rows["bf16"], rows["fp32"], atol=0.5)  # metres over a short walk
    assert runner.invoke(app, [*args, "--precision", "fp16"]).exit_code == 2


def test_predict_bad_input_is_one_line(trained, data_dir, tmp_path):
    no_ckpt = runner.invoke(
        app, ["predict", "--checkpoint", str(tmp_path / "none"), str(data_dir), "--out", "t.csv"]
    )
    fails_cleanly(no_ckpt, "no checkpoint there")
    many = runner.invoke(
        app, ["predict", "--checkpoint", str(trained / "ronin_tcn"), str(data_dir), "--out", "t.csv"]
    )
    fails_cleanly(many, "holds 3 sequences")
