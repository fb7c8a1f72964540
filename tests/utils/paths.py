"""Where the tests find the checkout's own files (one place, whatever folder a test lives in)."""

from __future__ import annotations

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
CHECKPOINTS = REPO_ROOT / "checkpoints"  # the shipped checkpoints
