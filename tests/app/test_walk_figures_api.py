"""The figures the page draws beside the verdict (issue 52): ``plausibility.step_times_s``, the one
labelled ``plausibility.step_length`` (the same numbers as the verdict's), ``plausibility.loop_closure``
on a walk that returns to its start; the compare table's rows carrying the verdict's levels; each
model's summary in at most 25 words; readable operation names in ``/docs``.

The walk is the shared Sensor Logger export of 20 steps (real IMU); its GPS is synthetic (Sensor
Logger's layout): out 14 m north and back, a loop by GPS.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.api.routes import exports, health, live, metrics, models, predict, profiles, runs, sequences
from tests.app.routes.helpers import DEFAULT_MODEL, OTHER_MODEL, upload
from tests.app.test_plausibility_api import sensorlogger_zip
from tests.app.test_verdict_api import fixes
from tests.utils.gps import twenty_steps_export


@pytest.fixture(scope="module")
def loop_runs(client: TestClient, shared_data: Path) -> list[dict]:
    """Both fixture models on the 20-step walk with GPS that goes 14 m north and comes back."""
    export = twenty_steps_export(shared_data)
    t = np.arange(0.0, 21.0)
    north = 14.0 * (1.0 - np.abs(t - 10.0) / 10.0)  # out and back
    data = sensorlogger_zip(export, fixes(export, t, north, 3.0))
    answers = [upload(client, data, "walk.zip", model=m) for m in (DEFAULT_MODEL, OTHER_MODEL)]
    assert all(a.status_code == 200 for a in answers), [a.text for a in answers]
    return [a.json() for a in answers]


def figure(body: dict, name: str) -> float | None:
    return next(f["value"] for f in body["plausibility"]["figures"] if f["name"] == name)


def reasons(body: dict) -> dict[str, dict]:
    return {r["code"]: r for r in body["verdict"]["reasons"]}


def test_step_times_are_the_detected_steps(loop_runs: list[dict]) -> None:
    body = loop_runs[0]
    times = body["plausibility"]["step_times_s"]
    assert len(times) == figure(body, "step_count") and 18 <= len(times) <= 24
    assert np.all(np.diff(times) > 0.2)  # one step each, in order
    t = body["trajectory"]["t"]
    assert t[0] - 1.0 <= times[0] and times[-1] <= t[-1] + 1.0  # on the trajectory's clock
    assert times == loop_runs[1]["plausibility"]["step_times_s"]  # the accelerometer's, not the model's


def test_one_step_length_labelled_and_the_same_in_the_verdict(loop_runs: list[dict]) -> None:
    for body in loop_runs:
        step = body["plausibility"]["step_length"]
        assert step["from_path_m"] == pytest.approx(figure(body, "step_length"), abs=1e-3)
        assert 0.3 < step["from_cadence_m"] < 1.0 and step["low_m"] < step["high_m"]
        found = reasons(body)["step_distance"]["figures"]
        for key in ("from_path_m", "from_cadence_m", "low_m", "high_m"):
            assert found[key] == pytest.approx(step[key], abs=0.006), key
    cadence_steps = {b["plausibility"]["step_length"]["from_cadence_m"] for b in loop_runs}
    assert len(cadence_steps) == 1  # what the cadence suggests does not depend on the model


def test_a_walk_that_returns_to_its_start_states_its_loop_closure(loop_runs: list[dict]) -> None:
    for body in loop_runs:
        loop = body["plausibility"]["loop_closure"]
        traj = body["trajectory"]
        gap = np.hypot(traj["x"][-1] - traj["x"][0], traj["y"][-1] - traj["y"][0])
        assert loop["gap_m"] == pytest.approx(gap, abs=0.01)
        assert loop["path_m"] == pytest.approx(26.0, rel=0.2)  # the GPS's smoothed out-and-back
        assert loop["share"] == pytest.approx(loop["gap_m"] / loop["path_m"], abs=1e-3)
        assert reasons(body)["loop_closure"]["figures"]["gap_m"] == pytest.approx(loop["gap_m"], abs=0.01)


def test_no_loop_closure_without_a_loop(client: TestClient, csv_without_gt: bytes) -> None:
    body = upload(client, csv_without_gt, "phone.csv").json()
    assert body["plausibility"]["loop_closure"] is None
    assert isinstance(body["plausibility"]["step_times_s"], list)


def test_compare_rows_carry_the_verdicts_levels_and_flags(client: TestClient, loop_runs: list[dict]) -> None:
    table = client.get("/compare", params={"ids": ",".join(b["run_id"] for b in loop_runs)}).json()
    for body, row in zip(loop_runs, table["rows"], strict=True):
        levels = {code: r["level"] for code, r in reasons(body).items()}
        assert row["levels"] == levels and row["verdict"] == body["verdict"]["level"]
        assert bool(row["flags"]) == any(level != "ok" for level in levels.values())
        step = reasons(body)["step_distance"]
        if step["level"] != "ok":
            assert {"steps too short", "steps too long"} & set(row["flags"])
    step_column = next(c for c in table["columns"] if c["key"] == "step_length")
    assert step_column["label"] == "Step (path / steps)"
    assert "m a step by the cadence" in table["summary"]


def test_every_model_has_a_summary_of_at_most_25_words(client: TestClient) -> None:
    listed = client.get("/models").json()
    assert listed
    for model in listed:
        words = model["summary"].split()
        assert 3 <= len(words) <= 25, model["summary"]
        assert "trained on" in model["summary"]


@pytest.mark.parametrize(
    "module", [exports, health, live, metrics, models, predict, profiles, runs, sequences]
)
def test_every_operation_has_a_readable_name_in_docs(module) -> None:
    for route in module.router.routes:
        if not getattr(route, "include_in_schema", False):
            continue
        generated = route.name.replace("_", " ").title()  # what /docs shows without a summary
        assert route.summary and route.summary != generated, route.path
        assert not route.summary.endswith("Route"), route.path


def test_a_csv_with_truth_and_no_orientation_warns_only_when_scored_unaligned(
    client: TestClient, sample_frame
) -> None:
    columns = ["t", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z"]
    data = sample_frame[[*columns, *(f"gt_device_world_{a}" for a in "xyz")]].to_csv(index=False).encode()
    aligned = upload(client, data).json()  # the default: the truth's start aligned to the prediction's
    assert aligned["metrics"]["alignment"] == "start"
    assert not [w for w in aligned["warnings"] if "heading" in w and "truth" in w], aligned["warnings"]
    assert any("keeps its own heading" in n for n in aligned["notes"])
    unaligned = upload(client, data, align="none").json()
    assert any(w.startswith("the ground truth's heading is not aligned") for w in unaligned["warnings"])
