"""Small inputs, bounded costs: a real uvicorn server (a subprocess, so that its memory is its own)
gets the inputs that once cost minutes and gigabytes, and answers each with a short 4xx in seconds
while its peak memory stays within 600 MB of where it started.

- a CSV whose header has 10^6 columns (9.4 MB): once 180 s without an answer and 2.6 GB;
- a ~1 MB gzip body that unpacks to 1 GiB (256 members of 4 MiB: the trailer declares only the last
  one, so decompression itself must stop at the cap, not unpack then check), and a tiny one whose
  trailer declares 1 GiB (refused before any unpacking).

The peak is the kernel's own (``VmHWM`` in ``/proc/PID/status``, reset through ``clear_refs`` once the
server has started), so it counts every allocation, numpy's and zlib's included. Linux only.
"""

from __future__ import annotations

import gzip
import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from app.settings import REPO_ROOT
from tests.hardening.conftest import MODEL_NAME, write_tiny_checkpoint

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="reads the server's peak memory from /proc (Linux)"
)

MAX_ANSWER_S = 15.0
MAX_BODY_BYTES = 4096
MAX_GROWTH_MB = 600.0
HEADER = b"t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n"
ROW = b"0.005,0.01,0.02,0.03,0.1,0.2,9.81\n"


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _status_kb(pid: int, field: str) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise AssertionError(f"no {field} in /proc/{pid}/status")


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, int]]:
    """``uvicorn app.main:app`` with the default limits (200 MiB uploads) and a tiny checkpoint."""
    root = tmp_path_factory.mktemp("bounded_cost")
    write_tiny_checkpoint(root / "checkpoints")
    (root / "data").mkdir()
    port = _free_port()
    env = os.environ | {
        "FTIN_CHECKPOINT_DIR": str(root / "checkpoints"),
        "FTIN_DEFAULT_MODEL": MODEL_NAME,
        "FTIN_DATA_DIRS": str(root / "data"),
        "FTIN_RUNS_DIR": str(root / "runs"),
        "FTIN_VISER_ENABLED": "false",
        "FTIN_SCENE_FIRST_RUN": "false",
        "PYTHONPATH": str(REPO_ROOT),
    }
    command = [sys.executable, "-m", "uvicorn", "app.main:app", "--host", "127.0.0.1", "--port", str(port)]
    process = subprocess.Popen(
        command, env=env, cwd=root, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
    )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 120
        while True:
            if process.poll() is not None:
                pytest.fail(f"the server did not start: {process.stderr.read() if process.stderr else ''}")
            try:
                if httpx.get(url + "/health", timeout=2).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline:
                pytest.fail("the server did not answer /health within 120 s")
            time.sleep(0.3)
        yield url, process.pid
    finally:
        process.terminate()
        try:
            process.wait(20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(20)


def _wide_csv() -> bytes:
    """The schema's columns and 10^6 - 7 more (9.4 MB), then one row."""
    names = b",".join(b"col%d" % i for i in range(10**6 - 7))
    return HEADER.rstrip(b"\n") + b"," + names + b"\n" + ROW


def _gzip_bomb(members: int, member_bytes: int = 4 * 2**20) -> bytes:
    """A header, then one endless cell of zeros: ``members`` gzip members of ``member_bytes`` each
    (~4 KB packed)."""
    first = gzip.compress(HEADER + b"0" * (member_bytes - len(HEADER)), compresslevel=9)
    rest = gzip.compress(b"0" * member_bytes, compresslevel=9)
    return first + rest * (members - 1)


def _honest_bomb() -> bytes:
    """One member whose trailer says 1 GiB: the size check refuses it before any unpacking."""
    piece = gzip.compress(ROW * 1000, compresslevel=9)[:-4]
    return piece + (2**30).to_bytes(4, "little")  # a wrong CRC is never reached: refused first


def test_inputs_that_once_cost_gigabytes_get_short_4xx_fast(server: tuple[str, int]) -> None:
    url, pid = server
    with httpx.Client(base_url=url, timeout=120) as client:
        warm = client.post("/predict", content=HEADER + ROW * 3, headers={"content-type": "text/csv"})
        assert warm.status_code == 422  # too short: imports and first-request work done before the baseline
        try:
            Path(f"/proc/{pid}/clear_refs").write_text("5")  # VmHWM := VmRSS
        except OSError as exc:
            pytest.skip(f"cannot reset the server's peak memory ({exc})")
        before_kb = _status_kb(pid, "VmRSS")
        cases = {
            "wide.csv": (_wide_csv(), "text/csv", "has 1000000 columns"),
            "bomb.csv.gz": (_gzip_bomb(256), "application/gzip", "unpacks to more than 200 MiB"),
            "honest-bomb.csv.gz": (_honest_bomb(), "application/gzip", "unpacks to more than 200 MiB"),
        }
        for name, (body, content_type, expected) in cases.items():
            started = time.monotonic()
            response = client.post(
                "/predict", params={"name": name}, content=body, headers={"content-type": content_type}
            )
            took = time.monotonic() - started
            assert 400 <= response.status_code < 500, (name, response.status_code, response.text[:300])
            assert len(response.content) < MAX_BODY_BYTES, (name, len(response.content))
            assert expected in response.json()["detail"], (name, response.json()["detail"])
            assert took < MAX_ANSWER_S, f"{name}: {took:.1f} s"
            print(
                f"{name}: {len(body) / 2**20:.1f} MiB sent -> {response.status_code} in {took:.2f} s, "
                f"{len(response.content)} bytes"
            )
        growth_mb = (_status_kb(pid, "VmHWM") - before_kb) / 1024
        print(f"server peak memory grew by {growth_mb:.0f} MB over the three")
        assert growth_mb < MAX_GROWTH_MB
        assert client.get("/health").status_code == 200
