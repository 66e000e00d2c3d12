"""Independent numpy references for route mode (SeqSLAM), written from OpenSeqSLAM's Matlab code
(doContrastEnhancement.m, doFindMatches.m) and its documented Octave semantics, not from the C++.

Orientation here is nightloc's: difference matrices are (n_query, n_ref), rows = queries. Every
floating-point step is done in the same order and precision as Octave: float32 sequential sums,
float32 mean, deviations, sum of squares, division and sqrt; double only for the final ratio.
"""

from __future__ import annotations

import math

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


def filter_predict(belief: np.ndarray, off: float, p) -> tuple[np.ndarray, float]:
    """The prediction of (belief over n references, off-route probability) by one frame, with a
    RouteParams-like ``p`` (vmin, vmax, filter_backward, filter_floor, filter_leave,
    filter_rejoin)."""
    n = belief.size
    on = belief.sum()
    predicted = np.zeros(n)
    for k, weight in sorted(motion_kernel(p.vmin, p.vmax, p.filter_backward).items()):
        if k >= 0:
            predicted[k:] += weight * belief[: n - k] if k < n else 0.0
        else:
            predicted[: n + k] += weight * belief[-k:]
    moved = predicted.sum()
    predicted = predicted * (on / moved) if moved > 0 else np.full(n, on / n)
    predicted = (1 - p.filter_floor) * predicted + p.filter_floor * on / n
    predicted = (1 - p.filter_leave) * predicted + off * p.filter_rejoin / n
    off = off * (1 - p.filter_rejoin) + on * p.filter_leave
    return predicted, off


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


def route_filter(matrix: np.ndarray, p, weights=None):
    """The filter over the rows of ``matrix`` from the uniform belief.

    Returns (refs int64, confidence, off_route, final belief)."""
    n_query, n = matrix.shape
    belief, off = np.full(n, 1.0 / n), 0.0
    refs = np.empty(n_query, np.int64)
    confidence = np.empty(n_query)
    off_route = np.empty(n_query)
    for q in range(n_query):
        predicted, off = filter_predict(belief, off, p)
        weight = 1.0 if weights is None else float(weights[q])
        likelihood = filter_likelihood(matrix[q], p.filter_sharpness * weight, p.filter_clip)
        off *= likelihood.mean()
        belief = predicted * likelihood
        total = belief.sum() + off
        belief, off = belief / total, off / total
        best = int(np.argmax(belief))
        refs[q] = best
        confidence[q] = belief[max(0, best - p.filter_window) : best + p.filter_window + 1].sum()
        off_route[q] = off
    return refs, confidence, off_route, belief


def texture_weights(images: np.ndarray, min_texture: float) -> np.ndarray:
    """min(1, mean |pixel - image mean| / min_texture) per image (1 when min_texture is 0)."""
    if min_texture <= 0:
        return np.ones(len(images))
    flat = images.reshape(len(images), -1).astype(np.float64)
    mad = np.abs(flat - flat.mean(axis=1, keepdims=True)).mean(axis=1)
    return np.minimum(1.0, mad / min_texture)
