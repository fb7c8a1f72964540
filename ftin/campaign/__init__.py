"""The training campaign: the protocol's jobs (``ftin.protocol``) trained and scored on Ray.

``folder`` is the campaign folder (its state, the frozen code, every job's run folder), ``job`` the
one body of a job wherever it trains (train or resume, score, record), ``engine`` the Ray side (a
local Ray or an existing cluster: workers, GPUs, retries), ``burst`` jobs trained on a lent GPU
machine instead, ``collect`` the committable records and the shipped checkpoints. Ray is an optional
extra (``pip install -e ".[cluster]"``): without it only the commands that need no engine (status,
collect, ship, burst) work.
"""

from __future__ import annotations


class CampaignError(ValueError):
    """A campaign cannot do what was asked; the message says why and what to do."""


INSTALL_HINT = 'the campaign engine needs Ray: pip install -e ".[cluster]" (or pip install "ray[tune]")'
