"""The teach run: a reference map from the robot's own day drive, without a survey.

``teach_run(traverse)`` reads the drive's wheel odometry (``odometry.csv``: ``image,forward,
left,turn``), chains it into a dead reckoning (the start), prepares every frame, matches every
frame against every other (:func:`nightloc.difference_matrix`), picks and measures visual
constraints (:mod:`~nightloc.mapping.candidates`), solves the pose graph
(:mod:`~nightloc.mapping.optimiser`, GTSAM) and re-measures with the better estimate
(``rounds`` times), then builds the :class:`~nightloc.ReferenceMap` (pose source
``"optimised"``, each pose's marginal covariance). Its frame is the drive's odometry frame:
frame 0 at the origin, heading 0. Without a single visual constraint (images that never
overlap, a forward camera) the map is the dead reckoning, with a warning.
"""

from __future__ import annotations

import dataclasses
import os
import time
import warnings
from dataclasses import dataclass
from typing import Union

import numpy as np

from ..errors import MappingError
from ..io.traverse import Traverse, load_traverse
from ..matching.sad import difference_matrix
from ..motion.odometry import MapDisplacement, RobotMotion, traverse_odometry
from ..preparation.params import PreparationParams
from ..preparation.preparer import Preparer
from .candidates import VisualConstraint, candidate_pairs, measure_constraints
from .dead_reckoning import compose_steps, dead_reckoning
from .factors import require_gtsam
from .optimiser import GraphSolution, optimise_graph, solve_heading_graph, solve_positions
from .params import TeachParams
from .reference_map import ReferenceMap
from .warping import PanoramaWarper

__all__ = ["TeachParams", "TeachReport", "TeachWarning", "odometry_steps", "teach_poses", "teach_run"]

PathLike = Union[str, "os.PathLike[str]"]


class TeachWarning(UserWarning):
    """The teach run built a map, but a weaker one than asked (e.g. dead reckoning only)."""


@dataclass(frozen=True)
class TeachReport:
    """What a teach run did.

    Attributes:
        frames: frames in the map.
        pose_source: ``"optimised"`` or ``"dead-reckoned"``.
        dead_reckoning: ``(N, 3)`` the odometry chained alone (x, y, heading).
        poses: ``(N, 3)`` the map's poses.
        constraints: the visual constraints of the last round.
        accepted, rejected: visual constraints within / beyond the accept gate at the solution.
        gated_out: candidate pairs dropped by the distance gate (last round).
        solution: the optimiser's :class:`~nightloc.mapping.optimiser.GraphSolution`, or None.
        seconds: wall time of the whole run.
        warnings: what the map lacks, in words (also issued as :class:`TeachWarning`).
        accept_gate: the gate the counts used (standard deviations).
        covariances: ``(N, 3, 3)`` the map's pose covariances.
    """

    frames: int
    pose_source: str
    dead_reckoning: np.ndarray
    poses: np.ndarray
    constraints: tuple[VisualConstraint, ...]
    accepted: int
    rejected: int
    gated_out: int
    solution: GraphSolution | None
    seconds: float
    warnings: tuple[str, ...] = ()
    accept_gate: float = 3.0
    covariances: np.ndarray | None = None

    @property
    def covariances_summary(self) -> tuple[float, float] | None:
        """Median and largest position standard deviation (metres, the larger axis of each
        pose's covariance ellipse), or None without covariances."""
        if self.covariances is None:
            return None
        largest = np.sqrt(np.linalg.eigvalsh(self.covariances[:, :2, :2])[:, -1].clip(min=0.0))
        return float(np.median(largest)), float(largest.max())

    def counts_by_kind(self) -> dict[str, tuple[int, int]]:
        """``{kind: (accepted, rejected)}`` for ``"sequence"`` and ``"place"`` constraints."""
        out = {"sequence": [0, 0], "place": [0, 0]}
        if self.solution is not None:
            for c, residual in zip(self.constraints, self.solution.residuals):
                out[c.kind][0 if residual <= self.accept_gate else 1] += 1
        return {k: (v[0], v[1]) for k, v in out.items()}


def odometry_steps(odometry: list, names: tuple[str, ...] | None = None) -> np.ndarray:
    """``(N - 1, 3)`` robot-frame steps from a traverse's motions (element 0, before the first
    frame, is ignored).

    Raises:
        MappingError: a motion is missing, or the log is map-frame displacements (``dx, dy``):
            the pose graph needs the robot-frame steps of wheel odometry.
    """
    steps = []
    for k, motion in enumerate(odometry[1:], start=1):
        where = f"frame {k}" + (f" ({names[k]})" if names is not None else "")
        if isinstance(motion, MapDisplacement):
            raise MappingError(
                "a teach run needs wheel odometry (odometry.csv with columns image,forward,left,turn); this log holds "
                "map-frame displacements (dx,dy), which already are a map: give the traverse poses.csv instead"
            )
        if not isinstance(motion, RobotMotion):
            raise MappingError(f"the odometry has no motion before {where}; every frame after the first needs one")
        steps.append((motion.forward, motion.left, motion.turn))
    steps_array = np.array(steps, dtype=np.float64).reshape(-1, 3)
    if not np.isfinite(steps_array).all():
        raise MappingError("the odometry holds NaN or infinity")
    return steps_array


def teach_run(
    traverse: Traverse | PathLike,
    params: PreparationParams | None = None,
    teach: TeachParams | None = None,
    *,
    odometry: list | None = None,
    threads: int | None = None,
) -> tuple[ReferenceMap, TeachReport]:
    """Builds a reference map from a day drive's frames and wheel odometry (no poses needed).

    Args:
        traverse: the drive (a folder with images/ and odometry.csv; any poses.csv is ignored).
        params: preparation parameters (default the paper's).
        teach: :class:`TeachParams` (default the documented defaults).
        odometry: the drive's motions (one per frame, element 0 None) instead of its odometry.csv.
        threads: matching threads (default all cores).

    Returns:
        ``(map, report)``: the :class:`~nightloc.ReferenceMap` (pose source ``"optimised"``, or
        ``"dead-reckoned"`` without any visual constraint) and a :class:`TeachReport`.

    Raises:
        DatasetError: odometry.csv missing, malformed, a frame without a row, non-finite values.
        MappingError: map-frame odometry, fewer than 2 frames, or a graph that cannot be solved.
        MissingDependencyError: GTSAM is not installed (``pip install "nightloc[mapping]"``).
    """
    start = time.perf_counter()
    require_gtsam()  # before any slow work
    teach = teach or TeachParams()
    if not isinstance(teach, TeachParams):
        raise TypeError(f"teach must be a TeachParams, got {type(teach).__name__}")
    if not isinstance(traverse, Traverse):
        traverse = load_traverse(traverse)
    if odometry is None:
        odometry = traverse_odometry(traverse)
    if len(odometry) != len(traverse):
        raise MappingError(f"{len(odometry)} odometry motions for the {len(traverse)} frames of {traverse.root}")
    if len(traverse) < 2:
        raise MappingError(f"{traverse.root} has {len(traverse)} frame; a teach run needs a drive of at least 2")
    steps = odometry_steps(list(odometry), traverse.names)
    preparer = Preparer(params)
    first = traverse.read(0)  # the camera's frame size, recorded for the queries' check
    images = preparer.prepare(traverse)
    if images.ndim == 2:
        images = images[np.newaxis]
    final, covariances, source, constraints, solution, gated_out, notes = teach_poses(
        images, steps, teach, panoramic=preparer.params.wrap, threads=threads
    )
    for note in notes:
        warnings.warn(note, TeachWarning, stacklevel=2)
    headings_out = np.pi - np.mod(np.pi - final[:, 2], 2 * np.pi)
    reference_map = ReferenceMap(
        images,
        final[:, :2],
        headings_out,
        traverse.names,
        preparer.params,
        str(traverse.root),
        frame_size=(first.shape[1], first.shape[0]),
        pose_source=source,
        covariances=covariances,
    )
    residuals = solution.residuals if solution is not None else np.zeros(0)
    accepted = int(np.sum(residuals <= teach.accept_gate))
    report = TeachReport(
        frames=len(traverse),
        pose_source=source,
        dead_reckoning=compose_steps(steps),
        poses=np.column_stack([final[:, :2], headings_out]),
        constraints=tuple(constraints) if solution is not None else (),
        accepted=accepted,
        rejected=int(len(residuals) - accepted),
        gated_out=gated_out,
        solution=solution,
        seconds=time.perf_counter() - start,
        warnings=tuple(notes),
        accept_gate=teach.accept_gate,
        covariances=covariances,
    )
    return reference_map, report


@dataclasses.dataclass(frozen=True)
class _TeachDrive:
    """What every round of a teach run reads: the prepared images ``(N, H, W)``, the odometry
    steps ``(N - 1, 3)`` and their covariances ``(N - 1, 3, 3)`` (with the turn bias, and without
    it: each step's own noise, for a graph that estimates the bias), the turns' standard
    deviations of both (radians), the images' difference matrix ``(N, N)``, the warper (or None)
    and the path length at each frame ``(N,)`` metres."""

    images: np.ndarray
    steps: np.ndarray
    step_cov: np.ndarray
    free_step_cov: np.ndarray
    turn_std: np.ndarray
    free_turn_std: np.ndarray
    scores: np.ndarray
    warper: PanoramaWarper | None
    path_length: np.ndarray

    @classmethod
    def of(
        cls, images: np.ndarray, steps: np.ndarray, step_cov: np.ndarray, teach: TeachParams, threads: int | None
    ) -> _TeachDrive:
        scores, _ = difference_matrix(images, images, threads=threads)
        warper = PanoramaWarper(images, teach.warp, threads) if teach.heading_method == "warp" else None
        # with the turn bias a variable, each step's own noise alone
        free_step_cov = dataclasses.replace(teach.wheel_noise, turn_bias_std=0.0).step_covariances(
            steps[:, 0], steps[:, 1]
        )
        return cls(
            images,
            steps,
            step_cov,
            free_step_cov,
            np.sqrt(step_cov[:, 2, 2]),
            np.sqrt(free_step_cov[:, 2, 2]),
            scores,
            warper,
            np.concatenate([[0.0], np.cumsum(np.hypot(steps[:, 0], steps[:, 1]))]),
        )


def _round_constraints(
    drive: _TeachDrive, teach: TeachParams, poses: np.ndarray, covariances: np.ndarray
) -> tuple[list[VisualConstraint], int]:
    """One round's visual constraints between the candidate pairs that the poses ``(N, 3)`` and
    their covariances ``(N, 3, 3)`` allow, and the candidates the distance gate dropped."""
    position_std = np.sqrt(np.linalg.eigvalsh(covariances[:, :2, :2])[:, -1].clip(min=0.0))
    heading_std = np.sqrt(covariances[:, 2, 2].clip(min=0.0))
    pairs, gated_out = candidate_pairs(
        drive.scores,
        poses,
        sequence_window=teach.sequence_window,
        max_distance=teach.max_distance,
        place_candidates=teach.place_candidates,
        strong_score=teach.strong_score,
        position_std=position_std,
        gate_sigmas=teach.gate_sigmas,
    )
    constraints = measure_constraints(
        drive.images,
        pairs,
        poses,
        heading_std=teach.heading_std,
        heading_std_per_metre=teach.heading_std_per_metre,
        axis_half_width=teach.axis_half_width,
        strong_score=teach.strong_score,
        place_position_std=teach.place_position_std,
        max_distance=teach.max_distance,
        scores=drive.scores if teach.along_std > 0 else None,
        along_std=teach.along_std,
        along_std_per_metre=teach.along_std_per_metre,
        path_length=drive.path_length,
        along_min_path=teach.along_min_path,
        heading_uncertainty=heading_std,
        unsure_heading=teach.unsure_heading,
        warper=drive.warper,
        direction_range=teach.direction_range,
    )
    return constraints, gated_out


def _solve_round(
    drive: _TeachDrive, teach: TeachParams, constraints: list[VisualConstraint], poses: np.ndarray, last: bool
) -> GraphSolution:
    """One round's graph: the headings (with the turn bias), then the positions, then the whole
    pose graph from them (the ``last`` round with more marginals)."""
    steps = drive.steps
    path_length = drive.path_length
    separation = np.array([abs(path_length[c.j] - path_length[c.i]) for c in constraints])
    heading_solution = solve_heading_graph(
        steps[:, 2],
        drive.free_turn_std if teach.estimate_turn_bias else drive.turn_std,
        constraints,
        poses[:, 2],
        teach.robust_scale,
        turn_bias_std=teach.wheel_noise.turn_bias_std if teach.estimate_turn_bias else None,
        separation=separation if teach.unwrap_stage > 0 else None,
        first_stage=teach.unwrap_stage,
    )
    headings = heading_solution.headings
    corrected = steps.copy()
    corrected[:, 2] -= heading_solution.turn_bias
    corrected_cov = drive.free_step_cov if teach.estimate_turn_bias else drive.step_cov
    positions = solve_positions(
        headings,
        corrected,
        corrected_cov,
        constraints,
        teach.robust_scale,
        teach.closed_loop_std if teach.closed_loop else None,
    )
    return optimise_graph(
        np.column_stack([positions, headings]),
        corrected,
        corrected_cov,
        constraints,
        robust_scale=teach.robust_scale,
        closed_loop_std=teach.closed_loop_std if teach.closed_loop else None,
        # intermediate rounds gate with about 100 marginals along the drive (interpolated in
        # the map frame), the last has every frame's up to 999 frames, then about 500
        marginal_stride=max(1, len(drive.images) // (500 if last else 100)),
    )


def teach_poses(
    images: np.ndarray,
    steps: np.ndarray,
    teach: TeachParams | None = None,
    *,
    panoramic: bool = True,
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray, str, list[VisualConstraint], GraphSolution | None, int, list[str]]:
    """The teach run on prepared images: poses from the odometry and the images.

    Args:
        images: ``(N, H, W)`` uint8 prepared panoramas of the drive's frames, in order.
        steps: ``(N - 1, 3)`` wheel odometry between them (robot frame: forward, left, turn).
        teach: parameters (default :class:`TeachParams`).
        panoramic: the images are 360-degree panoramas (else no relative heading is measured).
        threads: matching threads.

    Returns:
        ``(poses, covariances, source, constraints, solution, gated_out, notes)``: ``(N, 3)``
        poses (headings unwrapped), ``(N, 3, 3)`` covariances, ``"optimised"`` or
        ``"dead-reckoned"``, the last round's constraints, the optimiser's solution (or None),
        the candidates the distance gate dropped, and what the map lacks in words.
    """
    teach = teach or TeachParams()
    wheel_noise = teach.wheel_noise
    step_cov = wheel_noise.step_covariances(steps[:, 0], steps[:, 1])
    reckoned, reckoned_cov = dead_reckoning(steps, wheel_noise)
    notes: list[str] = []
    constraints: list[VisualConstraint] = []
    gated_out = 0
    solution = None
    if panoramic:
        drive = _TeachDrive.of(images, steps, step_cov, teach, threads)
        poses, covariances_now = reckoned.copy(), reckoned_cov
        for round_index in range(teach.rounds):
            constraints, gated_out = _round_constraints(drive, teach, poses, covariances_now)
            if not constraints:
                break
            solution = _solve_round(drive, teach, constraints, poses, round_index == teach.rounds - 1)
            poses = solution.poses.copy()
            poses[:, 2] = np.unwrap(poses[:, 2])
            covariances_now = solution.covariances
    else:
        notes.append("a forward camera (wrap=False) gives no relative headings")
    if solution is None or not constraints:
        solution = None
        notes.append(
            "no two frames of the drive matched as one place (images that never overlap?): the map is the "
            "dead reckoning of the wheel odometry alone"
        )
        return reckoned, reckoned_cov, "dead-reckoned", [], None, gated_out, notes
    return solution.poses, solution.covariances, "optimised", constraints, solution, gated_out, notes
