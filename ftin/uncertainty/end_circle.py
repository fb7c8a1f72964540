"""What may be said of a walk's 95 % end circle: the radius, or why it is withheld; with ground truth,
whether the true end lies inside it; and what the band's coverage figure was measured on.

Decisions:
- No radius on a walk whose verdict is implausible (``ftin.metrics.walk_verdict.radius_withheld``
  says why): the circle is drawn around the predicted end, and the walk's own evidence (its steps,
  its GPS, its ground truth) says that end is wrong, so "ends within R m of here" would claim what
  the model cannot know.
- With ground truth, the true end is compared start-aligned, as the uncertainty is defined and as
  ``ftin evaluate``'s coverage table compares it (``ftin.uncertainty.coverage.coverage_of``).
- The coverage figure (a 2-sigma band holds 86 % of true positions) is a property of the
  calibration, measured on validation walks, never of this run: ``coverage_text`` says so, and
  names the walks (or the model whose constants were borrowed).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ftin.data.types import Trajectory
from ftin.uncertainty import PathUncertainty
from ftin.uncertainty.calibration import calibration_for
from ftin.uncertainty.coverage import coverage_of

NOT_THIS_RUN = "Figures of those walks, not measured on this run."


@dataclass(frozen=True)
class EndCircle:
    end_radius_95_m: float | None  # None: withheld (``withheld_reason``)
    withheld_reason: str | None
    true_end_inside: bool | None  # None: no ground truth, or no radius
    true_end_error_m: float | None  # start-aligned distance from the predicted to the true end
    calibration: str
    coverage_text: str

    def as_dict(self) -> dict[str, Any]:
        radius, error = self.end_radius_95_m, self.true_end_error_m
        return {
            "end_radius_95_m": None if radius is None else round(radius, 2),
            "withheld_reason": self.withheld_reason,
            "true_end_inside": self.true_end_inside,
            "true_end_error_m": None if error is None else round(error, 2),
            "calibration": self.calibration,
            "coverage_text": self.coverage_text,
        }


def coverage_text(checkpoint: str) -> str:
    """What the band and the circle rest on, in words: the walks their constants were fitted on (a 2σ
    band is a Gaussian's 86 %; how much of those walks it held depends on the fit's target, so no share
    of this run is claimed)."""
    found = calibration_for(checkpoint)
    walks = found.fitted_on or "validation walks"
    if found.model != checkpoint:
        return (
            f"The 2σ band and the 95 % circle come from {found.model}'s constants, fitted on {walks}; "
            f"{checkpoint} has no calibration of its own. {NOT_THIS_RUN}"
        )
    return f"The 2σ band and the 95 % circle come from constants fitted on {walks}. {NOT_THIS_RUN}"


def end_circle(
    found: PathUncertainty,
    checkpoint: str,
    estimate: Trajectory,
    truth: Trajectory | None,
    withheld_reason: str | None = None,
) -> EndCircle:
    """The circle of ``found`` (``estimate``'s uncertainty) as it may be shown (module docstring);
    ``withheld_reason`` from the walk's verdict, ``truth`` the ground truth where there is one."""
    radius = None if withheld_reason is not None else found.end_radius_95_m
    inside = error = None
    if truth is not None and len(truth) > 1:
        try:
            covered = coverage_of(estimate, found.cov_m2, truth, found.end_radius_95_m)
        except ValueError:  # a truth the start alignment cannot fit (one that never moves)
            covered = None
        if covered is not None:
            error = covered.end_error_m
            inside = None if radius is None else covered.end_inside
    try:
        text = coverage_text(checkpoint)
    except KeyError:  # no calibration file: the uncertainty itself would not exist
        text = ""
    return EndCircle(radius, withheld_reason, inside, error, found.calibration, text)
