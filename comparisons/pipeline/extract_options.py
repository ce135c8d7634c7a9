"""The thresholds of the extraction (``extract``): which bounces matter, which velocity jumps are impacts, how rounded
the positions are; each checked on construction.

    >>> from chatterbench.comparisons.pipeline.extract_options import ExtractionOptions
    >>> ExtractionOptions().floor_steps, ExtractionOptions(position_rounding=1e-7).position_rounding   # float32 positions
    (4.0, 1e-07)
"""

from __future__ import annotations

from dataclasses import dataclass

from chatterbench.reference.errors import check_number

from .tolerances import ToleranceError


@dataclass(frozen=True)
class ExtractionOptions:
    """Internal thresholds of the extraction (their roles in ``extract``'s module docstring, rules 2 and 3)."""

    band: float = 0.1  # [-] bounces with less chatter left than this fraction of the stick tolerance do not matter
    floor_steps: float = 4.0  # [steps] nor do flights shorter than this many timesteps
    jump_factor: float = 2.0  # [-] a free step hides an impact if its velocity jump exceeds this times |y''| dt
    jump_atol: float = 1e-9  # [m/s] ... and this absolute floor (for |y''| = 0)
    position_rounding: float = 0.0  # [m] how far the positions are rounded (a float32 file's): two samples' positions
    # give a velocity only where twice this over the step is under the half-step offset |y''| dt / 2 it corrects

    def __post_init__(self) -> None:
        check_number("extraction band", self.band, lo=0.0, hi=1e3, lo_open=True, error=ToleranceError)
        check_number("extraction floor_steps", self.floor_steps, lo=0.0, hi=1e6, lo_open=True, error=ToleranceError)
        check_number("extraction jump_factor", self.jump_factor, lo=0.0, hi=1e6, error=ToleranceError)
        check_number("extraction jump_atol", self.jump_atol, lo=0.0, hi=1e6, error=ToleranceError)
        check_number("extraction position_rounding", self.position_rounding, lo=0.0, hi=1e6, error=ToleranceError)
