"""The training campaign of the protocol (``ftin/protocol.py``, docs/results/protocol.md): every job,
two at a time, one thread each, resumable across sessions.

    python scripts/campaign.py start  [--data ../shared/data] [--runs runs/campaign] [--hold MODEL,...]
    python scripts/campaign.py run --resume [--parallel 2]     # (re)start the scheduler
    python scripts/campaign.py status                           # jobs done / running / left
    python scripts/campaign.py refresh-code [--release]         # new jobs run on git HEAD from now
    python scripts/campaign.py pin JOB... [--restart]           # these jobs run on git HEAD (rerun)
    python scripts/campaign.py collect --checkpoints checkpoints --results docs/results/campaign

``start`` freezes the code: it copies ``ftin/`` and this script from git ``HEAD`` into
``<runs>/code-<commit>/`` and every job of the campaign runs on that copy (``PYTHONPATH``), so work
on the working tree never changes a running or resumed job. A job records the copy it started on
(``code.txt``) and always resumes on it; ``refresh-code`` freezes a newer ``HEAD`` for jobs not yet
started (only while the resume-state format is unchanged), and ``--hold`` keeps some models' jobs
from starting until ``refresh-code --release`` (code they need has not landed yet). ``pin`` moves
named jobs alone onto ``HEAD`` (a fix to one model's training), rerunning them with ``--restart``
and keeping the superseded run beside them.

A job's folder holds the run (``ftin train``'s config, resume state, history, best checkpoint),
``log.txt``, ``eval.json`` (its best checkpoint on the validation and test parts, ground-truth
and device orientation, plus the stand-still baseline) and ``done.json`` once finished. Killing
the scheduler (or the session ending) stops the jobs at their next step; ``run --resume``
continues each from its last resume state (written every few minutes), so at most a few minutes
of a job are repeated.

FTIN's TDL variant is chosen once both variants' seed-0 runs on OxIOD and RIDI are done: the one
with the lower geometric-mean validation MSE over the two datasets (validation only); seeds 1-2, the
pedestrian model and the simulator model then use it.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tarfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
STATE_FILE = "campaign.json"
SIM_TRAIN_WALKS = 48
SIM_VAL_WALKS = 4


# --- campaign folder ------------------------------------------------------------------------------


def load_state(runs: Path) -> dict[str, Any]:
    path = runs / STATE_FILE
    if not path.exists():
        sys.exit(f"error: {runs} holds no campaign (no {STATE_FILE}); run `campaign.py start` first")
    return json.loads(path.read_text())


def save_state(runs: Path, state: dict[str, Any]) -> None:
    tmp = runs / (STATE_FILE + ".tmp")
    tmp.write_text(json.dumps(state, indent=2) + "\n")
    os.replace(tmp, runs / STATE_FILE)


def freeze_code(runs: Path) -> tuple[str, Path]:
    """Copy ``ftin/`` and this script from git ``HEAD`` into ``<runs>/code-<commit>``."""
    commit = subprocess.run(
        ["git", "-C", str(REPO), "rev-parse", "HEAD"], capture_output=True, text=True, check=True
    ).stdout.strip()
    code = runs / f"code-{commit[:10]}"
    if code.exists():
        return commit, code
    archive = subprocess.run(
        ["git", "-C", str(REPO), "archive", "--format=tar", commit, "ftin", "scripts/campaign.py"],
        capture_output=True,
        check=True,
    ).stdout
    tmp = runs / f".code-{commit[:10]}.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(tmp, filter="data")
    os.replace(tmp, code)
    return commit, code


def start(args: argparse.Namespace) -> None:
    runs: Path = args.runs
    if (runs / STATE_FILE).exists():
        sys.exit(f"error: {runs} already holds a campaign; continue it with `run --resume`")
    runs.mkdir(parents=True, exist_ok=True)
    commit, code = freeze_code(runs)
    state = {
        "commit": commit,
        "code": code.name,
        "codes": [{"code": code.name, "commit": commit, "since": time.strftime("%Y-%m-%d %H:%M:%S")}],
        "data_root": str(Path(args.data).resolve()),
        "created": time.strftime("%Y-%m-%d %H:%M:%S"),
        "ftin_variant": None,
        "hold": [m for m in (args.hold or "").split(",") if m],
    }
    save_state(runs, state)
    print(f"campaign in {runs}: code frozen at {commit[:10]} ({code}); now `run --resume`")


def refresh_code(args: argparse.Namespace) -> None:
    runs: Path = args.runs
    state = load_state(runs)
    commit, code = freeze_code(runs)
    if code.name != state["code"]:
        state["code"], state["commit"] = code.name, commit
        state.setdefault("codes", []).append(
            {"code": code.name, "commit": commit, "since": time.strftime("%Y-%m-%d %H:%M:%S")}
        )
    if args.release:
        state["hold"] = []
    save_state(runs, state)
    print(f"jobs not yet started will run on {code.name}; held models: {state.get('hold') or 'none'}")


def pin(args: argparse.Namespace) -> None:
    """Run the named jobs on git HEAD's code from now on (a fix that concerns those models only),
    leaving every other job's code as it is. A job that has already started is moved aside to
    ``<job>.superseded-<time>`` (``--restart``) and runs again from the start."""
    runs: Path = args.runs
    state = load_state(runs)
    known = {job.name for job in all_jobs(state)}
    unknown = [name for name in args.jobs if name not in known]
    if unknown:
        sys.exit(f"error: no such job(s): {', '.join(unknown)} (see `status`)")
    started = [name for name in args.jobs if any((runs / name).glob("*.safetensors"))]
    if started and not args.restart:
        sys.exit(f"error: {', '.join(started)} already ran; pass --restart to move them aside and rerun")
    commit, code = freeze_code(runs)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for name in args.jobs:
        folder = runs / name
        fresh = folder.with_name(f".{folder.name}.pinned")  # code.txt in place before the scheduler looks
        shutil.rmtree(fresh, ignore_errors=True)
        fresh.mkdir(parents=True)
        (fresh / "code.txt").write_text(code.name + "\n")
        if folder.exists():
            folder.rename(folder.with_name(f"{folder.name}.superseded-{stamp}"))
        fresh.rename(folder)
        pinned = {"job": name, "code": code.name, "commit": commit, "since": stamp}
        state.setdefault("pinned", []).append(pinned)
        print(f"{name}: runs on {code.name} from now on")
    save_state(runs, state)


def job_code(runs: Path, state: dict[str, Any], name: str) -> Path:
    """The frozen code a job runs on: the one it started with, else the current one (recorded)."""
    marker = runs / name / "code.txt"
    if marker.exists():
        return runs / marker.read_text().strip()
    marker.parent.mkdir(parents=True, exist_ok=True)
    marker.write_text(state["code"] + "\n")
    return runs / state["code"]


# --- the job list -----------------------------------------------------------------------------------


def all_jobs(state: dict[str, Any]) -> list[Any]:
    from ftin import protocol

    jobs = protocol.campaign_jobs(state.get("ftin_variant"))
    if state.get("ftin_variant") is not None:  # the bundled samples' model, right after the pedestrian one
        after = next(i for i, j in enumerate(jobs) if j.dataset == protocol.PEDESTRIAN) + 1
        jobs.insert(after, sim_job(state["ftin_variant"]))
    return jobs


def sim_job(variant: str) -> Any:
    from ftin import protocol

    options = protocol.model_options("ftin", protocol.SIM)
    options["model_kwargs"] = dict(protocol.FTIN_VARIANTS[variant])
    return protocol.Job(f"sim/ftin-{variant}-s0", "ftin", protocol.SIM, 0, variant, options)


def job_config(job: Any, state: dict[str, Any], runs: Path) -> dict[str, Any]:
    from ftin import protocol

    if job.dataset == protocol.SIM:
        sim = runs / "sim-data"
        return {
            **protocol.COMMON,
            **job.options,
            "model": job.model,
            "seed": job.seed,
            "name": job.checkpoint_stem,
            "orientation": None,
            "data": [str(sim / "train")],
            "val": [str(sim / "val")],
        }
    return job.config(Path(state["data_root"]))


def is_done(runs: Path, job: Any) -> bool:
    return (runs / job.name / "done.json").exists()


def choose_variant(runs: Path, state: dict[str, Any]) -> str | None:
    """The FTIN variant with the lower geometric-mean best validation MSE over OxIOD and RIDI."""
    from ftin import protocol

    scores: dict[str, float] = {}
    for variant in protocol.FTIN_VARIANTS:
        logs = []
        for dataset in (protocol.OXIOD, protocol.RIDI):
            done = runs / dataset / f"ftin-{variant}-s0" / "done.json"
            if not done.exists():
                return None
            logs.append(math.log(json.loads(done.read_text())["best_val_mse"]))
        scores[variant] = sum(logs) / len(logs)
    chosen = min(scores, key=scores.get)
    state["ftin_variant"] = chosen
    state["ftin_variant_scores"] = {k: math.exp(v) for k, v in scores.items()}
    save_state(runs, state)
    print(
        f"FTIN variant chosen on validation: {chosen} (geometric-mean val MSE {state['ftin_variant_scores']})"
    )
    return chosen


# --- scheduler --------------------------------------------------------------------------------------


def run(args: argparse.Namespace) -> None:
    runs: Path = args.runs
    state = load_state(runs)
    if not args.resume:
        sys.exit("error: pass --resume to (re)start the campaign's scheduler")
    running: dict[str, subprocess.Popen] = {}
    stopping = {"now": False}

    def stop(signum: int, _frame: Any) -> None:
        stopping["now"] = True
        for proc in running.values():
            proc.send_signal(signal.SIGTERM)

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    while True:
        for name, proc in list(running.items()):
            if proc.poll() is not None:
                print(f"{time.strftime('%H:%M:%S')} {name}: exit {proc.returncode}", flush=True)
                del running[name]
        if stopping["now"]:
            if not running:
                return
            time.sleep(1)
            continue
        state = load_state(runs)  # refresh-code may have changed it
        if state.get("ftin_variant") is None:
            choose_variant(runs, state)
        jobs = [j for j in all_jobs(state) if j.model not in state.get("hold", [])]
        failed = [j.name for j in jobs if (runs / j.name / "failed.json").exists()]
        pending = [j for j in jobs if not is_done(runs, j) and j.name not in running and j.name not in failed]
        if not pending and not running:
            print(f"campaign finished; failed: {', '.join(failed) or 'none'}", flush=True)
            return
        while pending and len(running) < args.parallel:
            job = pending.pop(0)
            (runs / job.name).mkdir(parents=True, exist_ok=True)
            log = open(runs / job.name / "log.txt", "a")  # noqa: SIM115 - handed to the child
            code = job_code(runs, state, job.name).resolve()
            env = {**os.environ, "PYTHONPATH": str(code), "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
            script = code / "scripts" / "campaign.py"
            running[job.name] = subprocess.Popen(
                [sys.executable, str(script), "job", job.name, "--runs", str(runs)],
                env=env,
                stdout=log,
                stderr=subprocess.STDOUT,
                cwd=str(REPO),
            )
            print(f"{time.strftime('%H:%M:%S')} {job.name}: started", flush=True)
        time.sleep(5)


# --- one job (runs on the frozen code) -----------------------------------------------------------


def run_job(args: argparse.Namespace) -> None:
    import torch

    from ftin.train.config import TrainConfig
    from ftin.train.loop import run_training
    from ftin.train.state import RESUME_FILE

    torch.set_num_threads(1)
    runs: Path = args.runs
    state = load_state(runs)
    job = next((j for j in all_jobs(state) if j.name == args.name), None)
    if job is None:
        sys.exit(f"error: no job {args.name!r} in this campaign")
    out = runs / job.name
    if job.dataset == "sim":
        make_sim_data(runs)
    config = TrainConfig(out_dir=str(out), **job_config(job, state, runs))
    resume = (out / RESUME_FILE).exists()
    print(
        f"{time.strftime('%Y-%m-%d %H:%M:%S')} {job.name}: {'resuming' if resume else 'starting'}", flush=True
    )
    try:
        result = run_training(config, resume=resume, progress=False)
    except Exception as exc:  # record it, so the scheduler goes on with the other jobs
        (out / "failed.json").write_text(json.dumps({"error": repr(exc)}) + "\n")
        raise
    print(f"{job.name}: {result.stop_reason} after {result.epochs_done} epochs", flush=True)
    if not result.finished:
        return  # stopped by a signal: the scheduler resumes it later
    evaluation = evaluate_job(job, state, runs, result.checkpoint)
    (out / "eval.json").write_text(json.dumps(evaluation, indent=1) + "\n")
    done = {
        "job": job.name,
        "model": job.model,
        "dataset": job.dataset,
        "seed": job.seed,
        "variant": job.variant,
        "stop_reason": result.stop_reason,
        "epochs": result.epochs_done,
        "steps": result.steps,
        "best_val_mse": result.best_val_loss,
        "best_epoch": max((r["epoch"] for r in result.history if r["best"]), default=None),
        "lr_decays": sum(
            1 for a, b in zip(result.history, result.history[1:], strict=False) if b["lr"] < a["lr"]
        ),
        "wall_time_s": result.history[-1]["elapsed_s"] if result.history else None,
        "finished": time.strftime("%Y-%m-%d %H:%M:%S"),
    }
    (out / "done.json").write_text(json.dumps(done, indent=1) + "\n")


def make_sim_data(runs: Path) -> None:
    """Simulated walks with seeds disjoint from the app's bundled samples (created once)."""
    sim = runs / "sim-data"
    for part, count, seed in (("train", SIM_TRAIN_WALKS, 1000), ("val", SIM_VAL_WALKS, 5000)):
        if (sim / part / ".complete").exists():
            continue
        shutil.rmtree(sim / part, ignore_errors=True)
        subprocess.run(
            [
                sys.executable,
                "-m",
                "ftin",
                "sim",
                "--out",
                str(sim / part),
                "--count",
                str(count),
                "--duration-s",
                "120",
                "--seed",
                str(seed),
            ],
            check=True,
        )
        (sim / part / ".complete").write_text("")


def evaluate_job(job: Any, state: dict[str, Any], runs: Path, checkpoint: Path) -> dict[str, Any]:
    """Per-sequence metrics of the best checkpoint on val and test, both orientation sources."""
    from ftin import protocol
    from ftin.checkpoint import load_model
    from ftin.data.loading import load_sequences
    from ftin.evaluate import evaluate_checkpoint
    from ftin.metrics import Convention, evaluate_trajectory, stand_still

    loaded = load_model(checkpoint)
    result: dict[str, Any] = {
        "checkpoint": str(checkpoint),
        "convention": Convention.RONIN.value,
        "parts": {},
    }
    if job.dataset == protocol.SIM:
        sets = {
            ("sim", "val"): [runs / "sim-data" / "val"],
            ("sim", "test"): [REPO / "ftin" / "sim" / "samples"],
        }
        orientations: tuple[str | None, ...] = (None,)
    else:
        datasets = (protocol.OXIOD, protocol.RIDI) if job.dataset == protocol.PEDESTRIAN else (job.dataset,)
        root = Path(state["data_root"])
        sets = {(d, part): protocol.split_paths(root, d, part) for d in datasets for part in ("val", "test")}
        orientations = ("ground_truth", "device")
    for (dataset, part), paths in sets.items():
        for orientation in orientations:
            sequences = load_sequences(paths, "--data", orientation)
            report = evaluate_checkpoint(loaded, sequences, Convention.RONIN)
            rows = []
            for seq, res in zip(sequences, report.sequences, strict=True):
                still = evaluate_trajectory(stand_still(seq.gt), seq.gt, Convention.RONIN)
                rows.append(
                    {
                        "name": res.name,
                        "duration_s": res.duration_s,
                        **res.metrics.as_dict(),
                        "stand_still": dict(still.values),  # every registered metric of never moving
                    }
                )
            key = f"{dataset}/{part}/{orientation or 'ground_truth'}"
            result["parts"][key] = rows
    return result


# --- status and collection ---------------------------------------------------------------------------


def status(args: argparse.Namespace) -> None:
    runs: Path = args.runs
    state = load_state(runs)
    jobs = all_jobs(state)
    done = [j for j in jobs if is_done(runs, j)]
    failed = [j for j in jobs if (runs / j.name / "failed.json").exists()]
    started = [j for j in jobs if (runs / j.name / "history.json").exists() and j not in done]
    variant = state.get("ftin_variant") or "not chosen yet"
    print(f"campaign {runs} (code {state['code']}), FTIN variant: {variant}")
    print(
        f"jobs: {len(done)} done, {len(started)} started, {len(failed)} failed, "
        f"{len(jobs) - len(done) - len(started)} not started (of {len(jobs)} known now)"
    )
    for job in jobs:
        folder = runs / job.name
        line = f"  {job.name:34s}"
        if is_done(runs, job):
            d = json.loads((folder / "done.json").read_text())
            line += (
                f" done     {d['epochs']:3d} ep  best val {d['best_val_mse']:.5f} @ {d['best_epoch']}"
                f"  lr decays {d['lr_decays']}  {d['stop_reason']}  {d['wall_time_s'] / 60:.0f} min"
            )
        elif (folder / "history.json").exists():
            hist = json.loads((folder / "history.json").read_text())
            best = min(h["val_mse"] for h in hist)
            line += f" started  {len(hist):3d} ep  best val {best:.5f}  {hist[-1]['elapsed_s'] / 60:.0f} min"
        else:
            line += " -"
        print(line)


def validation_gate(record: dict[str, Any]) -> dict[str, Any]:
    """Whether a run may be hosted, from its validation recordings (ground-truth orientation): it must
    walk about the right distance (mean path ratio 0.8-1.25) and beat a predictor that never moves
    (mean ATE below the stand-still ATE). ``refused`` names the rule it broke, else None."""
    rows = [
        row
        for key, part in record["evaluation"]["parts"].items()
        if key.split("/")[1] == "val" and key.endswith("ground_truth")
        for row in part
    ]
    ratios = [row["path_length_ratio"] for row in rows if row["path_length_ratio"] is not None]
    ratio = sum(ratios) / len(ratios) if ratios else None
    ate = sum(row["ate"] for row in rows) / len(rows) if rows else None
    still = sum(row["stand_still"]["ate"] for row in rows) / len(rows) if rows else None
    refused = None
    if ratio is None or not 0.8 <= ratio <= 1.25:
        refused = "validation path ratio outside 0.8-1.25"
    elif ate is None or still is None or ate >= still:
        refused = "validation ATE not below standing still"
    return {
        "val_path_length_ratio": ratio,
        "val_ate_m": ate,
        "val_stand_still_ate_m": still,
        "refused": refused,
    }


def withdraw(checkpoints: Path, stem: str) -> None:
    """Remove an earlier checkpoint of ``stem``: a model whose campaign run fails the validation gate
    is not hosted, and neither is the older one it was to replace."""
    for suffix in (".safetensors", ".json", ".md"):
        old = checkpoints / (stem + suffix)
        if old.exists():
            old.unlink()
            print(f"withdrawn: {old} (its campaign run failed the validation gate)", file=sys.stderr)


def collect(args: argparse.Namespace) -> None:
    """Per-job results (committable JSON) and the shipped checkpoints: per (model, dataset) the
    seed with the best validation MSE, if it passes ``validation_gate`` (else an earlier checkpoint
    of that name is withdrawn)."""
    runs: Path = args.runs
    state = load_state(runs)
    results_dir: Path = args.results
    results_dir.mkdir(parents=True, exist_ok=True)
    if args.checkpoints is not None:
        args.checkpoints.mkdir(parents=True, exist_ok=True)
    best: dict[str, tuple[float, Any, dict[str, Any]]] = {}
    seeds: dict[str, list[dict[str, Any]]] = {}
    only = set(args.only.split(",")) if args.only else None
    for job in all_jobs(state):
        if not is_done(runs, job) or (only is not None and job.checkpoint_stem not in only):
            continue
        folder = runs / job.name
        record = {
            "training": json.loads((folder / "done.json").read_text()),
            "history": json.loads((folder / "history.json").read_text()),
            "evaluation": json.loads((folder / "eval.json").read_text()),
        }
        target = results_dir / (job.name.replace("/", "__") + ".json")
        target.write_text(json.dumps(record, indent=1) + "\n")
        if job.model == "ftin" and job.variant != state.get("ftin_variant"):
            continue
        val = record["training"]["best_val_mse"]
        stem = job.checkpoint_stem
        seeds.setdefault(stem, []).append(record)
        if stem not in best or val < best[stem][0]:
            best[stem] = (val, job, record)
    manifest = {
        "campaign_commit": state["commit"],
        "ftin_variant": state.get("ftin_variant"),
        "shipped": {},
        "not_shipped": {},
    }
    for stem, (val, job, record) in sorted(best.items()):
        gate = validation_gate(record)
        if gate["refused"]:
            manifest["not_shipped"][stem] = {"job": job.name, **gate}
            if args.checkpoints is not None:
                withdraw(args.checkpoints, stem)
            continue
        manifest["shipped"][stem] = {"job": job.name, "val_mse": val, **gate}
        if args.checkpoints is not None:
            from ftin.train.model_card import render_campaign_card

            for suffix in (".safetensors", ".json"):
                shutil.copy2(runs / job.name / (stem + suffix), args.checkpoints / (stem + suffix))
            meta = json.loads((runs / job.name / (stem + ".json")).read_text())
            card = render_campaign_card(meta, record, seeds[stem], state.get("ftin_variant"))
            (args.checkpoints / (stem + ".md")).write_text(card)
    (results_dir / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")
    print(json.dumps(manifest, indent=1))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--runs", type=Path, default=REPO / "runs" / "campaign")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("start", help="freeze the code and create the campaign folder")
    p.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data")
    p.add_argument("--hold", help="comma-separated models whose jobs wait for refresh-code --release")
    p = sub.add_parser("refresh-code", help="jobs not yet started run on git HEAD from now on")
    p.add_argument("--release", action="store_true", help="also release every held model")
    p = sub.add_parser("run", help="run the scheduler (jobs two at a time)")
    p.add_argument("--resume", action="store_true", help="required: continue the campaign in --runs")
    p.add_argument("--parallel", type=int, default=2)
    sub.add_parser("status", help="jobs done, running, left")
    p = sub.add_parser("pin", help="run the named jobs on git HEAD (a fix for those models only)")
    p.add_argument("jobs", nargs="+", help="job names as `status` lists them, e.g. oxiod/tlio-s0")
    p.add_argument("--restart", action="store_true", help="move jobs that already ran aside; rerun them")
    p = sub.add_parser("job", help="(internal) train and evaluate one job on the frozen code")
    p.add_argument("name")
    p = sub.add_parser("collect", help="per-job results JSON and the shipped checkpoints")
    p.add_argument(
        "--results",
        type=Path,
        default=REPO / "docs" / "results" / "campaign",
        help="folder for the per-job records and manifest.json (default: docs/results/campaign)",
    )
    p.add_argument(
        "--checkpoints",
        type=Path,
        default=None,
        help="also ship: copy each gate-passing best-validation seed here with its model card, and "
        "withdraw the refused names (default: ship nothing)",
    )
    p.add_argument(
        "--only",
        help="comma-separated checkpoint stems (e.g. ftin-pedestrian,ftin-sim): ship only these, "
        "for groups whose jobs are all done while the rest of the campaign runs",
    )
    for p in sub.choices.values():
        p.add_argument("--runs", type=Path, default=argparse.SUPPRESS)
    args = parser.parse_args()
    args.runs = Path(args.runs).resolve()
    commands = {
        "start": start,
        "run": run,
        "status": status,
        "job": run_job,
        "collect": collect,
        "refresh-code": refresh_code,
        "pin": pin,
    }
    commands[args.command](args)


if __name__ == "__main__":
    main()
