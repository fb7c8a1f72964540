"""How sure is a path, in every format: POST /predict's per-sample covariance and ``uncertainty``
object, metrics.json, the CSV's sigma columns, the verdict of a walk without ground truth, and
``ftin predict``'s line (``ftin.uncertainty``; docs/metrics.md, "How sure is it").

The API tests run the fixture checkpoints (tiny, not calibrated: they borrow the default model's
constants and say so); the CLI test runs the shipped default on a bundled walk.
"""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
import pytest
from fastapi.testclient import TestClient

from app.settings import BUNDLED_SAMPLES_DIR
from ftin.cli import app as cli
from ftin.uncertainty.radius import radius_holding
from tests.app.routes.helpers import upload
from tests.app.test_browser import (  # noqa: F401  (browser and page are fixtures)
    browser,
    open_upload_page,
)
from tests.app.test_browser import page as page  # noqa: F401  (a fixture)
from tests.utils.cli import runner
from tests.utils.paths import CHECKPOINTS


def covariances(answer: dict) -> np.ndarray:
    traj = answer["trajectory"]
    return np.column_stack([traj["cov_xx"], traj["cov_xy"], traj["cov_yy"]])


def test_predict_answers_a_covariance_per_sample_and_the_end_radius(
    client: TestClient, csv_without_gt: bytes
) -> None:
    answer = upload(client, csv_without_gt, "phone.csv").json()
    cov = covariances(answer)
    assert cov.shape == (len(answer["trajectory"]["t"]), 3)
    assert cov[0] == pytest.approx([0, 0, 0])  # nothing is uncertain at the start
    assert np.all(cov[:, 0] >= 0) and np.all(cov[:, 2] >= 0)
    assert np.all(cov[:, 0] * cov[:, 2] - cov[:, 1] ** 2 >= -1e-9)  # every one a covariance
    trace = cov[:, 0] + cov[:, 2]
    assert trace[-1] > trace[len(trace) // 2] > 0  # it grows along the walk
    found = answer["uncertainty"]
    end = np.array([[cov[-1, 0], cov[-1, 1]], [cov[-1, 1], cov[-1, 2]]])
    assert radius_holding(end) > 0
    # The fixture's tiny model barely moves: its verdict is implausible, so no radius, the reason
    # instead (test_end_circle_api: the radius of a walk judged plausible, the shipped default's).
    assert found["end_radius_95_m"] is None and "implausible" in found["withheld_reason"]
    # It has no constants of its own either: said, not hidden.
    assert found["calibration"].startswith(f"not calibrated for {answer['model']}")
    assert "ronin_resnet-walking" in found["calibration"]


def test_the_verdict_of_a_walk_with_ground_truth_quotes_no_radius(
    client: TestClient, csv_with_gt: bytes
) -> None:
    # Without ground truth the verdict quotes the radius (test_end_circle_api, the shipped default).
    scored = upload(client, csv_with_gt).json()  # ground truth says where it ends: no radius quoted
    assert "end_radius" not in {r["code"] for r in scored["verdict"]["reasons"]}
    assert scored["uncertainty"]["true_end_error_m"] > 0  # the true end, compared start-aligned


def test_metrics_json_and_the_csv_carry_it_too(client: TestClient, csv_without_gt: bytes) -> None:
    answer = upload(client, csv_without_gt, "phone.csv").json()
    run = f"/runs/{answer['run_id']}"
    assert client.get(f"{run}/metrics.json").json()["uncertainty"] == answer["uncertainty"]
    assert client.get(f"{run}/result").json()["uncertainty"] == answer["uncertainty"]
    table = pd.read_csv(io.StringIO(client.get(f"{run}/trajectory.csv").text), comment="#")
    assert list(table.columns) == ["t_s", "x_m", "y_m", "z_m", "sigma_x_m", "sigma_y_m"]
    cov = covariances(answer)
    assert table["sigma_x_m"].to_numpy() == pytest.approx(
        np.sqrt(cov[:, 0]), abs=1e-4
    )  # the API rounds to 1e-6 m^2
    assert table["sigma_y_m"].to_numpy() == pytest.approx(np.sqrt(cov[:, 2]), abs=1e-4)
    at_input = pd.read_csv(
        io.StringIO(client.get(f"{run}/trajectory.csv", params={"timestamps": "input"}).text), comment="#"
    )
    assert at_input["sigma_x_m"].iloc[-1] == pytest.approx(table["sigma_x_m"].iloc[-1], rel=0.05)


def test_ftin_predict_says_where_the_walk_ends(tmp_path) -> None:
    walk = pd.read_csv(BUNDLED_SAMPLES_DIR / "sim_handheld.csv", nrows=3000)  # 30 s at 100 Hz
    recording = tmp_path / "phone.csv"
    walk[["t", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z"]].to_csv(recording, index=False)
    checkpoint = ["--checkpoint", str(CHECKPOINTS / "ronin_resnet-walking.json")]
    result = runner.invoke(cli, ["predict", *checkpoint, str(recording), "--out", str(tmp_path / "t.csv")])
    assert result.exit_code == 0, result.output
    [line] = [line for line in result.stdout.splitlines() if line.startswith("uncertainty: ")]
    assert "m of here (95 %)" in line and "fitted for ronin_resnet-walking" in line
    [verdict] = [line for line in result.stdout.splitlines() if line.startswith("verdict: ")]
    assert "ends within" in verdict


def test_the_result_card_says_why_an_implausible_walk_has_no_circle(live_server, page) -> None:  # noqa: F811
    open_upload_page(page, live_server)  # the tiny fixture model barely moves: implausible
    shown = page.request.get(f"{live_server.base_url}/runs").json()[0]
    found = page.request.get(f"{live_server.base_url}{shown['result_url']}").json()["uncertainty"]
    assert found["end_radius_95_m"] is None and found["withheld_reason"]
    line = page.locator("#end-radius")
    assert line.is_visible() and "Ends within" not in line.inner_text()
    assert line.inner_text().lower() == found["withheld_reason"].lower()
    assert page.locator("#plot circle.end-radius").count() == 0


def test_the_result_card_says_where_the_walk_ends(shipped_server, page) -> None:  # noqa: F811  (a fixture)
    live_server = shipped_server  # the default reads the bundled walk metres long: a circle is drawn
    open_upload_page(page, live_server)
    shown = page.request.get(f"{live_server.base_url}/runs").json()[0]
    result = page.request.get(f"{live_server.base_url}{shown['result_url']}").json()
    radius = result["uncertainty"]["end_radius_95_m"]
    line = page.locator("#end-radius")
    assert line.is_visible() and line.inner_text().startswith("Ends within ")
    number = float(line.inner_text().split("within ")[1].split(" m")[0])
    assert number == pytest.approx(radius, abs=0.051 if radius < 10 else 0.51)
    assert line.get_attribute("title") == result["uncertainty"]["calibration"]
    # under the verdict and its reasons, which stay first in the card
    before = page.evaluate("document.getElementById('end-radius').previousElementSibling.id")
    assert before in ("walk-verdict", "walk-reasons")
