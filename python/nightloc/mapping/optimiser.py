"""Solving the teach run's pose graph.

Pose graphs are not convex in the headings: started from a dead reckoning that has drifted by
a large angle, a local optimiser can settle in a wrong minimum. So the graph is solved in the
field's usual order (as LAGO does):

1. **headings** alone, a linear least-squares problem on the unwrapped angles (odometry turns
   and visual relative headings, each visual measurement wrapped to the turn nearest the
   current estimate), re-weighted with the Cauchy kernel a few times (:func:`solve_headings`);
2. **positions** given those headings, linear again (odometry steps rotated into the map frame,
   coinciding places of strong matches, the closed loop) (:func:`solve_positions`);
3. the whole graph in GTSAM from there, Levenberg-Marquardt under the robust kernels, then each
   pose's marginal covariance (:func:`optimise_graph`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from ..errors import MappingError
from .candidates import VisualConstraint
from .factors import build_graph, require_gtsam

__all__ = [
    "GraphSolution",
    "HeadingSolution",
    "optimise_graph",
    "solve_heading_graph",
    "solve_headings",
    "solve_positions",
]

_ANCHOR = 1.0e6  # weight holding frame 0 at the origin in the linear steps


def _cauchy(whitened: np.ndarray, scale: float) -> np.ndarray:
    return 1.0 / (1.0 + (whitened / scale) ** 2)


@dataclass(frozen=True)
class HeadingSolution:
    """The linear heading stage's result.

    Attributes:
        headings: ``(N,)`` unwrapped headings, radians (frame 0 at 0).
        turn_bias: radians per step, the odometry's estimated turn bias (0 when not estimated):
            each measured turn read this much too far counter-clockwise.
    """

    headings: np.ndarray
    turn_bias: float = 0.0


def solve_headings(
    turns: np.ndarray,
    turn_std: np.ndarray,
    constraints: list[VisualConstraint],
    initial: np.ndarray,
    robust_scale: float,
    iterations: int = 5,
) -> np.ndarray:
    """``(N,)`` unwrapped headings (frame 0 at 0) best fitting the turns and the visual headings
    (:func:`solve_heading_graph` without a turn bias or stages)."""
    return solve_heading_graph(turns, turn_std, constraints, initial, robust_scale, iterations).headings


def _stage_limits(separation: np.ndarray | None, first_stage: float) -> list[float]:
    """The stages' limits on the constraints' separation: ``first_stage``, doubling while below the
    largest separation, then all (one stage, all, without ``separation``)."""
    if separation is None:
        return [np.inf]
    far = float(np.max(separation)) if len(separation) else 0.0
    limits = []
    limit = max(float(first_stage), 1e-9)
    while limit < far:
        limits.append(limit)
        limit *= 2.0
    limits.append(np.inf)
    return limits


def _weighted_heading_solve(
    turns: np.ndarray,
    turn_std: np.ndarray,
    ui: np.ndarray,
    uj: np.ndarray,
    unwrapped: np.ndarray,
    weight_visual: np.ndarray,
    turn_bias_std: float | None,
) -> np.ndarray:
    """One weighted linear least-squares solve: the ``N`` headings (radians; N - 1 = len(turns))
    and, with ``turn_bias_std``, the turn bias after them, from the odometry turns, the visual
    relative headings ``unwrapped`` between frames ``ui`` and ``uj`` with their weights, and the
    anchor theta_0 = 0."""
    n = len(turns) + 1
    unknowns = n + (1 if turn_bias_std is not None else 0)
    odo = np.arange(n - 1)
    # rows: theta_j - theta_i (+ bias for an odometry turn) = target; theta_0 = 0; bias = 0
    k_odo, k_vis = n - 1, len(ui)
    row = np.arange(k_odo + k_vis)
    one = np.ones(1)
    data: list[np.ndarray] = [np.ones(k_odo + k_vis), -np.ones(k_odo + k_vis), one]
    rows: list[np.ndarray] = [row, row, np.array([k_odo + k_vis])]
    cols: list[np.ndarray] = [np.concatenate([odo + 1, uj]), np.concatenate([odo, ui]), np.zeros(1, np.intp)]
    weights: list[np.ndarray] = [1.0 / np.asarray(turn_std, np.float64) ** 2, weight_visual, one * _ANCHOR]
    targets: list[np.ndarray] = [turns, unwrapped, np.zeros(1)]
    count = k_odo + k_vis + 1
    if turn_bias_std is not None:
        data += [np.ones(k_odo), one]
        rows += [np.arange(k_odo), np.array([count])]
        cols += [np.full(k_odo, n), np.array([n])]
        weights.append(one / max(float(turn_bias_std), 1e-12) ** 2)
        targets.append(np.zeros(1))
        count += 1
    design = scipy.sparse.csr_matrix(
        (np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))), shape=(count, unknowns)
    )
    w = np.concatenate(weights)
    normal = (design.T @ scipy.sparse.diags(w) @ design).tocsc()
    solution = scipy.sparse.linalg.spsolve(normal, design.T @ (w * np.concatenate(targets)))
    return solution


def solve_heading_graph(
    turns: np.ndarray,
    turn_std: np.ndarray,
    constraints: list[VisualConstraint],
    initial: np.ndarray,
    robust_scale: float,
    iterations: int = 5,
    *,
    turn_bias_std: float | None = None,
    separation: np.ndarray | None = None,
    first_stage: float = 10.0,
) -> HeadingSolution:
    """Headings (and the odometry's turn bias) best fitting the turns and the visual headings:
    linear least squares on the unwrapped angles, the visual rows Cauchy-reweighted.

    Each visual measurement is known only modulo a full turn; it is unwrapped to the turn nearest
    the current estimate. A dead reckoning far into a long drive can be off by more than half a
    turn, so with ``separation`` the constraints join in stages: first those at most
    ``first_stage`` (e.g. metres of driving) apart, then twice as far, and so on, each stage
    unwrapping against the estimate the nearer ones corrected.

    Args:
        turns: ``(N - 1,)`` odometry turns, radians; turn_std: their standard deviations (the
            per-step noise alone when the bias is estimated).
        constraints: visual relative headings.
        initial: ``(N,)`` current headings (to unwrap each visual measurement against).
        robust_scale: Cauchy scale in standard deviations (visual rows only).
        iterations: re-weightings per stage.
        turn_bias_std: radians per step, the prior spread of a constant turn bias added to every
            measured turn (a variable of the solution); None: no bias.
        separation: ``(len(constraints),)`` how far apart each constraint's frames are along the
            drive (e.g. metres driven between them); None: all in one stage.
        first_stage: the first stage's largest separation.
    """
    n = len(turns) + 1
    turns = np.asarray(turns, dtype=np.float64)
    heading = np.asarray(initial, dtype=np.float64).copy()
    if not constraints:
        return HeadingSolution(np.concatenate([[0.0], np.cumsum(turns)]))
    ci = np.array([c.i for c in constraints])
    cj = np.array([c.j for c in constraints])
    measured = np.array([c.heading for c in constraints])
    std = np.array([c.heading_std for c in constraints])
    limits = _stage_limits(separation, first_stage)
    bias = 0.0
    for stage, limit in enumerate(limits):
        use = np.ones(len(constraints), bool) if separation is None else np.asarray(separation) <= limit
        ui, uj, um, us = ci[use], cj[use], measured[use], std[use]
        for iteration in range(iterations):
            predicted = heading[uj] - heading[ui]
            unwrapped = um + 2 * np.pi * np.round((predicted - um) / (2 * np.pi))
            if stage == 0 and iteration == 0 and turn_bias_std is not None:
                # plain least squares first: from a dead reckoning bent by the bias, every visual
                # heading looks like an outlier to the kernel, which would then keep the bend
                weight_visual = 1.0 / us**2
            else:
                weight_visual = _cauchy((predicted - unwrapped) / us, robust_scale) / us**2
            solution = _weighted_heading_solve(turns, turn_std, ui, uj, unwrapped, weight_visual, turn_bias_std)
            heading = np.asarray(solution[:n])
            bias = float(solution[n]) if turn_bias_std is not None else 0.0
    return HeadingSolution(heading, bias)


def solve_positions(
    headings: np.ndarray,
    steps: np.ndarray,
    step_covariances: np.ndarray,
    constraints: list[VisualConstraint],
    robust_scale: float,
    closed_loop_std: float | None = None,
    iterations: int = 5,
) -> np.ndarray:
    """``(N, 2)`` positions (frame 0 at the origin) given the headings.

    Each odometry step, rotated into the map frame by its start heading, relates consecutive
    positions with its covariance; strong place pairs say two positions coincide (Cauchy
    re-weighted); the closed loop that the last position is the first.
    """
    n = len(steps) + 1
    c, s = np.cos(headings[:-1]), np.sin(headings[:-1])
    rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (N-1, 2, 2)
    delta = np.einsum("kab,kb->ka", rot, steps[:, :2])
    info = np.linalg.inv(rot @ step_covariances[:, :2, :2] @ np.swapaxes(rot, 1, 2))
    pairs_i = list(range(n - 1))
    pairs_j = list(range(1, n))
    strong = [c for c in constraints if c.position_std is not None]
    abeam = [c for c in constraints if c.along is not None and c.position_std is None]
    # abeam rows: x_i - x_j = along * u (u: j's direction of travel in the map frame), weighed along u only
    if abeam:
        angle = np.array([headings[c.j] + c.along_direction for c in abeam])
        u = np.stack([np.cos(angle), np.sin(angle)], axis=1)
        along = np.array([c.along for c in abeam], dtype=np.float64)
        along_std = np.array([c.along_std for c in abeam])
        outer = np.einsum("ka,kb->kab", u, u) + np.eye(2) * 1e-9
    loop = [] if closed_loop_std is None else [(0, n - 1)]
    positions = np.zeros((n, 2))
    for _ in range(iterations if strong or abeam else 1):
        fi = np.array(pairs_i + [c.i for c in strong] + [c.j for c in abeam] + [p[0] for p in loop], dtype=np.intp)
        fj = np.array(pairs_j + [c.j for c in strong] + [c.i for c in abeam] + [p[1] for p in loop], dtype=np.intp)
        targets = np.concatenate([delta, np.zeros((len(strong), 2))] + ([u * along[:, None]] if abeam else []))
        targets = np.concatenate([targets, np.zeros((len(loop), 2))])
        weights = [info]
        if strong:
            std = np.array([c.position_std for c in strong])
            residual = np.hypot(*(positions[[c.j for c in strong]] - positions[[c.i for c in strong]]).T) / std
            scale = _cauchy(residual, robust_scale) / std**2
            weights.append(scale[:, None, None] * np.eye(2))
        if abeam:
            offset = positions[[c.i for c in abeam]] - positions[[c.j for c in abeam]]
            residual = np.abs(np.sum(offset * u, axis=1) - along) / along_std
            scale = _cauchy(residual, robust_scale) / along_std**2
            weights.append(scale[:, None, None] * outer)
        if closed_loop_std is not None:
            weights.append(np.eye(2)[None] / closed_loop_std**2)
        w = np.concatenate(weights)
        normal = _block_laplacian(n, fi, fj, w)
        rhs = np.zeros((n, 2))
        wd = np.einsum("kab,kb->ka", w, targets)
        np.add.at(rhs, fj, wd)
        np.add.at(rhs, fi, -wd)
        normal = normal + scipy.sparse.csc_matrix(([_ANCHOR, _ANCHOR], ([0, 1], [0, 1])), shape=(2 * n, 2 * n))
        positions = scipy.sparse.linalg.spsolve(normal.tocsc(), rhs.reshape(-1)).reshape(n, 2)
    return positions


def _block_laplacian(n: int, fi: np.ndarray, fj: np.ndarray, w: np.ndarray) -> scipy.sparse.csc_matrix:
    """``sum_k A_k^T W_k A_k`` for rows ``x_j - x_i`` with 2x2 weights: a (2N, 2N) sparse matrix."""
    a, b = np.meshgrid(np.arange(2), np.arange(2), indexing="ij")
    rows, cols, vals = [], [], []
    for p, q, sign in ((fi, fi, 1.0), (fj, fj, 1.0), (fi, fj, -1.0), (fj, fi, -1.0)):
        rows.append((2 * p[:, None, None] + a).reshape(-1))
        cols.append((2 * q[:, None, None] + b).reshape(-1))
        vals.append((sign * w).reshape(-1))
    return scipy.sparse.csc_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(2 * n, 2 * n)
    )


@dataclass(frozen=True)
class GraphSolution:
    """The optimised poses and what the optimiser made of each visual constraint.

    Attributes:
        poses: ``(N, 3)`` x, y (metres), heading (radians, in (-pi, pi]) in the map frame.
        covariances: ``(N, 3, 3)`` marginal covariances of (x, y, heading) in the map frame.
        residuals: ``(len(constraints),)`` each visual constraint's whitened residual (standard
            deviations) at the solution; the report counts those within the gate as accepted.
        initial_error, final_error: the graph's error (robust) before and after optimisation.
        iterations: Levenberg-Marquardt iterations.
    """

    poses: np.ndarray
    covariances: np.ndarray
    residuals: np.ndarray
    initial_error: float
    final_error: float
    iterations: int


def constraint_residuals(poses: np.ndarray, constraints: list[VisualConstraint]) -> np.ndarray:
    """Whitened residual (standard deviations) of every constraint at ``poses``: the heading's,
    or for a strong pair the larger of the heading's and the positions' distance."""
    out = np.zeros(len(constraints))
    for k, c in enumerate(constraints):
        turn = poses[c.j, 2] - poses[c.i, 2] - c.heading
        residual = abs(math.remainder(turn, 2 * math.pi)) / c.heading_std
        if c.position_std is not None:
            residual = max(residual, float(np.hypot(*(poses[c.j, :2] - poses[c.i, :2]))) / c.position_std)
        elif c.along is not None:
            angle = poses[c.j, 2] + c.along_direction
            offset = poses[c.i, :2] - poses[c.j, :2]
            along = offset[0] * math.cos(angle) + offset[1] * math.sin(angle)
            residual = max(residual, abs(along - c.along) / c.along_std)
        out[k] = residual
    return out


def optimise_graph(
    initial: np.ndarray,
    steps: np.ndarray,
    step_covariances: np.ndarray,
    constraints: list[VisualConstraint],
    *,
    robust_scale: float,
    closed_loop_std: float | None = None,
    max_iterations: int = 100,
    marginal_stride: int = 1,
) -> GraphSolution:
    """Levenberg-Marquardt on the whole graph from ``initial`` (``(N, 3)`` poses), then marginals.

    ``marginal_stride`` > 1 computes the marginal covariance of every that many frames (and the
    last) and interpolates the others along the drive, element by element: the uncertainty varies
    smoothly along a drive, and each marginal costs a Bayes-tree query (the teach run's
    intermediate rounds, which only gate candidates with it, take about 100 along the drive).

    Raises:
        MappingError: the optimiser fails or returns non-finite poses or covariances.
    """
    gtsam = require_gtsam()
    graph = build_graph(
        steps, step_covariances, constraints, robust_scale=robust_scale, closed_loop_std=closed_loop_std
    )
    values = gtsam.Values()
    for k, (x, y, h) in enumerate(initial):
        values.insert(k, gtsam.Pose2(float(x), float(y), float(h)))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(max_iterations)
    n = len(initial)
    try:
        initial_error = float(graph.error(values))
        optimizer = gtsam.LevenbergMarquardtOptimizer(graph, values, params)
        result = optimizer.optimize()
        final_error = float(graph.error(result))
        poses = np.array([[p.x(), p.y(), p.theta()] for p in (result.atPose2(k) for k in range(n))])
        marginals = gtsam.Marginals(graph, result)
        keys = np.unique(np.append(np.arange(0, n, max(1, int(marginal_stride))), n - 1))
        sampled = np.array([marginals.marginalCovariance(int(k)) for k in keys])
    except (RuntimeError, IndexError, ValueError) as error:  # gtsam's IndeterminantLinearSystemException, ...
        raise MappingError(f"the pose graph of {n} frames could not be solved: {error}") from None
    if not (np.isfinite(poses).all() and np.isfinite(sampled).all() and math.isfinite(final_error)):
        raise MappingError(f"the pose graph of {n} frames has no finite solution (a degenerate odometry log?)")
    # GTSAM states a Pose2's covariance in its own (body) frame; the map's is in the map frame.
    # Turned into the map frame first, then interpolated: a robot turning on the spot between
    # two sampled frames turns its body frame, not its uncertainty.
    c, s = np.cos(poses[keys, 2]), np.sin(poses[keys, 2])
    turn = np.zeros((len(keys), 3, 3))
    turn[:, 0, 0], turn[:, 0, 1], turn[:, 1, 0], turn[:, 1, 1], turn[:, 2, 2] = c, -s, s, c, 1.0
    in_map = turn @ sampled @ np.swapaxes(turn, 1, 2)
    frames = np.arange(n)
    covariances = np.stack(
        [np.interp(frames, keys, in_map[:, a, b]) for a in range(3) for b in range(3)], axis=1
    ).reshape(n, 3, 3)
    covariances = 0.5 * (covariances + np.swapaxes(covariances, 1, 2))
    return GraphSolution(
        poses=poses,
        covariances=covariances,
        residuals=constraint_residuals(poses, constraints),
        initial_error=initial_error,
        final_error=final_error,
        iterations=int(optimizer.iterations()),
    )
