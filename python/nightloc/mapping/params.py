"""The teach run's parameters (TOML table ``[teach]``; defaults from the sweeps in docs/teach_run.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from ..config import params_section
from ..motion.wheel_noise import WheelNoise
from ..schema import ABOVE_0, AT_LEAST_0, Range, own_field
from .warping import WarpParams

__all__ = ["TeachParams"]

_FRACTION = AT_LEAST_0  # fractions of a step: WheelNoise checks they stay below 0.5


@params_section("teach")
@dataclass(frozen=True)
class TeachParams:
    """Parameters of the teach run (TOML ``[teach]``; defaults from the sweeps in docs/teach_run.md).

    Attributes:
    The wheel odometry's error model (the odometry factors' covariance; :class:`WheelNoise`):
        odometry_scale_std: per-run scale error of every step's length (fraction).
        odometry_distance_std: per-step length noise (fraction of the step).
        odometry_turn_std: per-step turn noise, radians.
        odometry_turn_bias_std: per-run turn bias, radians per step.
        estimate_turn_bias: the turn bias is a variable of the heading solution (observed by the
            images' relative headings), taken off every turn before the positions are solved.
        unwrap_stage: metres of driving; the heading solution takes in the visual headings of
            frames at most this far apart first, then twice as far, and so on (each unwrapped
            to the full turn nearest the estimate the nearer ones corrected); 0: all at once.

    Which pairs of frames are compared:
        sequence_window: each frame's heading is compared with the next this many frames.
        max_distance: metres; pairs the current estimate puts farther apart are not compared
            (unless their match is strong).
        place_candidates: best-matching frames (outside the sequence window) tried per frame.
        strong_score: a place pair scoring at most this (mean absolute difference of prepared
            images) was taken at one spot: its positions are tied too.
        gate_sigmas: a place pair's distance gate widens by this many standard deviations of
            the two positions (the estimate's marginal covariances).

    How a pair's relative heading is measured:
        heading_method: ``"warp"``: min-warping (:mod:`~nightloc.mapping.warping`: heading and
            direction of travel together, each column free to move along its parallax);
            ``"axis"``: the columns along the line between the two places.
        heading_std, heading_std_per_metre: a visual heading's standard deviation, radians,
            ``heading_std + heading_std_per_metre * distance`` (parallax grows with distance;
            0.03 suits min-warping, 0.05 the less sure ``"axis"`` headings).
        unsure_heading: radians; a place pair whose relative heading the estimate knows less
            well than this is measured at every shift (and, warping, every direction).
        axis_half_width: radians; ``"axis"``: columns compared either side of the line.
        direction_range: radians; ``"warp"``: directions of travel tried either side of the
            estimate's.
        elevation_top_deg, elevation_bottom_deg: ``"warp"``: degrees of elevation of the
            prepared images' top and bottom edges (the camera's vertical view; rows equally
            spaced in elevation).

    Positions from the images:
        place_position_std: metres; how far apart a strong pair's places may be.
        along_std, along_std_per_metre: metres; the standard deviation of where a place pair's
            frame lies along the other frame's pass, ``along_std + along_std_per_metre *
            distance``; ``along_std`` 0 measures none.
        along_min_path: metres of driving between two passes for an along-pass position.

    The graph:
        robust_scale: the Cauchy kernel's scale, in standard deviations.
        accept_gate: standard deviations; a visual constraint whose residual at the solution is
            larger counts as rejected (the robust kernel has all but ignored it).
        closed_loop: the drive ends where it began (a dock): tie the last position to the first.
        closed_loop_std: metres, how exactly it does.
        rounds: candidates picked and measured again from the optimised estimate.
    """

    odometry_scale_std: float = own_field(0.03, range=_FRACTION)
    odometry_distance_std: float = own_field(0.03, range=_FRACTION)
    odometry_turn_std: float = own_field(0.05, unit="rad", range=AT_LEAST_0)
    odometry_turn_bias_std: float = own_field(0.01, unit="rad per step", range=AT_LEAST_0)
    estimate_turn_bias: bool = True
    unwrap_stage: float = own_field(10.0, unit="m", range=AT_LEAST_0)
    sequence_window: int = own_field(3, unit="frames", range=AT_LEAST_0)
    max_distance: float = own_field(1.5, unit="m", range=ABOVE_0)
    place_candidates: int = own_field(6, unit="frames", range=AT_LEAST_0)
    strong_score: float = own_field(10.0, unit="grey levels", range=AT_LEAST_0)
    gate_sigmas: float = own_field(3.0, unit="standard deviations", range=AT_LEAST_0)
    heading_method: Literal["warp", "axis"] = "warp"
    heading_std: float = own_field(0.005, unit="rad", range=ABOVE_0)
    heading_std_per_metre: float = own_field(0.03, unit="rad per m", range=AT_LEAST_0)
    unsure_heading: float = own_field(0.15, unit="rad", range=ABOVE_0)
    axis_half_width: float = own_field(math.radians(30.0), unit="rad", range=ABOVE_0)
    direction_range: float = own_field(math.radians(30.0), unit="rad", range=ABOVE_0)
    elevation_top_deg: float = own_field(50.0, unit="degrees")
    elevation_bottom_deg: float = own_field(-30.0, unit="degrees")
    place_position_std: float = own_field(0.25, unit="m", range=ABOVE_0)
    along_std: float = own_field(0.05, unit="m", range=AT_LEAST_0)
    along_std_per_metre: float = own_field(0.15, unit="m per m", range=AT_LEAST_0)
    along_min_path: float = own_field(30.0, unit="m", range=ABOVE_0)
    robust_scale: float = own_field(1.0, unit="standard deviations", range=ABOVE_0)
    accept_gate: float = own_field(3.0, unit="standard deviations", range=ABOVE_0)
    closed_loop: bool = False
    closed_loop_std: float = own_field(0.05, unit="m", range=ABOVE_0)
    rounds: int = own_field(4, range=Range(1, math.inf))

    def validate(self) -> None:
        """The rules the table cannot say (each field's range is checked on construction): the
        odometry model's fractions, the elevations."""
        self.wheel_noise  # noqa: B018  (the odometry fractions below 0.5)
        self.warp  # noqa: B018  (the elevations)

    @property
    def wheel_noise(self) -> WheelNoise:
        """The odometry's error model (:class:`~nightloc.motion.wheel_noise.WheelNoise`)."""
        try:
            return WheelNoise(
                scale_std=self.odometry_scale_std,
                distance_std=self.odometry_distance_std,
                turn_std=self.odometry_turn_std,
                turn_bias_std=self.odometry_turn_bias_std,
            )
        except ValueError as error:
            raise ValueError(f"TeachParams odometry_*: {error}") from None

    @property
    def warp(self) -> WarpParams:
        """The min-warping parameters (:class:`~nightloc.mapping.warping.WarpParams`)."""
        try:
            return WarpParams(elevation_top=self.elevation_top_deg, elevation_bottom=self.elevation_bottom_deg)
        except ValueError as error:
            raise ValueError(f"TeachParams elevation_top_deg / elevation_bottom_deg: {error}") from None

    @classmethod
    def with_wheel_noise(cls, noise: WheelNoise, **changes: object) -> TeachParams:
        """Parameters whose odometry model is ``noise`` (and any other ``changes``)."""
        return cls(
            odometry_scale_std=noise.scale_std,
            odometry_distance_std=noise.distance_std,
            odometry_turn_std=noise.turn_std,
            odometry_turn_bias_std=noise.turn_bias_std,
            **changes,  # type: ignore[arg-type]
        )
