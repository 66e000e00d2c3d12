"""Small, independent numpy reference implementations the compiled core is checked against.

Written from the paper and OpenSeqSLAM's Matlab code, not from the C++: plain loops and numpy
rolls, exact integer sums, the same documented floating-point formulas.
"""

from __future__ import annotations

import numpy as np


def rotational_sums(query: np.ndarray, refs: np.ndarray, shifts) -> np.ndarray:
    """(N, n_shifts) int64: sum |roll(query, -k) - ref| for every reference and shift k."""
    q = query.astype(np.int64)
    r = refs.astype(np.int64)
    out = np.empty((len(refs), len(shifts)), dtype=np.int64)
    for j, k in enumerate(shifts):
        rolled = np.roll(q, -int(k), axis=1)
        out[:, j] = np.abs(r - rolled[None]).sum(axis=(1, 2))
    return out


def scores_from_sums(sums: np.ndarray, divisor: float) -> np.ndarray:
    """float32(double(sum) / divisor), the core's score formula."""
    return (sums.astype(np.float64) / float(divisor)).astype(np.float32)


def rotational_sad(query, refs, shifts) -> np.ndarray:
    return scores_from_sums(rotational_sums(query, refs, shifts), query.size)


def difference_matrix(queries, refs, shifts):
    """(scores float32 (M, N), best shifts int32 (M, N)); ties go to the earliest listed shift."""
    scores = np.empty((len(queries), len(refs)), dtype=np.float32)
    best = np.empty((len(queries), len(refs)), dtype=np.int32)
    shifts = np.asarray(shifts)
    for m, query in enumerate(queries):
        sums = rotational_sums(query, refs, shifts)
        j = np.argmin(sums, axis=1)  # first minimum
        best[m] = shifts[j]
        scores[m] = scores_from_sums(sums[np.arange(len(refs)), j], query.size)
    return scores, best


def patch_zscores(image: np.ndarray, radius: int, wrap: bool) -> np.ndarray:
    """Eq. (1) on one (H, W) image, unquantized: float64 z with exact integer window sums.

    z = (n*x - S) / sqrt(n*Q - S^2) for the window's count n, sum S and sum of squares Q (the
    population standard deviation); a flat window gives z = 0.
    """
    h, w = image.shape
    x = image.astype(np.int64)
    n = np.zeros((h, w), np.int64)
    s = np.zeros((h, w), np.int64)
    q = np.zeros((h, w), np.int64)
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            for y in range(h):
                yy = y + dy
                if yy < 0 or yy >= h:
                    continue
                if wrap:
                    cols = (np.arange(w) + dx) % w
                    valid = np.ones(w, bool)
                else:
                    cols = np.arange(w) + dx
                    valid = (cols >= 0) & (cols < w)
                    cols = np.clip(cols, 0, w - 1)
                v = x[yy, cols]
                n[y] += valid
                s[y] += np.where(valid, v, 0)
                q[y] += np.where(valid, v * v, 0)
    spread = n * q - s * s
    z = np.zeros((h, w))
    ok = spread > 0
    z[ok] = (n * x - s)[ok].astype(np.float64) / np.sqrt(spread[ok].astype(np.float64))
    return z


def patch_normalize(image: np.ndarray, radius: int, wrap: bool, scale: float) -> np.ndarray:
    """Eq. (1) quantized: clip(floor(128 + scale*z + 0.5), 0, 255) as uint8."""
    z = patch_zscores(image, radius, wrap)
    return np.clip(np.floor(128.0 + scale * z + 0.5), 0, 255).astype(np.uint8)


def block_normalize(image: np.ndarray, side: int) -> np.ndarray:
    """OpenSeqSLAM patchNormalize.m, mode 1, on one (H, W) image."""
    h, w = image.shape
    out = image.copy()
    for y0 in range(0, h - side + 1, side):
        for x0 in range(0, w - side + 1, side):
            block = image[y0 : y0 + side, x0 : x0 + side].astype(np.float64)
            mean = block.sum() / block.size
            sd = np.sqrt(((block - mean) ** 2).sum() / (block.size - 1))
            if sd == 0:
                out[y0 : y0 + side, x0 : x0 + side] = 0  # NaN -> uint8 0 in Matlab
                continue
            z = (block - mean) / sd
            rounded = np.sign(z) * np.floor(np.abs(z) + 0.5)  # Matlab round: half away from zero
            out[y0 : y0 + side, x0 : x0 + side] = np.clip(127 + rounded, 0, 255)
    return out


def octave_rgb2gray(rgb: np.ndarray) -> np.ndarray:
    """Octave's rgb2gray for uint8 RGB: ITU-R BT.601 luma, rounded half away from zero."""
    r, g, b = (rgb[..., k].astype(np.float64) for k in range(3))
    gray = 0.298936021293775 * r + 0.587043074451121 * g + 0.114020904255103 * b
    return np.clip(np.floor(gray + 0.5), 0, 255).astype(np.uint8)


def best_numpy_rotational_sums(query: np.ndarray, refs: np.ndarray, block: int = 64) -> np.ndarray:
    """The fastest vectorized numpy formulation measured (docs/performance.md): all shifts at once,
    |a-b| = a + b - 2 min(a, b) with np.minimum on uint8 and uint32 sums, references in blocks.
    (N, W) int64 sums for shifts 0..W-1."""
    n, _h, w = refs.shape
    flat_refs = refs.reshape(n, -1)
    rolled = np.stack([np.roll(query, -k, axis=1).reshape(-1) for k in range(w)])  # (W, h*w)
    ref_totals = flat_refs.sum(axis=1, dtype=np.int64)
    rolled_totals = rolled.sum(axis=1, dtype=np.int64)
    out = np.empty((n, w), dtype=np.int64)
    for start in range(0, n, block):
        mins = np.minimum(flat_refs[start : start + block, None, :], rolled[None]).sum(axis=2, dtype=np.uint32)
        out[start : start + block] = ref_totals[start : start + block, None] + rolled_totals[None] - 2 * mins
    return out


# --------------------------------------------------------------------------------------------
# Translation window (nightloc.matching.sad's module docstring): plain slicing over the overlap.


def _offset_rank(value: int) -> int:
    """Order of an offset among equal means: 0, -1, +1, -2, +2, ..."""
    return 2 * abs(value) - (1 if value < 0 else 0)


def window_candidates(query: np.ndarray, refs: np.ndarray, shifts, window: tuple[int, int]):
    """Every candidate of a window search: a list of (sums int64 (N,), overlap, rank, column
    value, dy), column candidates in table order per row offset. ``window = (columns, rows)``;
    columns > 0 means shifts == [0] and non-wrapping column offsets."""
    h, w = query.shape
    columns, rows = window
    q = query.astype(np.int64)
    r = refs.astype(np.int64)
    values = list(range(-columns, columns + 1)) if columns else [int(k) for k in shifts]
    out = []
    for dy in range(-rows, rows + 1):
        r0, r1 = max(0, -dy), min(h, h - dy)
        for j, value in enumerate(values):
            if columns:
                c0, c1 = max(0, -value), min(w, w - value)
                part_q = q[r0 + dy : r1 + dy, c0 + value : c1 + value]
                part_r = r[:, r0:r1, c0:c1]
                col_rank = _offset_rank(value)
            else:
                part_q = np.roll(q, -value, axis=1)[r0 + dy : r1 + dy]
                part_r = r[:, r0:r1]
                col_rank = j
            sums = np.abs(part_r - part_q[None]).sum(axis=(1, 2))
            overlap = part_q.size
            rank = _offset_rank(dy) * len(values) + col_rank
            out.append((sums, overlap, rank, value, dy))
    return out


def window_score(sums, overlap: int, pixels: int, divisor: float | None) -> np.ndarray:
    """float32(double(sum) / d): d = overlap (divisor None), divisor at full overlap, else
    divisor * overlap / pixels."""
    if divisor is None:
        d = float(overlap)
    elif overlap == pixels:
        d = float(divisor)
    else:
        d = float(divisor) * float(overlap) / float(pixels)
    return (np.asarray(sums, dtype=np.float64) / d).astype(np.float32)


def _best_of(candidates):
    """Per reference, the best candidate: lowest exact mean (Python integers), then lowest rank.
    Returns (sums, overlaps, values, dys) arrays (N,)."""
    n = len(candidates[0][0])
    best = [None] * n
    for sums, overlap, rank, value, dy in candidates:
        for i in range(n):
            s = int(sums[i])
            b = best[i]
            if b is None or s * b[1] < b[0] * overlap or (s * b[1] == b[0] * overlap and rank < b[2]):
                best[i] = (s, overlap, rank, value, dy)
    return tuple(np.array([b[k] for b in best], dtype=np.int64) for k in (0, 1, 3, 4))


def window_table(query, refs, shifts, window, divisor=None):
    """(scores float32 (N, n_columns), rows int32 (N, n_columns)): per column candidate, the best
    over the row offsets."""
    h, w = query.shape
    candidates = window_candidates(query, refs, shifts, window)
    n_columns = 2 * window[0] + 1 if window[0] else len(shifts)
    scores = np.empty((len(refs), n_columns), np.float32)
    rows = np.empty((len(refs), n_columns), np.int32)
    for j in range(n_columns):
        sums, overlaps, _values, dys = _best_of(candidates[j::n_columns])
        scores[:, j] = [window_score(s, o, h * w, divisor) for s, o in zip(sums, overlaps)]
        rows[:, j] = dys
    return scores, rows


def window_difference_matrix(queries, refs, shifts, window, divisor=None):
    """(scores float32 (M, N), best column candidates int32, best row offsets int32)."""
    h, w = queries.shape[1:]
    m, n = len(queries), len(refs)
    scores = np.empty((m, n), np.float32)
    values = np.empty((m, n), np.int32)
    rows = np.empty((m, n), np.int32)
    for k, query in enumerate(queries):
        sums, overlaps, best_values, dys = _best_of(window_candidates(query, refs, shifts, window))
        scores[k] = [window_score(s, o, h * w, divisor) for s, o in zip(sums, overlaps)]
        values[k] = best_values
        rows[k] = dys
    return scores, values, rows


def window_best_reference(query, refs, shifts, window) -> int:
    """The reference with the lowest exact mean; ties: the lowest index."""
    sums, overlaps, _values, _dys = _best_of(window_candidates(query, refs, shifts, window))
    best = 0
    for i in range(1, len(refs)):
        if int(sums[i]) * int(overlaps[best]) < int(sums[best]) * int(overlaps[i]):
            best = i
    return best
