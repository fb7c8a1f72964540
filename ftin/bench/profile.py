"""Model size and speed: parameter count, FLOPs per window, measured inference windows per second.

Conventions (also printed by ``ftin models``):

* FLOPs are counted by ``torch.utils.flop_counter.FlopCounterMode`` on one window in eval mode: matrix
  products and convolutions, a multiply-add counted as 2 FLOPs; biases, normalisation, activations
  and other elementwise work are not counted. PyTorch has no formula for LSTM layers, bilinear layers
  or FFTs, so we add them: LSTM ``2 x tokens x (W_ih + W_hh entries)`` per layer and direction (the
  gate matmuls; without oneDNN, PyTorch's LSTM decomposes into matmuls that are counted anyway),
  bilinear/trilinear ``2 x`` the size of the broadcast product, and FFTs the usual
  ``5 N log2 N`` per complex transform of length N, half that for real-input / real-output ones.
* Throughput is measured on this machine: eval mode, ``torch.inference_mode``, one warm-up pass, then
  ``repeats`` timed passes of a ``(batch, 6, window)`` batch; windows/s = batch / fastest pass time
  (the fastest pass is the least disturbed by other processes on a shared machine, as ``timeit``).
  ``threads`` sets ``torch.set_num_threads`` for the measurement only (restored afterwards).
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass

import torch
from torch import nn
from torch.utils.flop_counter import FlopCounterMode

from ftin.models.registry import check_known_models, create_model, list_models

IN_CHANNELS = 6
DEFAULT_WINDOW = 200  # the reference parameter counts are for 6 x 200 inputs (``ftin models``)
aten = torch.ops.aten


# ------------------------------------------------------------------------ FLOP formulas PyTorch lacks
def _lstm_layer_flops(input_shape, w_ih, w_hh, *args, out_shape=None, **kwargs) -> int:
    # aten.lstm is composite: FlopCounterMode decomposes it before looking up a formula, and on CPU
    # it lands in one oneDNN kernel per layer and direction, whose gate matmuls we count here.
    tokens = math.prod(input_shape[:-1])  # (T, B, I) or (B, T, I)
    return 2 * tokens * (math.prod(w_ih) + math.prod(w_hh))


def _trilinear_flops(i1, i2, i3, expand1, expand2, expand3, *args, out_shape=None, **kwargs) -> int:
    full: list[int] = []
    for shape, expand in ((i1, expand1), (i2, expand2), (i3, expand3)):
        dims = list(shape)
        for d in sorted(expand):
            dims.insert(d, 1)
        full = [max(a, b) for a, b in zip(full, dims, strict=True)] if full else dims
    return 2 * math.prod(full)


def _fft_cost(shape: Sequence[int], dims: Sequence[int], per_point_log: float) -> int:
    n = math.prod(shape[d] for d in dims)
    signals = math.prod(shape) // n if n else 0
    return int(round(per_point_log * n * math.log2(n) * signals)) if n > 1 else 0


def _fft_r2c_flops(self_shape, dim, *args, out_shape=None, **kwargs) -> int:
    return _fft_cost(self_shape, dim, 2.5)


def _fft_c2r_flops(self_shape, dim, *args, out_shape=None, **kwargs) -> int:
    return _fft_cost(out_shape, dim, 2.5)  # the real output holds the transform length


def _fft_c2c_flops(self_shape, dim, *args, out_shape=None, **kwargs) -> int:
    return _fft_cost(self_shape, dim, 5.0)


EXTRA_FLOP_FORMULAS = {
    aten.mkldnn_rnn_layer: _lstm_layer_flops,
    aten._trilinear: _trilinear_flops,
    aten._fft_r2c: _fft_r2c_flops,
    aten._fft_c2r: _fft_c2r_flops,
    aten._fft_c2c: _fft_c2c_flops,
}


# -------------------------------------------------------------------------------------- measurements
def count_parameters(model: nn.Module) -> int:
    return sum(p.numel() for p in model.parameters())


def flops_per_window(model: nn.Module, window: int) -> int:
    """FLOPs of one ``(1, 6, window)`` forward pass in eval mode (see the module docstring)."""
    was_training = model.training
    model.eval()
    try:
        x = torch.zeros(1, IN_CHANNELS, window)
        # no_grad, not inference_mode: FlopCounterMode's module tracker needs autograd views
        # (parametrized weights such as weight norm are computed inside forward)
        with torch.no_grad(), FlopCounterMode(display=False, custom_mapping=EXTRA_FLOP_FORMULAS) as fc:
            model(x)
        return int(fc.get_total_flops())
    finally:
        model.train(was_training)


@contextlib.contextmanager
def torch_threads(threads: int | None) -> Iterator[int]:
    """Temporarily set ``torch.set_num_threads``; yields the thread count in effect."""
    previous = torch.get_num_threads()
    if threads is not None:
        if threads < 1:
            raise ValueError(f"threads must be >= 1, got {threads}")
        torch.set_num_threads(threads)
    try:
        yield torch.get_num_threads()
    finally:
        torch.set_num_threads(previous)


def windows_per_second(
    model: nn.Module, window: int, batch: int = 512, threads: int | None = None, repeats: int = 3
) -> float:
    """Measured eval-mode inference throughput in windows per second (fastest of ``repeats`` passes)."""
    if batch < 1 or repeats < 1:
        raise ValueError(f"batch and repeats must be >= 1, got batch={batch}, repeats={repeats}")
    was_training = model.training
    model.eval()
    x = torch.randn(batch, IN_CHANNELS, window, generator=torch.Generator().manual_seed(0))
    try:
        with torch_threads(threads), torch.inference_mode():
            model(x)  # warm-up: allocator, oneDNN primitive caches
            seconds = []
            for _ in range(repeats):
                start = time.perf_counter()
                model(x)
                seconds.append(time.perf_counter() - start)
    finally:
        model.train(was_training)
    return batch / min(seconds)


# ------------------------------------------------------------------------------------ whole models
@dataclass(frozen=True)
class ModelProfile:
    name: str
    window: int
    parameters: int | None
    flops_per_window: int | None
    windows_per_s: float | None  # None when not measured (or not supported at this window)
    batch: int
    threads: int
    out_dim: int | None
    has_uncertainty: bool | None
    error: str | None = None  # why the model could not be profiled at this window

    def to_dict(self) -> dict:
        return asdict(self)


def profile_model(
    name: str,
    window: int = DEFAULT_WINDOW,
    batch: int = 512,
    threads: int | None = None,
    repeats: int = 3,
    measure_speed: bool = True,
) -> ModelProfile:
    """Profile one registered model at its default configuration, built for ``window`` (the registry's
    input contract decides whether it takes it).

    A window the model cannot take is reported in ``error`` (the row stays in a side-by-side table);
    an unknown name raises ``UnknownModelError``.
    """
    with torch_threads(threads) as threads_used:
        try:
            model = create_model(name, window=window)  # built for it, or ValueError (the contract)
        except ValueError as error:
            return ModelProfile(name, window, None, None, None, batch, threads_used, None, None, str(error))
        speed = windows_per_second(model, window, batch, None, repeats) if measure_speed else None
        return ModelProfile(
            name=name,
            window=window,
            parameters=count_parameters(model),
            flops_per_window=flops_per_window(model, window),
            windows_per_s=speed,
            batch=batch,
            threads=threads_used,
            out_dim=getattr(model, "out_dim", None),
            has_uncertainty=bool(getattr(model, "has_uncertainty", False)),
        )


def profile_models(
    names: Sequence[str] | None = None,
    window: int = DEFAULT_WINDOW,
    batch: int = 512,
    threads: int | None = None,
    repeats: int = 3,
    measure_speed: bool = True,
) -> list[ModelProfile]:
    """``profile_model`` for each name (default: every registered model), in the given order."""
    names = list_models() if names is None else list(names)
    check_known_models(names)
    return [profile_model(n, window, batch, threads, repeats, measure_speed) for n in names]
