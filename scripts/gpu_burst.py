"""Campaign jobs trained in a burst on a lent GPU machine (``ftin.campaign.burst``: why and how).

Here:  python scripts/gpu_burst.py pack --runs runs/generalisation --out gpu_pack [--jobs N] [--skip NAME ...]
There: python scripts/gpu_burst.py train --pack gpu_pack --out "$OUT" --workers 14 --minutes 8
There: python scripts/gpu_burst.py fetch --out "$OUT"                  (the next call, while warm)
There: python scripts/gpu_burst.py train --pack gpu_pack --out "$OUT" --workers 14 --minutes 4 --resume
       (a next call, while warm: continues the jobs the deadline stopped)
Here:  python scripts/gpu_burst.py finish --runs runs/generalisation --results OUT/*.tar.gz

``--smoke`` (train) ends every job after one epoch: a check of the whole path on a CPU, not a result.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from ftin.campaign import burst
from ftin.campaign.folder import CODE_FILE, Campaign

RUNS_THERE = Path("/tmp/burst-runs")  # the run folders on the lent machine (kept while it is warm)
FILES_BACK = 7  # one checkpoint (8.5 MiB) a file: 7 fit the 8 files and 64 MiB a call brings back


def main() -> None:
    raw = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=raw)
    sub = parser.add_subparsers(dest="verb", required=True)
    p = sub.add_parser("pack", help="the chosen pending jobs and their prepared recordings")
    p.add_argument("--runs", type=Path, required=True)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--jobs", type=int, default=None, help="the first N pending jobs (default: all)")
    p.add_argument("--skip", nargs="*", default=[], help="pending jobs to leave to the campaign here")
    t = sub.add_parser("train", help="train the packed jobs until done or the deadline")
    t.add_argument("--pack", type=Path, required=True)
    t.add_argument("--out", type=Path, required=True, help="folder for one .tar.gz per finished job")
    t.add_argument("--workers", type=int, default=7)
    t.add_argument("--first", type=int, default=None, help="only the first N packed jobs")
    t.add_argument("--skip-first", type=int, default=0, help="leave out the first N packed jobs")
    t.add_argument("--minutes", type=float, required=True, help="no job runs past this many minutes")
    t.add_argument("--device", default="cuda")
    t.add_argument("--smoke", action="store_true")
    t.add_argument("--keep", type=int, default=FILES_BACK, help="archive at most N finished jobs")
    t.add_argument(
        "--resume",
        action="store_true",
        help="continue what an earlier call on this warm machine left: the jobs its deadline stopped",
    )
    a = sub.add_parser("fetch", help="archive the finished jobs no call has brought back (a warm machine)")
    a.add_argument("--out", type=Path, required=True)
    a.add_argument("--again", action="store_true", help="also the jobs an earlier call archived")
    a.add_argument("--skip-first", type=int, default=0, help="leave out the first N of them")
    f = sub.add_parser("finish", help="unpack a burst's finished jobs into the campaign and score them")
    f.add_argument("--runs", type=Path, required=True)
    f.add_argument("--results", type=Path, nargs="+", required=True, help="the burst's .tar.gz files")
    args = parser.parse_args()

    if args.verb == "pack":
        campaign = Campaign(args.runs)
        # a job a driver here has taken has its code marker; --skip names others to leave here
        names = [
            j.name
            for j in campaign.pending()
            if not (campaign.runs / j.name / CODE_FILE).exists() and j.name not in args.skip
        ]
        names = names[: args.jobs] if args.jobs else names
        print(json.dumps(burst.pack(args.runs, names, args.out)))
        print("\n".join(names))
    elif args.verb == "train":
        started = time.time()
        work = burst.Burst(args.pack, RUNS_THERE, started + 60 * args.minutes, args.device, args.smoke)
        burst.train(work, args.workers, args.first, args.skip_first, resume=args.resume)
        names = burst.archive(RUNS_THERE, args.out, limit=args.keep, new_only=True)
        print(json.dumps({"wall_s": round(time.time() - started, 1), "archived": names}))
    elif args.verb == "fetch":
        names = burst.archive(
            RUNS_THERE, args.out, skip=args.skip_first, limit=FILES_BACK, new_only=not args.again
        )
        print(json.dumps({"archived": names}))
    else:
        for name, outcome in burst.finish(args.runs, args.results).items():
            print(f"{name}: {outcome}")


if __name__ == "__main__":
    main()
