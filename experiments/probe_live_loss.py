"""Probe: how far does a lossy live stream's path fall from the clean stream's?

    .venv/bin/python -m experiments.probe_live_loss [--out docs/results/probes/live_loss.md]

The shared Sensor Logger exports replayed into the real app (FastAPI TestClient, the shipped
checkpoints, the default model) at 0.2 s and 0.5 s batches: once clean, then with 10 % of the push
messages lost, 5 % duplicated and 5 % sent a batch late (``ftin.live.replay.perturb``), five seeds
each. Reported: the lossy path over the clean path per seed (the promise: within 5 %). Then, as a
check on walks no choice in ``ftin.live`` was made on, 30 s of five RIDI and OxIOD walks (the
recordings' own attitude) pushed the same way (``ftin.live.replay.sequence_messages``).
"""

from __future__ import annotations

import io
import math
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from experiments.common import argument_parser, parse, write_report
from ftin.data.readers import oxiod, ridi
from ftin.files import DEFAULT_DATA_ROOT
from ftin.live.replay import Push, export_messages, perturb, send, sequence_messages

EXPORTS = ("sensorlogger/inhand-20-steps-Zyf", "sensorlogger/2022-09-16_11-15-46.zip")
RIDI_WALKS = ("dan_handheld1", "hang_bag_side1", "dan_leg1")
OXIOD_WALKS = ("handheld/data1/syn/imu2.csv", "handheld/data1/syn/imu3.csv")
SECONDS = 30.0
PUSH = "/live/sensorlogger"


def path_m(client: TestClient, messages: list) -> float:
    def post(url: str, body: dict) -> tuple[int, str]:
        response = client.post(url, json=body)
        return response.status_code, response.text

    send(messages, PUSH, math.inf, post)
    client.app.state.services.live.end_all()
    session_id = messages[0].body["sessionId"]
    session = next(s for s in client.get("/live/sessions").json() if s["session_id"] == session_id)
    tum = np.loadtxt(io.StringIO(client.get(f"/runs/{session['run_id']}/trajectory.tum").text), comments="#")
    return float(np.linalg.norm(np.diff(tum[:, 1:3], axis=0), axis=1).sum())


def walks() -> dict[str, object]:
    """Name -> the first 30 s (after the first 5) of each held-out walk, without ground truth."""
    out: dict[str, object] = {}
    for name in RIDI_WALKS:
        out[f"ridi/{name}"] = ridi.read(DEFAULT_DATA_ROOT / "ridi" / name)
    for name in OXIOD_WALKS:
        out[f"oxiod/{name}"] = oxiod.read(DEFAULT_DATA_ROOT / "oxiod" / name)
    for name, seq in out.items():
        rate = float(np.median(1.0 / np.diff(seq.t_s)))
        out[name] = seq.slice(int(5 * rate), int((5 + SECONDS) * rate)).with_(gt=None)
    return out


def row(client: TestClient, name: str, make: Callable[[str], list[Push]], batch_s: float) -> str:
    clean = path_m(client, make("clean"))
    ratios = []
    for seed in range(5):
        ratios.append(path_m(client, perturb(make(f"lossy-{seed}"), 0.1, 0.05, 0.05, seed)) / clean)
        print(name, batch_s, seed, ratios[-1], flush=True)
    worst = max(abs(r - 1.0) for r in ratios)
    cells = ", ".join(f"{r:.3f}" for r in ratios)
    return f"| {name} | {batch_s:g} s | {clean:.1f} | {cells} | {worst:.1%} |"


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--out", type=Path, default=Path("docs/results/probes/live_loss.md"))
    args = parse(parser)
    lines = [
        "# A lossy live stream against the clean one",
        "",
        "Made by `python -m experiments.probe_live_loss` (its docstring: method). "
        "Cells: lossy path / clean path.",
        "",
        "| recording | batch | clean path (m) | seeds 0-4 | worst |",
        "|---|--:|--:|---|--:|",
    ]
    with tempfile.TemporaryDirectory() as runs:
        settings = Settings(viser_enabled=False, runs_dir=Path(runs))
        with TestClient(create_app(settings), base_url="http://127.0.0.1") as client:  # an allowed Host
            for export in EXPORTS:
                source = DEFAULT_DATA_ROOT / "phone" / export
                for batch_s in (0.2, 0.5):
                    tag = f"{Path(export).stem}-{batch_s}"
                    lines.append(
                        row(
                            client,
                            export,
                            lambda s, b=batch_s, t=tag, e=source: export_messages(
                                e, b, session_id=f"{s}-{t}"
                            ),
                            batch_s,
                        )
                    )
            for name, seq in walks().items():
                for batch_s in (0.2, 0.5):
                    tag = f"{name.replace('/', '-')}-{batch_s}"
                    lines.append(
                        row(
                            client,
                            name,
                            lambda s, b=batch_s, t=tag, q=seq: sequence_messages(q, b, session_id=f"{s}-{t}"),
                            batch_s,
                        )
                    )
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
