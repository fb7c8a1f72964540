"""One training loop for every registered model (``docs/design.md``, "Training").

``train(config, train_sequences, val_sequences)`` runs in one process or, under ``torchrun``, in
several (``ftin.train.distributed``). ``run_training(config)`` first reads the data the config names
(``ftin.data.loading``). The run folder ``config.out_dir`` holds:

- ``config.json``: the resolved ``TrainConfig`` (rate, window and out_dim filled in);
- ``<name>.safetensors`` + ``<name>.json``: the best checkpoint (lowest validation MSE);
- ``resume.safetensors``: model, optimizer, scheduler, RNG states and ``TrainProgress``
  (``ftin.train.state``);
- ``history.json``: one record per finished epoch.

Decisions:
- Exact resume: data order and augmentation depend only on ``(seed, epoch)`` (``ftin.train.data``),
  and the torch/numpy/Python RNG states are in the resume state, so a run stopped after any step and
  resumed reaches the same weights as an uninterrupted run (in one process; under DDP every rank
  restores rank 0's RNG state). ``batch_size`` is the global batch.
- ``max_minutes`` is per invocation (a CPU budget); ``max_steps`` counts optimizer steps over the
  whole run. Either stops the run after the current step and writes the resume state; ``--resume``
  continues it. SIGINT/SIGTERM do the same at the next step boundary.
- The model is ``create_model(name, window=, out_dim=, **model_kwargs)`` (the registry's contract
  decides which of them it takes), its first weights seeded or, for fine-tuning, ``init_from``'s.
  The dataset yields per-part targets ``(B, K, D)``, K = ``model.target_parts(window)``;
  ``forward_parts`` is trained with the loss its family's reference uses (``ftin.train.losses``),
  and validated on the MSE of ~1 s mean velocities.
- The scheduler and the best checkpoint follow the validation velocity MSE (training MSE without
  validation data); training ends when the learning rate falls below ``min_lr`` or after
  ``max_epochs``. When a run stops before any epoch ends, its current weights are written as the
  checkpoint (``metrics.partial = true``) so that a budget run always leaves something to load.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from ftin.checkpoint import save_checkpoint
from ftin.data.loading import data_rate_hz, load_sequences
from ftin.data.types import ImuSequence
from ftin.interrupts import stop_on_signals
from ftin.models import create_model, model_contract
from ftin.models.base import VelocityModel
from ftin.train.config import ConfigError, TrainConfig
from ftin.train.data import TrainData, training_data
from ftin.train.distributed import Distributed, distributed, parts_module
from ftin.train.losses import LossFn, make_loss, uses_nll
from ftin.train.rotation_consistency import consistency_loss, quarter_turns, turned_inputs
from ftin.train.sparse_truth import segment_loss, split_output
from ftin.train.start_weights import freeze_except, initialise_from, keep_frozen_in_eval
from ftin.train.state import (
    CONFIG_FILE,
    RESUME_FILE,
    TrainProgress,
    check_resumed_config,
    check_run_folder,
    checkpoint_meta,
    load_training_state,
    restore_rng,
    save_training_state,
    write_history,
)


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
    with distributed() as ddp:
        return _setup(config, train_sequences, val_sequences, resume, progress, ddp, started).loop()


def _setup(
    config: TrainConfig,
    train_sequences: Sequence[ImuSequence],
    val_sequences: Sequence[ImuSequence],
    resume: bool,
    show_progress: bool,
    ddp: Distributed,
    started: float,
) -> _Run:
    out_dir = Path(config.out_dir)
    check_run_folder(out_dir, resume)
    if not train_sequences:
        raise ConfigError("data: no training sequences")

    # 1 s windows at the data's rate unless the config says otherwise
    config = config.with_(imu_rate_hz=config.imu_rate_hz or data_rate_hz(train_sequences))
    rate_hz, window = config.imu_rate_hz, config.resolved_window

    # model and loss
    torch.manual_seed(config.seed)
    np.random.seed(config.seed % 2**32)
    options = {"window": window, **({} if config.out_dim is None else {"out_dim": config.out_dim})}
    options.update(config.model_kwargs)  # the user's keys win
    problem = model_contract(config.model).window_error(options["window"], options)
    if problem:
        raise ConfigError(f"--window {options['window']}: {config.model}: {problem}")
    try:
        model = create_model(config.model, **options)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"model {config.model!r}: {exc}") from None
    config = config.with_(window=window, out_dim=model.out_dim)
    if config.init_from is not None and not resume:  # a resumed run starts from its resume state
        initialise_from(model, config)
    try:
        parts = model.check_parts(window)
    except ValueError as exc:
        raise ConfigError(f"--window {window}: {exc}") from None
    use_nll = uses_nll(config.loss, model, config.model)
    try:
        loss_fn = make_loss(
            model,
            window,
            rate_hz,
            use_nll=use_nll,
            log_std_range=config.log_std_range,
            speed_weight=config.speed_weight,
        )
    except ValueError as exc:
        raise ConfigError(f"model {config.model!r} with --window {window}: {exc}") from None
    model.to(config.device)

    data = training_data(config, train_sequences, val_sequences, parts=parts, out_dim=model.out_dim, ddp=ddp)
    trained = freeze_except(model, config.train_only)
    optimizer = torch.optim.Adam(trained, lr=config.lr)
    scheduler = torch.optim.lr_scheduler.ReduceLROnPlateau(
        optimizer, mode="min", factor=config.plateau_factor, patience=config.plateau_patience
    )

    progress = TrainProgress()
    if resume:
        check_resumed_config(config, out_dir)
        saved, rng = load_training_state(
            out_dir / RESUME_FILE, model=model, optimizer=optimizer, scheduler=scheduler
        )
        progress = TrainProgress.from_dict(saved)
        progress.stop_reason = None  # budgets are per invocation; the loop re-checks epochs and lr
        restore_rng(rng)
    elif ddp.main:
        config.save(out_dir / CONFIG_FILE)
    # An uncertainty head trained with plain MSE gets no gradient: DDP must be told.
    net = parts_module(
        model,
        ddp,
        seed=config.seed,
        step=progress.global_step,
        unused_parameters=model.has_uncertainty and not use_nll,
    )
    return _Run(
        config,
        model,
        net,
        optimizer,
        scheduler,
        loss_fn,
        data,
        ddp,
        progress,
        started,
        elapsed_before=progress.elapsed_s,
        show_progress=show_progress and ddp.main,
        loss_switch=config.nll_warmup_epochs if use_nll and config.nll_warmup_epochs > 0 else None,
    )


@dataclass
class _Run:
    """One training invocation; ``loop`` runs epochs until a stop condition."""

    config: TrainConfig
    model: VelocityModel
    net: torch.nn.Module  # model.forward_parts, DDP-wrapped under several processes
    optimizer: torch.optim.Optimizer
    scheduler: Any
    loss_fn: LossFn
    data: TrainData
    ddp: Distributed
    progress: TrainProgress
    started: float  # time.monotonic() at the start of this invocation
    elapsed_before: float  # wall time of the earlier invocations
    show_progress: bool
    loss_switch: int | None = None  # epochs of MSE before the NLL (TLIO); None: one loss throughout
    last_val_nll: float | None = None  # of the latest validation pass (models with a log-std)

    @property
    def device(self) -> torch.device:
        return torch.device(self.config.device)

    @property
    def out_dir(self) -> Path:
        return Path(self.config.out_dir)

    def elapsed_s(self) -> float:
        return self.elapsed_before + time.monotonic() - self.started

    def loop(self) -> TrainResult:
        p, cfg = self.progress, self.config
        stop = threading.Event()  # set by SIGINT/SIGTERM: stop at the next step, resumable
        last_save = time.monotonic()
        with stop_on_signals(stop):
            while p.stop_reason is None:
                if p.epoch >= cfg.max_epochs:
                    p.stop_reason = "max_epochs"
                elif self.optimizer.param_groups[0]["lr"] < cfg.min_lr:  # a finished run, resumed
                    p.stop_reason = "min_lr"
                elif self._stalled():
                    p.stop_reason = "early_stop"
                if p.stop_reason is not None:
                    break
                batches = self._epoch_batches(p.epoch)
                bar = self._progress_bar(len(batches))
                self.net.train()
                if cfg.train_only:
                    keep_frozen_in_eval(self.model)
                tick, windows = time.monotonic(), 0
                for b in range(p.step_in_epoch, len(batches)):
                    p.stop_reason = self._budget_stop(stop)
                    if p.stop_reason is not None:
                        break
                    loss = self._step(batches[b], p.epoch)
                    p.step_in_epoch += 1
                    p.global_step += 1
                    p.epoch_loss_sum += loss * len(batches[b])
                    p.epoch_count += len(batches[b])
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
                if p.stop_reason is not None:
                    break
                self._end_epoch()
        if self.ddp.main:
            self._save_state()
            if p.best_epoch is None:  # stopped before any epoch ended: keep what there is
                self._save_checkpoint(partial=True)
        stem = self.out_dir / cfg.checkpoint_name
        return TrainResult(
            out_dir=self.out_dir,
            checkpoint=stem.with_name(stem.name + ".safetensors"),
            epochs_done=p.epoch,
            steps=p.global_step,
            best_val_loss=p.best_val_loss,
            stop_reason=p.stop_reason,
            history=list(p.history),
        )

    def _epoch_batches(self, epoch: int) -> list[np.ndarray]:
        self.data.sampler.set_epoch(epoch)
        self.data.train.set_epoch(epoch)
        indices = np.fromiter(iter(self.data.sampler), dtype=np.int64)
        return [indices[i : i + self.data.batch] for i in range(0, len(indices), self.data.batch)]

    def _step(self, indices: np.ndarray, epoch: int) -> float:
        x, v = self.data.train.get_batch(indices)
        # RIO's turned copies after the dense windows (ftin.train.rotation_consistency); none at weight 0
        turns = quarter_turns(len(x) if self.config.rotation_consistency_weight else 0)
        x = torch.cat([x, turned_inputs(x, turns)]) if len(turns) else x
        sparse = self.data.sparse_batch(self.config, self.progress.global_step)  # ftin.train.sparse_truth
        x = x if sparse is None else torch.cat([x, sparse.x])
        x = self.data.normalization.apply(x.to(self.device))
        with torch.autocast(self.device.type, dtype=torch.bfloat16, enabled=self.config.precision == "bf16"):
            output = self.net(x)  # forward_parts: velocity (B, K, D)
        output, rest = split_output(output, len(v))
        turned_velocity, sparse_velocity = rest[: len(turns)], rest[len(turns) :]
        loss = self.loss_fn(output, v.to(self.device), epoch < self.config.nll_warmup_epochs)
        if len(turns):
            turned = consistency_loss(output.velocity, turned_velocity, turns.to(self.device))
            loss = loss + self.config.rotation_consistency_weight * turned
        if sparse is not None:
            loss = loss + self.config.sparse_weight * segment_loss(sparse_velocity, sparse.layout)
        if not torch.isfinite(loss):
            raise FloatingPointError(
                f"training loss became {loss.item()} at epoch {epoch + 1}, "
                f"step {self.progress.global_step + 1}; lower --lr or check the data"
            )
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        return float(loss.detach())

    def _stalled(self) -> bool:
        return self.progress.stalled(self.config.early_stop_patience, self.loss_switch)

    def _budget_stop(self, stop: threading.Event) -> str | None:
        cfg, reason = self.config, None
        if cfg.max_steps is not None and self.progress.global_step >= cfg.max_steps:
            reason = "max_steps"
        elif cfg.max_minutes is not None and time.monotonic() - self.started >= 60.0 * cfg.max_minutes:
            reason = "max_minutes"
        elif stop.is_set():
            reason = "signal"
        # Every rank must stop at the same step (time and signals differ between processes).
        if self.ddp.world > 1 and self.ddp.any(reason is not None) and reason is None:
            reason = "max_minutes" if cfg.max_minutes is not None else "signal"
        return reason

    def validation_mse(self) -> float | None:
        """The validation MSE of ~1 s mean velocities over every rank's windows (``ftin.train.data``);
        the same pass leaves the Gaussian NLL of a model with a log-std in ``last_val_nll``."""
        mse, self.last_val_nll = self._validation()
        return mse

    def _validation(self) -> tuple[float | None, float | None]:
        """Validation MSE and (for a model with a log-std) Gaussian NLL per element; None without."""
        if self.data.val is None:
            return None, None
        sums = self.data.validation_sums(self.model, self.device, self.ddp, self.config.log_std_range)
        sq_sum, nll_sum, count = self.ddp.sum(*sums)
        count = max(count, 1)
        return sq_sum / count, (nll_sum / count if self.model.has_uncertainty else None)

    def _end_epoch(self) -> None:
        p, cfg = self.progress, self.config
        loss_sum, count = self.ddp.sum(p.epoch_loss_sum, p.epoch_count)
        train_loss = loss_sum / max(count, 1)
        self.last_val_nll = None
        val_loss = self.validation_mse()
        val_nll = self.last_val_nll
        # Without validation the training loss monitors the plateau (MSE unless the model uses NLL);
        # a frozen velocity (train_only) has a constant MSE: its validation NLL is what moves.
        monitored = val_loss if val_loss is not None else train_loss
        if cfg.train_only and val_nll is not None:
            monitored = val_nll
        self.scheduler.step(monitored)
        lr = self.optimizer.param_groups[0]["lr"]
        improved = p.best_val_loss is None or monitored < p.best_val_loss
        p.history.append(
            {
                "epoch": p.epoch + 1,
                "train_loss": train_loss,
                "val_mse": val_loss,
                **({"val_nll": val_nll} if val_nll is not None else {}),
                "lr": lr,
                "steps": p.global_step,
                "elapsed_s": self.elapsed_s(),
                "best": improved,
            }
        )
        p.epoch += 1
        p.step_in_epoch, p.epoch_loss_sum, p.epoch_count = 0, 0.0, 0
        if p.epoch == self.loss_switch:  # MSE ends here: the NLL phase starts its own plateau count
            self.scheduler.best, self.scheduler.num_bad_epochs = self.scheduler.mode_worse, 0
        if improved:
            p.best_val_loss, p.best_epoch = monitored, p.epoch
        if lr < cfg.min_lr:
            p.stop_reason = "min_lr"
        elif self._stalled():
            p.stop_reason = "early_stop"
        if not self.ddp.main:
            return
        if improved:
            self._save_checkpoint(partial=False)
        self._save_state()
        write_history(self.out_dir, p.history)
        if self.show_progress:
            val_text = "-" if val_loss is None else f"{val_loss:.4g}"
            tqdm.write(
                f"epoch {p.epoch}/{cfg.max_epochs}: train {train_loss:.4g}  val mse {val_text}  "
                f"lr {lr:.2g}{'  (best)' if improved else ''}",
                file=sys.stderr,
            )

    # -- files (rank 0 only) --

    def _save_state(self) -> None:
        self.progress.elapsed_s = self.elapsed_s()
        save_training_state(
            self.out_dir / RESUME_FILE,
            model=self.model,
            optimizer=self.optimizer,
            scheduler=self.scheduler,
            progress=self.progress.to_dict(),
        )

    def _save_checkpoint(self, partial: bool) -> None:
        meta = checkpoint_meta(
            self.config,
            self.progress,
            self.data.normalization,
            self.data.info,
            partial,
            processes=self.ddp.world,
            wall_time_s=self.elapsed_s(),
        )
        dtype = torch.float16 if self.config.weights_dtype == "float16" else torch.float32
        save_checkpoint(self.out_dir / self.config.checkpoint_name, self.model, meta, dtype=dtype)

    def _progress_bar(self, total: int) -> tqdm | None:
        if not self.show_progress:
            return None
        desc = f"epoch {self.progress.epoch + 1}/{self.config.max_epochs}"
        initial = self.progress.step_in_epoch
        return tqdm(total=total, initial=initial, desc=desc, unit="batch", leave=False, dynamic_ncols=True)
