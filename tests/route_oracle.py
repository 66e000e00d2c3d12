"""Independent numpy references for route mode (SeqSLAM), written from OpenSeqSLAM's Matlab code
(doContrastEnhancement.m, doFindMatches.m) and its documented Octave semantics, not from the C++.

The route filter's oracle has the C++'s shape: one function per motion model
(:func:`window_motion`, :func:`speed_motion`, :func:`odometry_motion`, named in :data:`MOTIONS`)
and the floor and off-route step they share (:func:`floor_and_exchange`), written from the
definitions in ``cpp/include/nightloc/route_filter.hpp``.

Orientation here is nightloc's: difference matrices are (n_query, n_ref), rows = queries. Every
floating-point step is done in the same order and precision as Octave: float32 sequential sums,
float32 mean, deviations, sum of squares, division and sqrt; double only for the final ratio.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

F32 = np.float32


def enhance_zscores(d: np.ndarray, radius: int = 5) -> np.ndarray:
    """Local contrast enhancement without the final offset: for every query row and reference i,
    the z-score of d[:, i] over references i-radius..i+radius (clipped), N-1 std, all float32."""
    n_query, n_ref = d.shape
    out = np.empty_like(d, dtype=F32)
    for i in range(n_ref):
        lo, hi = max(0, i - radius), min(n_ref - 1, i + radius)
        window = d[:, lo : hi + 1].astype(F32)
        count = window.shape[1]
        total = np.zeros(n_query, F32)
        for j in range(count):
            total = (total + window[:, j]).astype(F32)
        mean = (total / F32(count)).astype(F32)
        squares = np.zeros(n_query, F32)
        for j in range(count):
            dev = (window[:, j] - mean).astype(F32)
            squares = (squares + (dev * dev).astype(F32)).astype(F32)
        with np.errstate(divide="ignore", invalid="ignore"):
            sd = np.sqrt((squares / F32(count - 1)).astype(F32)).astype(F32)
            out[:, i] = ((d[:, i] - mean).astype(F32) / sd).astype(F32)
    return out


def enhance_openseqslam(d: np.ndarray, radius: int = 5) -> np.ndarray:
    """OpenSeqSLAM's enhancement: z-scores minus their global minimum (NaN ignored)."""
    z = enhance_zscores(d, radius)
    return (z - F32(np.nanmin(z))).astype(F32)


def enhance_causal(d: np.ndarray, radius: int = 5) -> np.ndarray:
    """Causal enhancement: z-scores plus the fixed bound (n-1)/sqrt(n), n = 2*radius+1."""
    n = 2 * radius + 1
    bound = F32((n - 1) / math.sqrt(n))
    return (enhance_zscores(d, radius) + bound).astype(F32)


def velocity_offsets(ds: int, vmin: float, vmax: float, steps: int) -> np.ndarray:
    """(n_velocities, steps) int64 row offsets floor(k * move/ds), moves vmin*ds : vmax*ds by 1."""
    moves = []
    move = vmin * ds
    while move <= vmax * ds + 1e-9:
        moves.append(move)
        move += 1.0
    v = np.array(moves) / ds
    return np.floor(np.arange(steps)[None, :] * v[:, None]).astype(np.int64)


def _nanmin_first(values: np.ndarray) -> tuple:
    """(min, first index) ignoring NaN; all NaN -> (nan, 0), like Octave's min."""
    present = np.flatnonzero(~np.isnan(values))
    if present.size == 0:
        return math.nan, 0
    index = int(present[np.argmin(values[present])])  # (numpy's nanargmin would treat NaN as +inf)
    return float(values[index]), index


def _decide(anchor_scores: np.ndarray, window: int) -> tuple:
    best, index = _nanmin_first(anchor_scores)
    mask = np.ones(len(anchor_scores), bool)
    mask[max(0, index - window) : index + window + 1] = False
    rest = anchor_scores[mask]
    second = math.nan if rest.size == 0 or np.all(np.isnan(rest)) else float(np.nanmin(rest))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = float(np.float64(best) / np.float64(second))
    return index, ratio


def find_matches_centred(dd: np.ndarray, ds: int = 10, vmin: float = 0.8, vmax: float = 1.2, rwindow: int = 10):
    """OpenSeqSLAM doFindMatches on an (n_query, n_ref) matrix: (ref int64 with -1 where undefined,
    score float64 with NaN where undefined). ds is rounded up to even as OpenSeqSLAM does."""
    ds = ds + ds % 2
    n_query, n_ref = dd.shape
    padded = np.concatenate([dd.astype(F32), np.full((n_query, 1), np.inf, F32)], axis=1)
    offsets = velocity_offsets(ds, vmin, vmax, ds + 1)
    refs = np.full(n_query, -1, np.int64)
    scores = np.full(n_query, np.nan)
    starts = np.arange(n_ref + 1)
    for q in range(ds // 2, n_query - ds // 2):
        columns = q - ds // 2 + np.arange(ds + 1)
        per_velocity = np.empty((len(offsets), n_ref + 1), F32)
        for vi, off in enumerate(offsets):
            total = np.zeros(n_ref + 1, F32)
            for k in range(ds + 1):
                rows = np.minimum(starts + off[k], n_ref)
                with np.errstate(over="ignore", invalid="ignore"):  # inf and NaN propagate as in the core
                    total = (total + padded[columns[k], rows]).astype(F32)
            per_velocity[vi] = total
        anchor = np.fmin.reduce(per_velocity, axis=0)  # min over speeds, NaN ignored
        index, ratio = _decide(anchor, rwindow // 2)
        refs[q] = min(index + ds // 2, n_ref - 1)
        scores[q] = ratio
    return refs, scores


def find_matches_causal(dd: np.ndarray, ds: int = 10, vmin: float = 0.8, vmax: float = 1.2, rwindow: int = 10):
    """Causal trajectories: ds columns ending at the query, ending at reference e; the row at
    column q - j is e - floor(j * v); rows before 0 cost +inf. Sum in time order."""
    n_query, n_ref = dd.shape
    offsets = velocity_offsets(ds, vmin, vmax, ds)
    refs = np.full(n_query, -1, np.int64)
    scores = np.full(n_query, np.nan)
    ends = np.arange(n_ref)
    for q in range(ds - 1, n_query):
        per_velocity = np.empty((len(offsets), n_ref), F32)
        for vi, off in enumerate(offsets):
            total = np.zeros(n_ref, F32)
            for k in range(ds):
                j = ds - 1 - k  # frames before the query
                rows = ends - off[j]
                values = np.where(rows >= 0, dd[q - j, np.maximum(rows, 0)], np.inf).astype(F32)
                with np.errstate(over="ignore", invalid="ignore"):  # inf and NaN propagate as in the core
                    total = (total + values).astype(F32)
            per_velocity[vi] = total
        anchor = np.fmin.reduce(per_velocity, axis=0)  # min over speeds, NaN ignored
        index, ratio = _decide(anchor, rwindow // 2)
        refs[q] = index
        scores[q] = ratio
    return refs, scores


def synthetic_route(
    n_ref: int, n_query: int, speed: float, seed: int, height: int = 16, width: int = 32, noise: float = 12.0
):
    """A 1D route for tests: reference frames of a smoothly changing world (one new random
    texture every frame, blended with its neighbours), and a query traverse of the same route at
    ``speed`` reference frames per query frame, darker, with sensor noise.

    Returns (refs uint8 (n_ref, h, w), queries uint8 (n_query, h, w), truth int64 (n_query,):
    the reference frame each query frame shows, -1 past the end of the route).
    """
    rng = np.random.default_rng(seed)
    places = rng.uniform(0, 255, size=(n_ref + 2, height, width))
    kernel = np.array([0.25, 0.5, 0.25])
    world = kernel[0] * places[:-2] + kernel[1] * places[1:-1] + kernel[2] * places[2:]
    refs = np.clip(world, 0, 255).astype(np.uint8)
    position = np.arange(n_query) * speed
    truth = np.rint(position).astype(np.int64)
    truth[truth >= n_ref] = -1
    queries = np.empty((n_query, height, width), np.uint8)
    for q, ref in enumerate(truth):
        source = world[ref] if ref >= 0 else rng.uniform(0, 255, size=(height, width))
        darker = 0.6 * source + 20 + rng.normal(0, noise, size=source.shape)
        queries[q] = np.clip(darker, 0, 255).astype(np.uint8)
    return refs, queries, truth


# --------------------------------------------------------------------------------------------
# the route filter (nightloc.route.filter), from its definition


def _triangle_antiderivative(t: float) -> float:
    """Integral of max(0, 1 - |u|) du from -inf to t."""
    if t <= -1.0:
        return 0.0
    if t <= 0.0:
        return 0.5 * (t + 1.0) ** 2
    if t <= 1.0:
        return 1.0 - 0.5 * (1.0 - t) ** 2
    return 1.0


def motion_kernel(vmin: float, vmax: float, backward: float) -> dict:
    """{advance k: probability} of the filter's prediction. An advance floor(x + v), x ~ U[0, 1),
    lands on k with probability max(0, 1 - |v - k|) (the overlap of [v, v+1) with [k, k+1)),
    averaged over v ~ U[vmin, vmax] with the triangle's antiderivative; a step of -1 with
    probability ``backward`` replaces it."""
    kernel = {}
    for k in range(math.floor(vmin) - 1, math.floor(vmax) + 3):
        if vmax > vmin:
            weight = (_triangle_antiderivative(vmax - k) - _triangle_antiderivative(vmin - k)) / (vmax - vmin)
        else:
            weight = max(0.0, 1.0 - abs(vmin - k))
        if weight > 1e-15:
            kernel[k] = weight * (1.0 - backward)
    if backward > 0:
        kernel[-1] = kernel.get(-1, 0.0) + backward
    return kernel


def filter_likelihood(row: np.ndarray, sharpness: float, clip: float) -> np.ndarray:
    """exp(-sharpness * min(z, clip)) scaled to a maximum of 1, z the row standardized by the
    mean and population standard deviation of its finite values (non-finite: z = 0); ones when
    the row has no spread or sharpness is 0."""
    x = np.asarray(row, dtype=np.float64)
    finite = np.isfinite(x)
    if not finite.any():
        return np.ones(x.size)
    mean = x[finite].mean()
    sd = np.sqrt(np.mean((x[finite] - mean) ** 2))
    if sharpness <= 0 or sd <= 0:
        return np.ones(x.size)
    with np.errstate(invalid="ignore"):
        z = np.where(finite, (x - mean) / sd, 0.0)
    log_l = -sharpness * np.minimum(z, clip)
    return np.exp(log_l - log_l.max())


def texture_weights(images: np.ndarray, min_texture: float) -> np.ndarray:
    """min(1, mean |pixel - image mean| / min_texture) per image (1 when min_texture is 0)."""
    if min_texture <= 0:
        return np.ones(len(images))
    flat = images.reshape(len(images), -1).astype(np.float64)
    mad = np.abs(flat - flat.mean(axis=1, keepdims=True)).mean(axis=1)
    return np.minimum(1.0, mad / min_texture)


# --------------------------------------------------------------------------------------------
# the speed and odometry models of the route filter, from their definitions


def window_kernel(lo: float, hi: float) -> dict:
    """{advance k: probability} of floor(x + u), x ~ U[0, 1), u ~ U[lo, hi], any signs: the
    average over u of the triangle max(0, 1 - |u - k|) (the overlap of [u, u+1) with [k, k+1))."""
    kernel = {}
    for k in range(math.floor(lo) - 1, math.floor(hi) + 3):
        if hi > lo:
            weight = (_triangle_antiderivative(hi - k) - _triangle_antiderivative(lo - k)) / (hi - lo)
        else:
            weight = max(0.0, 1.0 - abs(lo - k))
        if weight > 1e-15:
            kernel[k] = weight
    return kernel


def plane_kernels(p) -> tuple[list[dict], list[float]]:
    """The speed model's planes: kernels in cells (a step back of one reference, ``cells``
    cells, with probability ``filter_backward``) and speeds."""
    cells = p.filter_speed_cells
    count = math.floor((p.filter_speed_max - p.filter_speed_min) / p.filter_speed_step + 1e-9) + 1
    planes = [p.filter_speed_min + s * p.filter_speed_step for s in range(count)]
    kernels = []
    for v in planes:
        kernel = {
            k: w * (1 - p.filter_backward)
            for k, w in window_kernel(cells * (v - p.filter_speed_jitter), cells * (v + p.filter_speed_jitter)).items()
        }
        if p.filter_backward > 0:
            kernel[-cells] = kernel.get(-cells, 0.0) + p.filter_backward
        kernels.append(kernel)
    return kernels, planes


def speed_chain(p) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """(speeds, up, down, stationary prior, passes per frame) of the speed model's random walk
    between planes: ``passes = ceil(variance / 0.5)`` passes, variance = (speed_change /
    speed_step)^2 planes^2; per pass up/down = (a +- drift) / 2 with a = variance / passes and
    drift = -(v - 1) / (tau * step * passes) clipped to [-a, a]; the prior is the stationary
    distribution of one pass, solved as a linear system (uniform when the speed never changes)."""
    count = math.floor((p.filter_speed_max - p.filter_speed_min) / p.filter_speed_step + 1e-9) + 1
    speeds = p.filter_speed_min + np.arange(count) * p.filter_speed_step
    up, down = np.zeros(count), np.zeros(count)
    variance = (p.filter_speed_change / p.filter_speed_step) ** 2
    if variance <= 0 or count == 1:
        return speeds, up, down, np.full(count, 1.0 / count), 0
    passes = max(1, math.ceil(variance / 0.5))
    a = variance / passes
    pull = (
        np.zeros(count)
        if math.isinf(p.filter_speed_tau)
        else -(speeds - 1) / (p.filter_speed_tau * p.filter_speed_step * passes)
    )
    drift = np.clip(pull, -a, a)
    up[:-1] = 0.5 * (a + drift[:-1])
    down[1:] = 0.5 * (a - drift[1:])
    transition = np.diag(1 - up - down) + np.diag(up[:-1], 1) + np.diag(down[1:], -1)  # row: from
    system = np.vstack([transition.T - np.eye(count), np.ones(count)])
    prior = np.linalg.lstsq(system, np.r_[np.zeros(count), 1.0], rcond=None)[0]
    prior = np.clip(prior, 0, None)
    return speeds, up, down, prior / prior.sum(), passes


def odometry_spread(advance: float, spacing: float, p) -> np.ndarray:
    """The odometry model's noise taps over cells: ``[q, 1-2q, q]`` convolved ``passes`` times
    (passes = ceil(variance / 0.5), at most 256, q <= 1/4) for a variance of cells^2 *
    ((noise * advance / spacing)^2 + jitter^2)."""
    cells = p.filter_odometry_cells
    variance = cells**2 * ((p.filter_odometry_noise * abs(advance) / spacing) ** 2 + p.filter_odometry_jitter**2)
    if variance <= 0:
        return np.ones(1)
    passes = min(256, math.ceil(variance / 0.5))
    q = min(0.25, variance / (2 * passes))
    taps = np.ones(1)
    for _ in range(passes):
        taps = np.convolve(taps, [q, 1 - 2 * q, q])
    return taps


def _odometry_move(
    belief: np.ndarray, advance: float, distances: np.ndarray, cells: int, p
) -> tuple[np.ndarray, float]:
    """One frame of the odometry model's motion: each cell's mass to the cell at its distance +
    advance (linear between references; beyond the ends by the mean spacing), split linearly
    between the two nearest cells, then the noise; returns (prediction, mean advance in refs)."""
    n = distances.size
    m = n * cells
    spacing = (distances[-1] - distances[0]) / (n - 1)
    u = (np.arange(m) + 0.5) / cells - 0.5

    def distance_at(x):
        if x <= 0:
            return distances[0] + x * spacing
        if x >= n - 1:
            return distances[-1] + (x - (n - 1)) * spacing
        r = int(math.floor(x))
        return distances[r] + (x - r) * (distances[r + 1] - distances[r])

    def position_of(d):
        if d < distances[0]:
            return (d - distances[0]) / spacing
        r = int(np.searchsorted(distances, d, side="right")) - 1  # the last reference at or before d
        if r == n - 1:
            return n - 1 + (d - distances[-1]) / spacing
        return r + (d - distances[r]) / (distances[r + 1] - distances[r])

    moved = np.zeros(m)
    travelled = 0.0
    if advance == 0:
        moved = belief.copy()
    else:
        for c in range(m):
            target_u = position_of(distance_at(u[c]) + advance)
            travelled += belief[c] * (target_u - u[c])
            t = min(max((target_u + 0.5) * cells - 0.5, -2.0), m + 1.0)
            i = math.floor(t)
            share = t - i
            if 0 <= i < m:
                moved[i] += (1 - share) * belief[c]
            if 0 <= i + 1 < m:
                moved[i + 1] += share * belief[c]
    total = belief.sum()
    taps = odometry_spread(advance, spacing, p)
    half = len(taps) // 2
    spread = np.convolve(moved, taps)[half : half + m]  # centred; what spreads past either end is lost
    return spread, (travelled / total if total > 0 else 0.0)


# --------------------------------------------------------------------------------------------
# the route filter's loop, the same for every motion model: a model moves the belief (planes x
# cells per reference), then floor_and_exchange() and the update


@dataclass(frozen=True)
class OracleMotion:
    """One motion model of the oracle: ``cells`` per reference, ``prior`` over its planes,
    ``move(belief, advance) -> (prediction, speed)`` (mass past either end dropped; speed NaN
    when the model has none), ``speed(plane_mass, moved_speed)`` the answer's speed and
    ``novelty(advance)`` the factor on a frame's evidence weight (from the second frame on)."""

    cells: int
    prior: np.ndarray
    move: Callable[[np.ndarray, float], tuple[np.ndarray, float]]
    speed: Callable[[np.ndarray, float], float] = lambda plane_mass, moved: moved
    novelty: Callable[[float], float] = lambda advance: 1.0


def window_motion(p, n: int, distances=None) -> OracleMotion:
    """The window model: one plane of one cell per reference moved by :func:`motion_kernel`."""
    kernel = sorted(motion_kernel(p.vmin, p.vmax, p.filter_backward).items())

    def move(belief: np.ndarray, advance: float) -> tuple[np.ndarray, float]:
        predicted = np.zeros_like(belief)
        for k, weight in kernel:
            if 0 <= k < n:
                predicted[0, k:] += weight * belief[0, : n - k]
            elif -n < k < 0:
                predicted[0, : n + k] += weight * belief[0, -k:]
        return predicted, math.nan

    return OracleMotion(1, np.ones(1), move)


def speed_motion(p, n: int, distances=None) -> OracleMotion:
    """The speed model: :func:`plane_kernels` per plane, then ``passes`` passes of the speed's
    random walk (:func:`speed_chain`); the answer's speed is the posterior's mean plane speed."""
    cells = p.filter_speed_cells
    kernels, planes = plane_kernels(p)
    _speeds, up, down, prior, passes = speed_chain(p)
    m = n * cells

    def move(belief: np.ndarray, advance: float) -> tuple[np.ndarray, float]:
        predicted = np.zeros_like(belief)
        for s, kernel in enumerate(kernels):
            for k, w in kernel.items():
                if 0 <= k < m:
                    predicted[s, k:] += w * belief[s, : m - k]
                elif -m < k < 0:
                    predicted[s, : m + k] += w * belief[s, -k:]
        for _ in range(passes):
            walk = (1 - up - down)[:, None] * predicted
            walk[1:] += up[:-1, None] * predicted[:-1]
            walk[:-1] += down[1:, None] * predicted[1:]
            predicted = walk
        return predicted, math.nan

    def speed(plane_mass: np.ndarray, moved: float) -> float:
        return float(np.dot(plane_mass, planes) / plane_mass.sum())

    return OracleMotion(cells, prior, move, speed)


def odometry_motion(p, n: int, distances=None) -> OracleMotion:
    """The odometry model: :func:`_odometry_move` on one plane of ``filter_odometry_cells``
    cells per reference; a frame's evidence weighs ``min(1, |advance| / (novelty * spacing))``."""
    distances = np.asarray(distances, dtype=np.float64)
    cells = p.filter_odometry_cells
    spacing = (distances[-1] - distances[0]) / (n - 1)

    def move(belief: np.ndarray, advance: float) -> tuple[np.ndarray, float]:
        moved, travelled = _odometry_move(belief[0], advance, distances, cells, p)
        return moved[np.newaxis], travelled

    def novelty(advance: float) -> float:
        if p.filter_odometry_novelty <= 0:
            return 1.0
        return min(1.0, abs(advance) / (p.filter_odometry_novelty * spacing))

    return OracleMotion(cells, np.ones(1), move, novelty=novelty)


#: Motion model name -> the oracle's model.
MOTIONS = {"window": window_motion, "speed": speed_motion, "odometry": odometry_motion}


def floor_and_exchange(predicted: np.ndarray, on: float, off: float, prior: np.ndarray, p) -> tuple[np.ndarray, float]:
    """What follows every model's motion: the prediction (planes x cells) rescaled to the
    on-route mass ``on`` (nothing left: the prior spread evenly), ``filter_floor`` of it mixed
    uniformly, then ``filter_leave`` of the on-route mass leaves and ``filter_rejoin`` of the
    off-route mass comes back uniformly. Returns (prediction, off-route probability)."""
    m = predicted.shape[1]
    uniform = np.outer(prior, np.full(m, 1.0 / m))
    moved = predicted.sum()
    predicted = predicted * (on / moved) if moved > 0 else on * uniform
    predicted = (1 - p.filter_floor) * predicted + p.filter_floor * on * uniform
    predicted = (1 - p.filter_leave) * predicted + off * p.filter_rejoin * uniform
    return predicted, off * (1 - p.filter_rejoin) + on * p.filter_leave


def route_filter_model(matrix: np.ndarray, p, motion: str, weights=None, advances=None, distances=None):
    """The filter with the motion model ``motion`` (:data:`MOTIONS`) over the rows of ``matrix``
    from the prior belief (the first frame: no motion, full weight). Returns (refs, confidence,
    off_route, speed, final belief over references)."""
    n_query, n = matrix.shape
    model = MOTIONS[motion](p, n, distances)
    cells = model.cells
    m = n * cells
    belief = np.outer(model.prior, np.full(m, 1.0 / m))
    off = 0.0
    refs = np.empty(n_query, np.int64)
    confidence, off_route, speed = np.empty(n_query), np.empty(n_query), np.empty(n_query)
    for q in range(n_query):
        advance = 0.0 if advances is None or q == 0 else float(advances[q])
        moved, moved_speed = model.move(belief, advance)
        predicted, off = floor_and_exchange(moved, belief.sum(), off, model.prior, p)
        weight = 1.0 if weights is None else float(weights[q])
        if q > 0:  # the same view again is no new evidence
            weight *= model.novelty(advance)
        likelihood = filter_likelihood(matrix[q], p.filter_sharpness * weight, p.filter_clip)
        off *= likelihood.mean()
        belief = predicted * np.repeat(likelihood, cells)[np.newaxis]
        total = belief.sum() + off
        belief, off = belief / total, off / total
        marginal = belief.sum(axis=0).reshape(n, cells).sum(axis=1)
        best = int(np.argmax(marginal))
        refs[q] = best
        confidence[q] = marginal[max(0, best - p.filter_window) : best + p.filter_window + 1].sum()
        off_route[q] = off
        speed[q] = model.speed(belief.sum(axis=1), moved_speed)
    return refs, confidence, off_route, speed, belief.sum(axis=0).reshape(n, cells).sum(axis=1)


def filter_predict(belief: np.ndarray, off: float, p) -> tuple[np.ndarray, float]:
    """The window model's prediction of (belief over n references, off-route probability) by
    one frame, with a RouteParams-like ``p``."""
    model = window_motion(p, belief.size)
    moved, _ = model.move(belief[np.newaxis], 0.0)
    predicted, off = floor_and_exchange(moved, belief.sum(), off, model.prior, p)
    return predicted[0], off


def route_filter(matrix: np.ndarray, p, weights=None):
    """The window model over the rows of ``matrix``: (refs, confidence, off_route, final belief)."""
    refs, confidence, off_route, _speed, belief = route_filter_model(matrix, p, "window", weights)
    return refs, confidence, off_route, belief


def route_filter_planes(matrix: np.ndarray, p, weights=None, advances=None, distances=None):
    """The speed model (``distances`` None) or the odometry model over the rows of ``matrix``:
    (refs, confidence, off_route, speed, final belief over references)."""
    motion = "speed" if distances is None else "odometry"
    return route_filter_model(matrix, p, motion, weights, advances, distances)


def synthetic_route_at(
    n_ref: int,
    positions: np.ndarray,
    seed: int,
    height: int = 16,
    width: int = 32,
    noise: float = 12.0,
    likeness: float = 1.0,
):
    """The route of :func:`synthetic_route` seen by a query at ``positions`` (reference frames,
    any order and speed: a stop repeats a place, a reverse goes back): query frame k shows the
    place at ``round(positions[k])`` (``likeness`` of it, the rest a fresh random texture: weak
    evidence, as at night), darker, with fresh sensor noise.

    Returns (refs uint8 (n_ref, h, w), queries uint8 (n, h, w), truth int64 (n,), -1 off the route).
    """
    rng = np.random.default_rng(seed)
    places = rng.uniform(0, 255, size=(n_ref + 2, height, width))
    kernel = np.array([0.25, 0.5, 0.25])
    world = kernel[0] * places[:-2] + kernel[1] * places[1:-1] + kernel[2] * places[2:]
    refs = np.clip(world, 0, 255).astype(np.uint8)
    truth = np.rint(np.asarray(positions, dtype=np.float64)).astype(np.int64)
    truth[(truth < 0) | (truth >= n_ref)] = -1
    queries = np.empty((len(truth), height, width), np.uint8)
    for q, ref in enumerate(truth):
        clutter = rng.uniform(0, 255, size=(height, width))
        source = likeness * world[ref] + (1 - likeness) * clutter if ref >= 0 else clutter
        darker = 0.6 * source + 20 + rng.normal(0, noise, size=source.shape)
        queries[q] = np.clip(darker, 0, 255).astype(np.uint8)
    return refs, queries, truth


def noisy_matrix(seed: int, n_query: int = 90, n_ref: int = 70) -> tuple[np.ndarray, np.ndarray]:
    """A test problem for the filter: ``(n_query, n_ref)`` float32 scores with a true reference
    0.7 per query frame lower by 2, a row without spread, NaN and inf entries, and ``(n_query,)``
    evidence weights (one 0)."""
    rng = np.random.default_rng(seed)
    matrix = rng.normal(3.0, 1.0, size=(n_query, n_ref)).astype(np.float32)
    truth = (np.arange(n_query) * 0.7).astype(int) % n_ref
    matrix[np.arange(n_query), truth] -= 2.0
    matrix[5, :] = 1.0  # a row without spread
    matrix[9, ::7] = np.nan  # constant enhancement windows
    matrix[10, :] = np.nan
    matrix[11, 3] = np.inf
    weights = rng.uniform(0, 1, n_query)
    weights[20] = 0.0
    return matrix, weights


def evaluate_route(refs: np.ndarray, queries: np.ndarray, params, tolerance: int = 2):
    """Route mode's matches of ``queries`` along ``refs`` (prepared stacks, the same place at the same
    index) with ``params``, evaluated against that diagonal within ``tolerance`` frames."""
    from nightloc import route

    result = route.match_prepared(refs, queries, params, threads=2)
    truth = route.GroundTruth.from_frames(result.n_queries, result.n_refs, tolerance)
    return route.evaluate_matches(result.refs, result.scores, truth)
