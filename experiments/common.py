"""What the probes share: their command line (options, one torch thread), the recordings they score,
stage one's checkpoints they reload, and the markdown table they write.

Probes are run from the repository root as modules (``python -m experiments.<probe>``), so they import
this as ``experiments.common`` and the library as ``ftin``.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable
from pathlib import Path

import torch

from ftin import protocol
from ftin.campaign.folder import Campaign
from ftin.files import DEFAULT_DATA_ROOT


def argument_parser(doc: str) -> argparse.ArgumentParser:
    """A probe's parser, its ``--help`` the module docstring as written."""
    return argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)


def add_checkpoint_options(parser: argparse.ArgumentParser, stride: int, checkpoint_help: str) -> None:
    """``--checkpoint`` (repeatable), ``--data-root``, ``--stride`` and ``--out``: the window probes'."""
    parser.add_argument("--checkpoint", action="append", required=True, help=checkpoint_help)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--stride", type=int, default=stride, help="samples between probed windows")
    parser.add_argument("--out", type=Path, default=None, help="markdown table (default: print only)")


def parse(parser: argparse.ArgumentParser) -> argparse.Namespace:
    """The arguments; torch on one thread (a probe shares the machine, and numbers stay comparable)."""
    args = parser.parse_args()
    torch.set_num_threads(1)
    return args


def hidden_walk_paths(data_root: Path, dataset: str, fold: int | None = None) -> list[Path]:
    """Recordings that decide nothing else and that the shipped checkpoints never trained on: the
    validation part of OxIOD and RIDI, every Inria walk outside its test part; with ``fold`` (a
    checkpoint of the generalisation campaign's walker fold) that fold's held-out walkers."""
    if fold is not None:
        return protocol.split_paths(data_root, dataset, "val", fold)
    parts = ("train", "val") if dataset == protocol.INRIA else ("val",)
    return [p for part in parts for p in protocol.split_paths(data_root, dataset, part)]


def arm_of(job: protocol.Job) -> str:
    """A stage-one job's arm: its name's last part without the seed (``ronin_resnet-mirror``)."""
    return re.sub(r"-s\d+$", "", job.name.split("/")[-1])


def job_checkpoints(
    campaign: Campaign, keep: Callable[[protocol.Job], bool]
) -> list[tuple[protocol.Job, Path]]:
    """The jobs of ``campaign`` that ``keep`` keeps and whose checkpoint is still on disk (runs/ is lost
    with its machine; the committed records keep no weights), each with that checkpoint."""
    found = []
    for job in filter(keep, campaign.jobs()):
        checkpoint = campaign.job_dir(job) / f"{job.checkpoint_stem}.safetensors"
        if checkpoint.exists():
            found.append((job, checkpoint))
        else:
            print(f"{job.name}: no checkpoint on disk, skipped")
    return found


def write_report(out: Path | None, lines: list[str], echo: bool = True) -> None:
    """The report's lines as one markdown file at ``out`` (when given), printed unless ``echo`` is off."""
    text = "\n".join(lines) + "\n"
    if echo:
        print(text)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text, encoding="utf-8")
        print(f"wrote {out}")


def weights_key(loaded) -> str:
    """A checkpoint's weights in a cache key (the card's sha256, 12 digits): a probe's cache keyed by
    the checkpoint's name alone would serve a retrained checkpoint its predecessor's rows."""
    return str(loaded.meta.get("weights_sha256", "unknown"))[:12]
