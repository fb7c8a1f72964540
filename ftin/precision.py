"""Numeric precision of inference: fp32, or bf16 autocast where the CPU makes it free.

Decisions (measured by ``experiments/probe_bf16.py``: docs/results/probes/bf16.md):
- ``bf16`` runs the model's forward only under ``torch.autocast("cpu", dtype=torch.bfloat16)``
  (matrix products and convolutions in bfloat16, reductions and normalisation as autocast keeps them);
  the input normalisation before it and everything after it (the turned-copy average, the integration)
  stay in float32 / float64: ``ftin.infer`` casts the outputs back.
- bf16 is free only on a CPU with bf16 instructions (x86 ``avx512_bf16`` or ``amx_bf16``): elsewhere
  autocast emulates it and runs slower than fp32. ``auto`` therefore picks bf16 only there, and only
  for a model family whose validation ATE under bf16 stayed within ``BF16_ATE_BAR`` of fp32's
  (``BF16_FAMILIES``); every other case runs fp32, and says why.
- The choice is made once, at start-up (``choose``): the app names it in ``GET /health``, the CLI
  takes ``--precision``. Reported numbers (``ftin evaluate``) stay fp32 unless asked.
"""

from __future__ import annotations

import contextlib
import enum
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import torch

BF16_ATE_BAR = 0.01  # the issue's bar: mean validation ATE within 1 % of fp32's
# Registry names of the families whose shipped walking checkpoint met the bar (the probe's table):
# RoNIN ResNet (the default, ronin_resnet-walking) moved by -0.8 % to +0.2 %; FTIN (ftin-walking) by
# -2.5 % on OxIOD, so it stays fp32; families never measured on walks stay fp32 too.
BF16_FAMILIES = frozenset({"ronin_resnet"})
_BF16_CPU_FLAGS = ("avx512_bf16", "amx_bf16")  # /proc/cpuinfo names of native bf16 arithmetic
_CPUINFO = Path("/proc/cpuinfo")


class Precision(str, enum.Enum):
    """What inference runs in."""

    FP32 = "fp32"
    BF16 = "bf16"


class PrecisionSetting(str, enum.Enum):
    """What a user asks for (``FTIN_PRECISION``, ``--precision``): ``auto`` leaves it to ``choose``."""

    AUTO = "auto"
    FP32 = Precision.FP32.value
    BF16 = Precision.BF16.value


@dataclass(frozen=True)
class PrecisionChoice:
    precision: Precision
    reason: str  # in words, for /health and the CLI


@cache
def cpu_bf16() -> tuple[bool, str]:
    """Whether this CPU does bf16 arithmetic natively, and what showed it (cached: it never changes)."""
    capability = torch.backends.cpu.get_cpu_capability()
    flags = _cpu_flags()
    found = [flag for flag in _BF16_CPU_FLAGS if flag in flags]
    # torch's own probes, where this build has them (they read CPUID, also where /proc is absent)
    if not found and getattr(torch.cpu, "_is_avx512_bf16_supported", lambda: False)():
        found.append("avx512_bf16 (torch)")
    if not found and getattr(torch.cpu, "_is_amx_tile_supported", lambda: False)():
        found.append("amx (torch)")
    if found:
        return True, f"this CPU has {' and '.join(found)} (torch capability {capability})"
    return False, f"this CPU has neither {' nor '.join(_BF16_CPU_FLAGS)} (torch capability {capability})"


def _cpu_flags() -> set[str]:
    try:
        text = _CPUINFO.read_text(encoding="utf-8", errors="replace")
    except OSError:  # not Linux: torch's probes answer instead
        return set()
    return {flag for line in text.splitlines() if line.startswith("flags") for flag in line.split()}


def choose(setting: PrecisionSetting | str, family: str | None = None) -> PrecisionChoice:
    """The precision ``setting`` means on this CPU for a model of registry name ``family`` (None: the
    CPU alone decides, as for a server before any model is named)."""
    setting = PrecisionSetting(setting)
    if setting is PrecisionSetting.FP32:
        return PrecisionChoice(Precision.FP32, "fp32 as asked")
    if setting is PrecisionSetting.BF16:
        return PrecisionChoice(Precision.BF16, "bf16 as asked")
    native, why = cpu_bf16()
    if not native:
        return PrecisionChoice(Precision.FP32, f"auto: fp32, {why}")
    if family is not None and family not in BF16_FAMILIES:
        return PrecisionChoice(
            Precision.FP32,
            f"auto: fp32 for {family}, whose bf16 accuracy was not shown within "
            f"{BF16_ATE_BAR:.0%} of fp32 (docs/results/probes/bf16.md); {why}",
        )
    return PrecisionChoice(Precision.BF16, f"auto: bf16, {why}")


def forward_context(precision: Precision | str) -> contextlib.AbstractContextManager:
    """The context a model's forward runs in: bf16 autocast, or nothing."""
    if Precision(precision) is Precision.BF16:
        return torch.autocast("cpu", dtype=torch.bfloat16)
    return contextlib.nullcontext()
