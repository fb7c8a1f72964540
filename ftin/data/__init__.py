"""Sequence types, readers for every supported dataset layout, and preprocessing."""

from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence, Trajectory

__all__ = ["DataFormatError", "ImuSequence", "Trajectory"]
