"""``ftin profile add / show / list / delete`` and ``ftin predict --profile`` on the runs folder a server
wrote (the same store, ``ftin.profiles.store``): a run made by the app, a profile made by the CLI."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from ftin.cli import app
from ftin.data.readers.generic_csv import write_csv
from tests.utils.cli import fails_cleanly, runner
from tests.utils.paths import CHECKPOINTS

MODEL = "ronin_resnet-walking"


def rows(path: Path) -> np.ndarray:
    return np.loadtxt(
        path,
        delimiter=",",
        comments="#",
        skiprows=1 + sum(line.startswith("#") for line in path.read_text().splitlines()),
    )


def test_a_profile_made_on_the_command_line_scales_a_prediction(sim_sequences, tmp_path) -> None:
    recording = tmp_path / "walk.csv"
    write_csv(sim_sequences[0].with_(gt=None), recording)
    # The default model (a walk of known length must be metres long: tiny test models barely move)
    runs_dir, checkpoints = tmp_path / "runs", tmp_path / "checkpoints"
    checkpoints.mkdir()
    for part in CHECKPOINTS.glob(f"{MODEL}.*"):
        shutil.copy(part, checkpoints / part.name)
    settings = Settings(
        checkpoint_dir=checkpoints, default_model=MODEL, runs_dir=runs_dir, data_dirs=[],
        viser_enabled=False, scene_first_run=False,
    )  # fmt: skip
    with TestClient(create_app(settings)) as client:  # the server's run, stored in its runs folder
        answer = client.post(
            "/predict", files={"file": ("walk.csv", recording.read_bytes(), "text/csv")}
        ).json()
    t = answer["trajectory"]
    predicted = float(np.hypot(np.diff(t["x"]), np.diff(t["y"])).sum())
    folder = ["--runs-dir", str(runs_dir)]

    added = runner.invoke(
        app,
        ["profile", "add", "cara", "--run", answer["run_id"], "--distance", str(1.25 * predicted), *folder],
    )
    assert added.exit_code == 0, added.output
    assert "cara: scale 1.250" in added.stdout and "(1 walk)" in added.stdout
    shown = json.loads(runner.invoke(app, ["profile", "show", "cara", "--json", *folder]).stdout)
    assert shown["scale"] == pytest.approx(1.25, rel=1e-3) and shown["walks"][0]["run_id"] == answer["run_id"]
    listed = json.loads(runner.invoke(app, ["profile", "list", "--json", *folder]).stdout)
    assert [p["name"] for p in listed] == ["cara"]

    checkpoint = ["--checkpoint", str(checkpoints / MODEL)]
    plain, scaled = tmp_path / "plain.csv", tmp_path / "scaled.csv"
    assert runner.invoke(app, ["predict", *checkpoint, str(recording), "--out", str(plain)]).exit_code == 0
    result = runner.invoke(
        app, ["predict", *checkpoint, str(recording), "--out", str(scaled), "--profile", "cara", *folder]
    )
    assert result.exit_code == 0, result.output
    assert "profile: cara, scale 1.250" in result.stdout
    before, after = rows(plain), rows(scaled)
    np.testing.assert_allclose(
        after[:, 1:3] - after[0, 1:3], 1.25 * (before[:, 1:3] - before[0, 1:3]), atol=1e-5
    )
    np.testing.assert_allclose(after[:, 3], before[:, 3], atol=1e-6)  # height is left as it was

    with TestClient(create_app(settings)) as client:  # the server sees the CLI's profile
        assert client.get("/profiles/cara").json() == shown

    assert runner.invoke(app, ["profile", "delete", "cara", *folder]).exit_code == 0
    assert "no profiles" in runner.invoke(app, ["profile", "list", *folder]).stdout
    fails_cleanly(runner.invoke(app, ["profile", "show", "cara", *folder]), "unknown profile 'cara'")
    fails_cleanly(
        runner.invoke(
            app, ["predict", *checkpoint, str(recording), "--out", str(scaled), "--profile", "cara", *folder]
        ),
        "unknown profile 'cara'",
    )
    fails_cleanly(runner.invoke(app, ["profile", "add", "dan", "--run", "nosuchrun", *folder]), "nosuchrun")
    # an IMU-only recording has no GPS: without --distance it cannot count
    fails_cleanly(
        runner.invoke(app, ["profile", "add", "dan", "--run", answer["run_id"], *folder]), "needs distance_m"
    )
    fails_cleanly(runner.invoke(app, ["profile", "show", "bad name", *folder]), "profile name")
