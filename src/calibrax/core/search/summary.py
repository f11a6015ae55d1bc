"""What a campaign reached, as the CLI, the report and the Python API read it: the best observed
point against the metric's noise threshold, and the model's answer."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class CampaignSummary:
    """What a finished (or stopped) campaign reached."""

    store: Path
    points: int
    done: int
    failed: int
    best_id: int | None
    best_params: dict[str, float]
    best_value: float
    best_uncertainty: float
    #: the metric's noise threshold at the best point and the rate it holds at (NaN: none stated)
    noise_threshold: float = float("nan")
    noise_threshold_rate: float = float("nan")
    #: the model's answer (recommendation and plausible region), None before a model could be fitted
    answer: dict[str, Any] | None = None

    def noise_text(self) -> str:
        """How the best distance compares with the metric's noise threshold, in words."""
        return noise_text(self.best_value, self.noise_threshold, self.noise_threshold_rate)


def noise_text(value: float, threshold: float, rate: float) -> str:
    """"within the noise (threshold d = 7.5, which the truth meets 95% of the time)", or "outside"."""
    if not (math.isfinite(threshold) and math.isfinite(value)):
        return "no noise threshold stated"
    where = "within" if value <= threshold else "outside"
    return f"{where} the noise (threshold d = {threshold:.3g}, which the truth meets {rate:.0%} of the time)"


def duration_text(seconds: float) -> str:
    """45 s, 12 min, 2.3 h (progress lines)."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


__all__ = ["CampaignSummary", "noise_text", "duration_text"]
