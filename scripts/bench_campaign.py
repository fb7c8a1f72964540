"""Ray's overhead per campaign job, against one plain subprocess per job (the former scheduler's way).

    .venv/bin/python scripts/bench_campaign.py [--jobs 4]

The same tiny jobs (a small TCN, one epoch on simulated walks, then scored) run twice, one at a time:
(1) each in a fresh ``python`` process on the frozen code, as the former scheduler started them
(its 5 s polling not counted); (2) through ``ftin.campaign.engine.run`` on a local Ray with one
worker. Per job, the overhead is the wall time around the job minus the time the job itself logged
(first to last line of its ``log.txt``): process start and imports, Ray's scheduling, the worker's
start. Memory: the peak RSS of a job process (``ru_maxrss`` of the children), and the RSS of Ray's
own processes (GCS, raylet, agents; from /proc) while the campaign runs, beside the driver's.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
from datetime import datetime
from pathlib import Path

from ftin.campaign import engine
from ftin.campaign.folder import Campaign
from ftin.sim.samples import write_walks

# Ray's own processes; its workers (ray::IDLE, ray::train_job) hold the jobs and are counted apart.
RAY_SYSTEM = ("gcs_server", "raylet", "DashboardAgent", "RuntimeEnvAgent", "log_monitor", "monitor.py")
RAY_WORKERS = ("ray::IDLE", "ray::train_job")


def make_jobs(root: Path, count: int) -> Path:
    write_walks(root / "walks" / "train", 2, 60.0, 50.0, seed=100)
    write_walks(root / "walks" / "val", 1, 20.0, 50.0, seed=200)
    write_walks(root / "walks" / "test", 1, 20.0, 50.0, seed=300)
    options = {"model_kwargs": {"channels": [8, 8]}, "imu_rate_hz": 50.0, "window": 50, "stride": 5,
               "batch_size": 32, "max_epochs": 1, "orientation": None}  # fmt: skip
    parts = {part: [f"walks/{part}"] for part in ("train", "val", "test")}
    jobs = [{"name": f"walks/tcn-s{seed}", "model": "ronin_tcn", "dataset": "walks", "seed": seed,
             "options": options, "parts": parts} for seed in range(count)]  # fmt: skip
    (root / "jobs.json").write_text(json.dumps(jobs))
    return root / "jobs.json"


def logged_seconds(folder: Path) -> float:
    stamps = [line[:19] for line in (folder / "log.txt").read_text().splitlines()]
    first, last = (datetime.strptime(s, "%Y-%m-%d %H:%M:%S") for s in (stamps[0], stamps[-1]))
    return (last - first).total_seconds()


def rss_mib(names: tuple[str, ...]) -> float:
    total = 0
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
            if any(name in cmd for name in names):
                status = Path(f"/proc/{pid}/status").read_text()
                total += int(
                    next(line.split()[1] for line in status.splitlines() if line.startswith("VmRSS"))
                )
        except (OSError, StopIteration):
            continue
    return total / 1024


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--jobs", type=int, default=4)
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench_campaign_"))
    jobs_file = make_jobs(root / "data", args.jobs)

    plain = Campaign.create(root / "plain", root / "data", jobs_file)
    overheads = []
    for job in plain.jobs():
        code = plain.code_for(job)
        snippet = "import sys, json; from ftin.campaign.job import run_job; run_job(*json.loads(sys.argv[1]))"
        payload = json.dumps([str(plain.runs), job.to_json(), str(plain.data_root)])
        env = {**os.environ, "PYTHONPATH": str(code), "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        start = time.monotonic()
        subprocess.run([sys.executable, "-c", snippet, payload], env=env, check=True, capture_output=True)
        overheads.append(time.monotonic() - start - logged_seconds(plain.job_dir(job)))
    peak_job = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024

    ray_campaign = Campaign.create(root / "ray", root / "data", jobs_file)
    start = time.monotonic()
    with engine.ray_session(workers=1) as ray:
        started = time.monotonic() - start
        system: list[float] = []
        workers: list[float] = []
        done = threading.Event()

        def sample() -> None:
            while not done.wait(0.5):
                system.append(rss_mib(RAY_SYSTEM))
                workers.append(rss_mib(RAY_WORKERS))

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        begin = time.monotonic()
        engine.run(ray_campaign, workers=1, on_event=lambda _: None)
        ray_wall = time.monotonic() - begin
        done.set()
        sampler.join()
        del ray
    ray_logged = sum(logged_seconds(ray_campaign.job_dir(j)) for j in ray_campaign.jobs())
    result = {
        "jobs": args.jobs,
        "plain_overhead_s_per_job": sum(overheads) / len(overheads),
        "plain_job_peak_rss_mib": peak_job,
        "ray_start_s": started,
        "ray_overhead_s_per_job": (ray_wall - ray_logged) / args.jobs,
        "ray_system_rss_mib_max": max(system, default=None),
        "ray_worker_rss_mib_max": max(workers, default=None),
        "note": "log stamps have 1 s resolution; run with --jobs 8 for a steadier mean",
    }
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
