"""One training loop for every registered model (design §3, "Training").

``train(config, train_sequences, val_sequences)`` runs in one process or, under ``torchrun``, in
several (DistributedDataParallel on gloo for CPU). ``run_training(config)`` first reads the data
the config names. The run folder ``config.out_dir`` holds:

- ``config.json``: the resolved ``TrainConfig`` (rate, window and out_dim filled in);
- ``<name>.safetensors`` + ``<name>.json``: the best checkpoint (lowest validation MSE);
- ``resume.safetensors``: model, optimizer, scheduler, RNG states and progress (``ftin.train.state``);
- ``history.json``: one record per finished epoch.

Decisions:
- Data order: ``DistributedSampler`` (also with one process) seeded by ``config.seed`` and the
  epoch, plus per-window yaw angles drawn from ``(seed, epoch)``; with the torch/numpy/Python RNG
  states in the resume state, a run stopped after any step and resumed reaches the same weights
  as an uninterrupted run (in one process; under DDP every rank restores rank 0's RNG state).
- ``batch_size`` is the global batch: each of N processes takes ``ceil(batch_size / N)``.
- ``max_minutes`` is per invocation (a CPU budget); ``max_steps`` counts optimizer steps over the
  whole run. Either stops the run after the current step and writes the resume state; ``--resume``
  continues it. SIGINT/SIGTERM do the same at the next step boundary.
- Parts and losses (``ftin.models.base``, ``ftin.train.losses``): the dataset yields per-part
  targets ``(B, K, D)``, K = ``model.target_parts(window)``; the model's ``forward_parts`` is trained
  with the loss its family's reference uses (``model.train_loss``): window models with MSE / NLL as
  before, RNIN with its displacement + 8 x cumulative loss, RoNIN LSTM / TCN with the cumulative-
  position loss over chunks of ``window`` frames (the reference's ``--window 400 --stride 100``).
- Validation stays comparable across every model: the MSE of 1 s mean velocities. K = 1 models are
  compared on their window's velocity, as before; multi-part models average predicted and target
  part velocities over blocks of ``round(imu_rate_hz)`` frames (``validation_blocks``: RNIN's 1 s
  sub-windows are blocks of one part, a per-frame model's 400-frame chunk at 200 Hz two blocks).
- The scheduler and the best checkpoint follow the validation velocity MSE (training MSE without
  validation data); training ends when the learning rate falls below ``min_lr`` or after
  ``max_epochs``. When a run stops before any epoch ends, its current weights are written as the
  checkpoint (``metrics.partial = true``) so that a budget run always leaves something to load.
"""

from __future__ import annotations

import inspect
import json
import math
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.distributed as dist
from torch.utils.data.distributed import DistributedSampler
from tqdm import tqdm

from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence
from ftin.data.windows import InputNormalization, WindowDataset, fit_normalization
from ftin.models import create_model
from ftin.models.base import VelocityModel, VelocityOutput
from ftin.train.checkpoint import atomic_write_text, save_checkpoint, to_json_safe
from ftin.train.config import BUDGET_FIELDS, ConfigError, LossKind, TrainConfig
from ftin.train.losses import LossFn, make_loss
from ftin.train.losses import velocity_loss as velocity_loss  # re-exported: ftin.bench and tests use it
from ftin.train.state import load_training_state, restore_rng, save_training_state

CONFIG_FILE = "config.json"
RESUME_FILE = "resume.safetensors"
HISTORY_FILE = "history.json"


@dataclass
class TrainResult:
    out_dir: Path
    checkpoint: Path | None  # weights of the best checkpoint
    epochs_done: int
    steps: int
    best_val_loss: float | None
    stop_reason: str  # "max_epochs", "min_lr", "early_stop", "max_minutes", "max_steps", "signal", "finished"
    history: list[dict[str, Any]] = field(default_factory=list)

    @property
    def finished(self) -> bool:
        return self.stop_reason in ("max_epochs", "min_lr", "early_stop", "finished")


# --- data -----------------------------------------------------------------------------------------


def load_sequences(
    paths: Sequence[str | Path], option: str = "--data", orientation: str | None = None
) -> list[ImuSequence]:
    """Every sequence in ``paths``: a folder is searched with ``list_sequences``, a file read directly.

    ``orientation`` (``"ground_truth"`` or ``"device"``) goes to the readers that offer that choice
    (OxIOD, RIDI); the others keep their own.
    """
    from ftin.data.readers import READERS, detect_format, list_sequences, read_sequence

    def read(ref_or_path: Any, fmt: str | None) -> ImuSequence:
        takes = fmt is not None and "orientation" in inspect.signature(READERS[fmt].read).parameters
        options = {"orientation": orientation} if orientation is not None and takes else {}
        return read_sequence(ref_or_path, **options)

    sequences: list[ImuSequence] = []
    for raw in paths:
        path = Path(raw).expanduser()
        if not path.exists():
            raise DataFormatError(f"{option} {raw}: no such file or folder")
        fmt = detect_format(path)
        if path.is_dir() and fmt is None:
            refs = list_sequences(path)
            if not refs:
                raise DataFormatError(f"{option} {raw}: no recognised sequences in this folder")
            sequences.extend(read(ref, ref.format) for ref in refs)
        else:
            sequences.append(read(path, fmt))
    if not sequences:
        raise DataFormatError(f"{option}: no sequences given")
    return sequences


def prepare_sequence(seq: ImuSequence, rate_hz: float) -> ImuSequence:
    """Orientation (estimated when missing), then the uniform ``rate_hz`` grid the windows assume."""
    from ftin.data.preprocess import ensure_orientation, resample

    return resample(ensure_orientation(seq), rate_hz)


def data_rate_hz(sequences: Sequence[ImuSequence]) -> float:
    """Median rate of the sequences, rounded to 1 Hz (the default ``imu_rate_hz``)."""
    return float(round(float(np.median([seq.rate_hz for seq in sequences]))))


def split_validation(
    sequences: Sequence[ImuSequence], fraction: float, seed: int
) -> tuple[list[ImuSequence], list[ImuSequence]]:
    """Hold out a seeded ``fraction`` of whole sequences (at least one when there are two or more)."""
    n = len(sequences)
    if n < 2 or fraction <= 0:
        return list(sequences), []
    n_val = min(n - 1, max(1, round(fraction * n)))
    order = np.random.default_rng(seed).permutation(n)
    held_out = set(order[:n_val].tolist())
    train = [s for i, s in enumerate(sequences) if i not in held_out]
    val = [s for i, s in enumerate(sequences) if i in held_out]
    return train, val


def build_model(name: str, window: int, out_dim: int | None, model_kwargs: dict[str, Any]) -> VelocityModel:
    """``create_model`` with ``window`` and ``out_dim`` passed to the models whose config has them.

    The model's own ``config`` tells which keys it takes (RoNIN's LSTM has no ``window``, say); a key
    the user set in ``model_kwargs`` wins.
    """
    probe = create_model(name, **model_kwargs)
    overrides = {"window": window, "out_dim": out_dim}
    extra = {
        key: value
        for key, value in overrides.items()
        if value is not None and key not in model_kwargs and probe.config.get(key, value) != value
    }
    return create_model(name, **model_kwargs, **extra) if extra else probe


# --- parts -----------------------------------------------------------------------------------------


class PartsForward(torch.nn.Module):
    """``model.forward_parts`` as a module's ``forward``, so that DistributedDataParallel (which
    synchronises gradients only for calls of the module it wraps) can wrap it."""

    def __init__(self, model: VelocityModel) -> None:
        super().__init__()
        self.model = model

    def forward(self, x: torch.Tensor) -> VelocityOutput:
        return self.model.forward_parts(x)  # velocity (B, K, D)


def validation_blocks(window: int, parts: int, rate_hz: float) -> int:
    """How many consecutive parts make one ~1 s validation block (module docstring).

    A part lasts ``window / parts`` frames; a block is ``round(rate_hz)`` frames, rounded to whole
    parts, at least one part and at most the whole window (a window shorter than 1 s is one block).
    Parts left over after the last whole block are not scored.
    """
    part_frames = window // parts
    return int(min(parts, max(1, round(round(rate_hz) / part_frames))))


def block_means(velocity: torch.Tensor, per_block: int) -> torch.Tensor:
    """``(B, K, D) -> (B, K // per_block, D)``: mean over consecutive blocks of ``per_block`` parts."""
    batch, parts, dim = velocity.shape
    blocks = parts // per_block
    return velocity[:, : blocks * per_block].reshape(batch, blocks, per_block, dim).mean(dim=2)


# --- distributed ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Dist:
    rank: int = 0
    world: int = 1
    owns_group: bool = False

    @property
    def main(self) -> bool:
        return self.rank == 0

    def sum(self, *values: float) -> list[float]:
        if self.world == 1:
            return list(values)
        tensor = torch.tensor(values, dtype=torch.float64)
        dist.all_reduce(tensor, op=dist.ReduceOp.SUM)
        return tensor.tolist()

    def any(self, flag: bool) -> bool:
        if self.world == 1:
            return flag
        tensor = torch.tensor([1 if flag else 0], dtype=torch.int64)
        dist.all_reduce(tensor, op=dist.ReduceOp.MAX)
        return bool(tensor.item())


def _init_distributed() -> _Dist:
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world <= 1:
        return _Dist()
    owns = not dist.is_initialized()
    if owns:
        dist.init_process_group(backend="gloo")
    return _Dist(rank=dist.get_rank(), world=dist.get_world_size(), owns_group=owns)


@contextmanager
def _stop_signals(flag: dict[str, bool]) -> Iterator[None]:
    """SIGINT/SIGTERM ask for a clean stop at the next step; a second SIGINT interrupts at once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, _frame: Any) -> None:
        if flag["stop"] and signum == signal.SIGINT:
            raise KeyboardInterrupt
        flag["stop"] = True

    previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


# --- the loop -------------------------------------------------------------------------------------


def run_training(config: TrainConfig, *, resume: bool = False, progress: bool = True) -> TrainResult:
    """Read the sequences ``config.data`` / ``config.val`` name, then :func:`train`."""
    train_sequences = load_sequences(config.data, "--data", config.orientation)
    val_sequences = load_sequences(config.val, "--val", config.orientation) if config.val else []
    return train(config, train_sequences, val_sequences, resume=resume, progress=progress)


def train(
    config: TrainConfig,
    train_sequences: Sequence[ImuSequence],
    val_sequences: Sequence[ImuSequence] = (),
    *,
    resume: bool = False,
    progress: bool = True,
) -> TrainResult:
    """Train ``config.model`` on the sequences; see the module docstring for files and decisions."""
    started = time.monotonic()
    ddp = _init_distributed()
    try:
        return _train(config, train_sequences, val_sequences, resume, progress, ddp, started)
    finally:
        if ddp.owns_group:
            dist.destroy_process_group()


def _train(
    config: TrainConfig,
    train_sequences: Sequence[ImuSequence],
    val_sequences: Sequence[ImuSequence],
    resume: bool,
    show_progress: bool,
    ddp: _Dist,
    started: float,
) -> TrainResult:
    out_dir = Path(config.out_dir)
    resume_path = out_dir / RESUME_FILE
    if resume and not resume_path.exists():
        raise ConfigError(f"--resume: {out_dir} has no {RESUME_FILE} to continue from")
    if not resume and resume_path.exists():
        raise ConfigError(
            f"--out {out_dir} already holds a run; pass --resume to continue it or choose another folder"
        )
    if not train_sequences:
        raise ConfigError("data: no training sequences")

    rate_hz = config.imu_rate_hz or data_rate_hz(train_sequences)
    config = config.with_(imu_rate_hz=rate_hz)
    window = config.resolved_window
    val_source = "paths" if val_sequences else "none"
    if not val_sequences:
        train_sequences, val_sequences = split_validation(train_sequences, config.val_fraction, config.seed)
        val_source = "held_out" if val_sequences else "none"
    train_sequences = [prepare_sequence(s, rate_hz) for s in train_sequences]
    val_sequences = [prepare_sequence(s, rate_hz) for s in val_sequences]

    torch.manual_seed(config.seed)
    np.random.seed(config.seed % 2**32)
    try:
        model = build_model(config.model, window, config.out_dim, config.model_kwargs)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"model {config.model!r}: {exc}") from None
    config = config.with_(window=window, out_dim=model.out_dim)
    parts = _check_model_accepts(model, config)
    use_nll = _use_nll(config, model)
    try:
        loss_fn = make_loss(model, window, rate_hz, use_nll=use_nll, log_std_range=config.log_std_range)
    except ValueError as exc:
        raise ConfigError(f"model {config.model!r} with --window {window}: {exc}") from None
    device = torch.device(config.device)
    model.to(device)

    dataset = WindowDataset(
        train_sequences,
        window,
        config.stride,
        model.out_dim,
        parts=parts,
        augment_yaw=config.augment_yaw,
        seed=config.seed,
    )
    val_dataset = (
        WindowDataset(val_sequences, window, config.stride, model.out_dim, parts=parts, augment_yaw=False)
        if val_sequences
        else None
    )
    normalization = fit_normalization(dataset.imu_per_sequence, config.normalization)
    optimizer = torch.optim.Adam(model.parameters(), lr=config.lr)
    scheduler = torch.optim.lr_scheduler.ReduceLROnPlateau(
        optimizer, mode="min", factor=config.plateau_factor, patience=config.plateau_patience
    )
    sampler = DistributedSampler(
        dataset, num_replicas=ddp.world, rank=ddp.rank, shuffle=True, seed=config.seed
    )
    local_batch = math.ceil(config.batch_size / ddp.world)

    state: dict[str, Any] = {
        "epoch": 0,
        "step_in_epoch": 0,
        "global_step": 0,
        "epoch_loss_sum": 0.0,
        "epoch_count": 0,
        "best_val_loss": None,
        "best_epoch": None,
        "elapsed_s": 0.0,
        "history": [],
        "stop_reason": None,
    }
    if resume:
        _check_resumed_config(config, out_dir)
        saved, rng = load_training_state(resume_path, model=model, optimizer=optimizer, scheduler=scheduler)
        state.update(saved)
        state["stop_reason"] = None  # budgets are per invocation; the loop re-checks epochs and lr
        restore_rng(rng)
    elif ddp.main:
        config.save(out_dir / CONFIG_FILE)
    net: torch.nn.Module = PartsForward(model)
    if ddp.world > 1:
        if not ddp.main:  # same initial weights on every rank (seeded above), then distinct dropout
            torch.manual_seed(config.seed * 1000 + ddp.rank + state["global_step"])
        # An uncertainty head trained with plain MSE gets no gradient: DDP must be told.
        unused = model.has_uncertainty and not use_nll
        net = torch.nn.parallel.DistributedDataParallel(net, find_unused_parameters=unused)

    run = _Run(
        config=config,
        model=model,
        net=net,
        optimizer=optimizer,
        scheduler=scheduler,
        dataset=dataset,
        val_dataset=val_dataset,
        normalization=normalization,
        sampler=sampler,
        local_batch=local_batch,
        use_nll=use_nll,
        loss_fn=loss_fn,
        val_per_block=validation_blocks(window, parts, rate_hz),
        device=device,
        ddp=ddp,
        state=state,
        started=started,
        elapsed_before=float(state["elapsed_s"]),
        show_progress=show_progress and ddp.main,
        data_info={
            "training_data": {"paths": list(config.data), "sequences": dataset.names},
            "split": {
                "train": dataset.names,
                "val": [] if val_dataset is None else val_dataset.names,
                "val_source": val_source,
            },
        },
    )
    return run.loop()


@dataclass
class _Run:
    """The state of one training invocation; ``loop`` runs epochs until a stop condition."""

    config: TrainConfig
    model: VelocityModel
    net: torch.nn.Module
    optimizer: torch.optim.Optimizer
    scheduler: Any
    dataset: WindowDataset
    val_dataset: WindowDataset | None
    normalization: InputNormalization
    sampler: DistributedSampler
    local_batch: int
    use_nll: bool
    loss_fn: LossFn
    val_per_block: int  # parts per ~1 s validation block (validation_blocks)
    device: torch.device
    ddp: _Dist
    state: dict[str, Any]
    started: float
    elapsed_before: float
    show_progress: bool
    data_info: dict[str, Any]

    @property
    def out_dir(self) -> Path:
        return Path(self.config.out_dir)

    def elapsed_s(self) -> float:
        return self.elapsed_before + time.monotonic() - self.started

    def loop(self) -> TrainResult:
        st, cfg = self.state, self.config
        flag = {"stop": False}
        last_save = time.monotonic()
        with _stop_signals(flag):
            while st["stop_reason"] is None:
                if st["epoch"] >= cfg.max_epochs:
                    st["stop_reason"] = "max_epochs"
                    break
                if self.optimizer.param_groups[0]["lr"] < cfg.min_lr:  # a finished run, resumed
                    st["stop_reason"] = "min_lr"
                    break
                if self._stalled():
                    st["stop_reason"] = "early_stop"
                    break
                batches = self._epoch_batches(st["epoch"])
                bar = self._progress_bar(len(batches))
                self.net.train()
                tick, windows = time.monotonic(), 0
                for b in range(st["step_in_epoch"], len(batches)):
                    reason = self._budget_stop(flag)
                    if reason:
                        st["stop_reason"] = reason
                        break
                    loss = self._step(batches[b], st["epoch"])
                    st["step_in_epoch"] += 1
                    st["global_step"] += 1
                    st["epoch_loss_sum"] += loss * len(batches[b])
                    st["epoch_count"] += len(batches[b])
                    windows += len(batches[b])
                    if bar is not None:
                        rate = windows * self.ddp.world / max(time.monotonic() - tick, 1e-9)
                        bar.set_postfix(loss=f"{loss:.4g}", win_s=f"{rate:.0f}", refresh=False)
                        bar.update(1)
                    if self.ddp.main and time.monotonic() - last_save > 60.0 * cfg.save_every_min:
                        self._save_state()
                        last_save = time.monotonic()
                if bar is not None:
                    bar.close()
                if st["stop_reason"] is not None:
                    break
                self._end_epoch()
        if self.ddp.main:
            self._save_state()
            if st["best_epoch"] is None:  # stopped before any epoch ended: keep what there is
                self._save_checkpoint(partial=True)
        stem = self.out_dir / self.config.checkpoint_name
        return TrainResult(
            out_dir=self.out_dir,
            checkpoint=stem.with_name(stem.name + ".safetensors"),
            epochs_done=st["epoch"],
            steps=st["global_step"],
            best_val_loss=st["best_val_loss"],
            stop_reason=st["stop_reason"],
            history=list(st["history"]),
        )

    # -- steps and epochs --

    def _epoch_batches(self, epoch: int) -> list[np.ndarray]:
        self.sampler.set_epoch(epoch)
        self.dataset.set_epoch(epoch)
        indices = np.fromiter(iter(self.sampler), dtype=np.int64)
        return [indices[i : i + self.local_batch] for i in range(0, len(indices), self.local_batch)]

    def _step(self, indices: np.ndarray, epoch: int) -> float:
        x, v = self.dataset.get_batch(indices)
        x = self.normalization.apply(x.to(self.device))
        v = v.to(self.device)
        output = self.net(x)  # forward_parts: velocity (B, K, D)
        warmup = epoch < self.config.nll_warmup_epochs
        loss = self.loss_fn(output, v, warmup)
        if not torch.isfinite(loss):
            raise FloatingPointError(
                f"training loss became {loss.item()} at epoch {epoch + 1}, "
                f"step {self.state['global_step'] + 1}; lower --lr or check the data"
            )
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        return float(loss.detach())

    def _stalled(self) -> bool:
        """``early_stop_patience`` epochs in a row without a new best (derived, not stored)."""
        patience, best = self.config.early_stop_patience, self.state["best_epoch"]
        return patience is not None and best is not None and self.state["epoch"] - best >= patience

    def _budget_stop(self, flag: dict[str, bool]) -> str | None:
        cfg, st = self.config, self.state
        reason = None
        if cfg.max_steps is not None and st["global_step"] >= cfg.max_steps:
            reason = "max_steps"
        elif cfg.max_minutes is not None and time.monotonic() - self.started >= 60.0 * cfg.max_minutes:
            reason = "max_minutes"
        elif flag["stop"]:
            reason = "signal"
        # Every rank must stop at the same step (time and signals differ between processes).
        if self.ddp.world > 1 and self.ddp.any(reason is not None) and reason is None:
            reason = "max_minutes" if cfg.max_minutes is not None else "signal"
        return reason

    def validation_mse(self) -> float | None:
        """Mean squared error of ~1 s mean velocities over every validation window (all ranks
        together): per window for K = 1 models, per block of parts otherwise (module docstring)."""
        if self.val_dataset is None:
            return None
        self.model.eval()
        indices = np.arange(len(self.val_dataset))[self.ddp.rank :: self.ddp.world]
        sq_sum, count = 0.0, 0
        with torch.inference_mode():
            for i in range(0, len(indices), self.local_batch):
                x, v = self.val_dataset.get_batch(indices[i : i + self.local_batch])
                pred = self.model.forward_parts(self.normalization.apply(x.to(self.device))).velocity
                pred = block_means(pred, self.val_per_block)  # (B, blocks, D)
                target = block_means(v.to(self.device), self.val_per_block)
                sq_sum += float(((pred - target) ** 2).sum())
                count += target.numel()
        sq_sum, count = self.ddp.sum(sq_sum, count)
        return sq_sum / max(count, 1)

    def _end_epoch(self) -> None:
        st, cfg = self.state, self.config
        loss_sum, count = self.ddp.sum(st["epoch_loss_sum"], st["epoch_count"])
        train_loss = loss_sum / max(count, 1)
        val_loss = self.validation_mse()
        # Without validation the training loss monitors the plateau (MSE unless the model uses NLL).
        monitored = val_loss if val_loss is not None else train_loss
        self.scheduler.step(monitored)
        lr = self.optimizer.param_groups[0]["lr"]
        improved = st["best_val_loss"] is None or monitored < st["best_val_loss"]
        record = {
            "epoch": st["epoch"] + 1,
            "train_loss": train_loss,
            "val_mse": val_loss,
            "lr": lr,
            "steps": st["global_step"],
            "elapsed_s": self.elapsed_s(),
            "best": improved,
        }
        st["history"].append(record)
        st["epoch"] += 1
        st["step_in_epoch"] = 0
        st["epoch_loss_sum"], st["epoch_count"] = 0.0, 0
        if improved:
            st["best_val_loss"], st["best_epoch"] = monitored, st["epoch"]
        if lr < cfg.min_lr:
            st["stop_reason"] = "min_lr"
        elif self._stalled():
            st["stop_reason"] = "early_stop"
        if self.ddp.main:
            if improved:
                self._save_checkpoint(partial=False)
            self._save_state()
            atomic_write_text(self.out_dir / HISTORY_FILE, _json_dumps(st["history"]))
            if self.show_progress:
                val_text = "-" if val_loss is None else f"{val_loss:.4g}"
                tqdm.write(
                    f"epoch {st['epoch']}/{cfg.max_epochs}: train {train_loss:.4g}  val mse {val_text}  "
                    f"lr {lr:.2g}{'  (best)' if improved else ''}",
                    file=sys.stderr,
                )

    # -- files (rank 0 only) --

    def _save_state(self) -> None:
        self.state["elapsed_s"] = self.elapsed_s()
        save_training_state(
            self.out_dir / RESUME_FILE,
            model=self.model,
            optimizer=self.optimizer,
            scheduler=self.scheduler,
            progress=self.state,
        )

    def _save_checkpoint(self, partial: bool) -> None:
        st, cfg = self.state, self.config
        last = st["history"][-1] if st["history"] else {}
        meta = {
            "model_name": cfg.model,
            "imu_rate_hz": cfg.imu_rate_hz,
            "window": cfg.window,
            "stride": cfg.stride,
            "out_dim": self.model.out_dim,
            "normalization": self.normalization,
            **self.data_info,
            "metrics": {
                "val_mse": last.get("val_mse"),
                "train_loss": last.get("train_loss"),
                "monitored_loss": st["best_val_loss"],
                "epoch": st["best_epoch"],
                "partial": partial,
            },
            "epochs": st["epoch"],
            "steps": st["global_step"],
            "processes": self.ddp.world,
            "wall_time_s": self.elapsed_s(),
            "train_config": cfg.to_json(),
        }
        dtype = torch.float16 if cfg.weights_dtype == "float16" else torch.float32
        save_checkpoint(self.out_dir / cfg.checkpoint_name, self.model, meta, dtype=dtype)

    def _progress_bar(self, total: int) -> tqdm | None:
        if not self.show_progress:
            return None
        epoch = self.state["epoch"]
        return tqdm(
            total=total,
            initial=self.state["step_in_epoch"],
            desc=f"epoch {epoch + 1}/{self.config.max_epochs}",
            unit="batch",
            leave=False,
            dynamic_ncols=True,
        )


def _use_nll(config: TrainConfig, model: VelocityModel) -> bool:
    """Whether the ``"velocity"`` loss is the NLL. Families with their own reference loss (RNIN,
    RoNIN LSTM / TCN) train with it under ``auto``; ``nll`` is an error for them."""
    if config.loss is LossKind.NLL and not model.has_uncertainty:
        raise ConfigError(f"loss 'nll' needs a model with an uncertainty head; {config.model!r} has none")
    if config.loss is LossKind.NLL and model.train_loss != "velocity":
        raise ConfigError(
            f"loss 'nll': {config.model!r} trains with its reference's {model.train_loss!r} loss "
            "(ftin.train.losses); use loss 'auto'"
        )
    if config.loss is LossKind.MSE or model.train_loss != "velocity":
        return False
    return bool(model.has_uncertainty)


def _check_model_accepts(model: VelocityModel, config: TrainConfig) -> int:
    """Run the model once on zeros so a window it cannot take fails before any data work; returns
    the number of parts K its ``forward_parts`` predicts for the window."""
    model.eval()
    try:
        parts = model.target_parts(config.window)
        with torch.inference_mode():
            output = model.forward_parts(torch.zeros(2, 6, config.window))
    except ValueError as exc:
        raise ConfigError(f"--window {config.window}: {exc}") from None
    if output.velocity.shape != (2, parts, model.out_dim) or config.window % parts:
        raise ConfigError(
            f"model {config.model!r} returned part velocities of shape {tuple(output.velocity.shape)}, "
            f"expected (B, {parts}, {model.out_dim}) for {parts} equal parts of {config.window} samples"
        )
    return parts


def _check_resumed_config(config: TrainConfig, out_dir: Path) -> None:
    saved = TrainConfig.load(out_dir / CONFIG_FILE)
    # Compare as JSON: tuples in model_kwargs come back from config.json as lists.
    ours = {k: v for k, v in _as_json(config.to_json()).items() if k not in BUDGET_FIELDS}
    theirs = {k: v for k, v in _as_json(saved.to_json()).items() if k not in BUDGET_FIELDS}
    changed = sorted(k for k in ours if ours[k] != theirs.get(k))
    if changed:
        details = ", ".join(f"{k}: {theirs.get(k)!r} -> {ours[k]!r}" for k in changed)
        raise ConfigError(f"--resume: the run in {out_dir} was started with other options ({details})")


def _json_dumps(value: Any) -> str:
    return json.dumps(to_json_safe(value), indent=2) + "\n"


def _as_json(value: Any) -> Any:
    return json.loads(json.dumps(to_json_safe(value)))
