"""Walker profiles: a walker's own distance scale learnt from walks of known length (``scale``) and
kept on disk beside the runs (``store``). ``docs/metrics.md`` ("A walker's own scale")."""

from __future__ import annotations

from ftin.profiles.scale import AppliedProfile, ProfileScale, apply_scale, profile_scale, scale_sample

__all__ = ["AppliedProfile", "ProfileScale", "apply_scale", "profile_scale", "scale_sample"]
