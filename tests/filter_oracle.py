"""The grid Bayes filter in numpy, float64 (the test oracle of nightloc/grid_filter.hpp, not library code).

Written from the model in docs/localization.md, operation by operation where the core defines an
order and otherwise as plain linear algebra: each axis of the prediction is one matrix (the
bilinear shift convolved with three extended-box passes), the heading blur a circular kernel,
the measurement per reference and bin the score at the bin's shift, per place the lowest. The compiled filter keeps its
belief in float32 and sums in a fixed order, so the two agree to a tolerance (the tests say which).
"""

from __future__ import annotations

import math

import numpy as np

TWO_PI = 2.0 * math.pi
LOWEST_LOG2 = -60.0


def box_pass(s2: float) -> tuple[int, float, float]:
    """Extended box (Gwosdek et al. 2011) of variance ``s2`` cells^2: radius r, end weight alpha, 1/w."""
    r = int(math.floor(0.5 * math.sqrt(12.0 * s2 + 1.0) - 0.5))
    alpha = (2 * r + 1) * (3 * s2 - r * (r + 1)) / (6 * ((r + 1) ** 2 - s2))
    alpha = min(max(alpha, 0.0), 1.0)
    return r, alpha, 1.0 / (2 * r + 1 + 2 * alpha)


#: Box radius beyond which the core runs the blur as running sums (the whole kernel) instead of
#: explicit taps (the kernel without its ends below KERNEL_CUT of its peak: up to 6 r + 7 = 127).
MAX_EXPLICIT_RADIUS = 20
KERNEL_CUT = 1e-4


def blur_kernel(sigma: float) -> np.ndarray:
    """Three extended-box passes of variance sigma^2 / 3 each, convolved (centred, odd length); for
    box radii the core runs as explicit taps, without the ends below KERNEL_CUT of the peak."""
    if sigma <= 0:
        return np.ones(1)
    r, alpha, inv_w = box_pass(sigma * sigma / 3.0)
    box = np.full(2 * r + 3, inv_w)
    box[0] = box[-1] = alpha * inv_w
    kernel = np.ones(1)
    for _ in range(3):
        kernel = np.convolve(kernel, box)
    if r <= MAX_EXPLICIT_RADIUS:
        cut = 0
        while 2 * cut + 1 < len(kernel) and kernel[cut] < KERNEL_CUT * kernel.max():
            cut += 1
        kernel = kernel[cut : len(kernel) - cut]
    return kernel


def axis_matrix(n: int, shift: float, sigma: float) -> np.ndarray:
    """``(n, n)``: out = M @ in along one axis: shift by ``shift`` cells (bilinear) and blur, on the
    infinite line (zero beyond the grid), cut to the grid."""
    kernel = blur_kernel(sigma)
    whole = math.floor(shift)
    frac = shift - whole
    reach = len(kernel) // 2
    m = np.zeros((n, n))
    for u, g in enumerate(kernel):
        for e, w in ((0, 1.0 - frac), (1, frac)):
            v = whole + e + u - reach  # output j takes source j - v
            rows = np.arange(n)
            cols = rows - v
            ok = (cols >= 0) & (cols < n)
            m[rows[ok], cols[ok]] += g * w
    return m


def axis_shares(angle: float) -> tuple[float, float]:
    """Variance shares of a 1-D Gaussian along ``angle`` put on the axes (see grid_filter.cpp)."""
    c, s = abs(math.cos(angle)), abs(math.sin(angle))
    k = 1.0 / (c**3 + s**3)
    return k * c, k * s


class OracleFilter:
    """The filter of ``nightloc._core.GridFilter`` in float64.

    Args:
        weights: ``scipy.sparse`` ``(cells, places)`` interpolation weights (rows of cells without
            weights are empty); grid ``height x width`` row-major.
        x0, y0, dx, dy: the grid (centre of cell 0, spacing), metres.
        place_of_ref: ``(N,)`` place of each reference.
        ref_headings: ``(N,)`` radians or None.
        columns: panorama columns; shifts: the table's shift list.
        settings: the core's settings (heading_bins, likelihood_gain, distance_std, heading_std,
            distance_per_metre, heading_per_radian (wheel odometry), position_floor, heading_floor,
            uniform_floor, unknown_spread, credibility, confidence_radius, estimate_window).
        learned: ``(N,)`` flags of references learned on a night, or None.
    """

    def __init__(
        self,
        weights,
        height,
        width,
        x0,
        y0,
        dx,
        dy,
        place_of_ref,
        ref_headings,
        columns,
        shifts,
        settings,
        field_of_view=0.0,
        window_columns=0,
        learned=None,
    ):
        self.w = weights.tocsr()
        # learned references (an experience map): evidence about the day reference of their place
        # nearest in heading (their proxy), which they then score as (see update)
        self.learned = None if learned is None else np.asarray(learned, dtype=bool)
        self.h, self.wd = height, width
        self.x0, self.y0, self.dx, self.dy = x0, y0, dx, dy
        self.place_of_ref = np.asarray(place_of_ref)
        self.places = self.w.shape[1]
        # the score cap tempered by the map's look-alikes: places with references beyond lookalike_places
        with_refs = len(np.unique(self.place_of_ref))
        self.score_cap = settings.get("score_cap", 0.0)
        lookalikes = settings.get("lookalike_places", 0.0)
        if lookalikes > 0 and with_refs > lookalikes:
            self.score_cap *= math.log(lookalikes) / math.log(with_refs)
        self.headings = None if ref_headings is None else np.asarray(ref_headings, dtype=np.float64)
        self.proxy = np.full(len(self.place_of_ref), -1)
        if self.learned is not None and 0 < self.learned.sum() < len(self.learned):
            for i in np.flatnonzero(self.learned):
                same = self.place_of_ref == self.place_of_ref[i]
                day = [int(d) for d in np.flatnonzero(same & ~self.learned)]
                if day and self.headings is not None:
                    turn = [abs(math.remainder(self.headings[d] - self.headings[i], TWO_PI)) for d in day]
                    day = [day[int(np.argmin(turn))]]
                if day:
                    self.proxy[i] = day[0]
                    if self.headings is not None:  # read at its day reference's heading
                        self.headings = self.headings.copy()
                        self.headings[i] = self.headings[day[0]]
        self.columns = columns
        self.shifts = np.asarray(shifts)
        self.s = dict(settings)
        full = len(self.shifts) == columns and np.array_equal(self.shifts, np.arange(columns))
        # a forward camera: the table's columns are the column offsets -c .. c of a window
        self.fov, self.c = field_of_view, window_columns
        self.candidates = np.arange(-self.c, self.c + 1) if self.c else self.shifts
        forward = self.c > 0 and self.fov > 0
        self.can_pose = self.s["heading_bins"] > 1 and self.headings is not None and (full or forward)
        self.bins = self.s["heading_bins"] if self.can_pose else 1
        self.outside = np.diff(self.w.indptr) == 0
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self):
        self.recall_cell = self.h // 2 * self.wd + self.wd // 2  # the recall's centre: the grid's
        self.pose = self.can_pose
        self.offset = 0.0
        self.bin_max = None  # each bin's largest value after the last update (pose mode), else None
        self.frames = 0  # frames measured since reset (the first settle_frames are tempered)
        n = self.bins if self.pose else 1
        self.p = np.full((n, self.h, self.wd), 1.0 / (n * self.h * self.wd))

    def _to_position(self):
        self.bin_max = None
        if self.pose:
            self.p = self.p.sum(0, keepdims=True)
            self.pose = False

    def _to_pose(self):
        if not self.pose and self.can_pose:
            self.bin_max = None
            self.p = np.repeat(self.p, self.bins, axis=0)
            self.pose = True

    def _shift_blur(self, slice_, sx, sy, sigx, sigy):
        return axis_matrix(self.h, sy, sigy) @ slice_ @ axis_matrix(self.wd, sx, sigx).T

    def _finish(self, q, before):
        """The prior from the predicted mass ``q`` of a belief that summed to ``before``: mass that
        left the grid is gone (not given back to the cells that stay), plus the uniform floor."""
        eps = self.s["uniform_floor"]
        prior = (1 - eps) * q / before + eps / q.size
        if not prior.sum() > 0:  # nothing left on the grid and no floor: uniform
            return np.full_like(q, 1.0 / q.size)
        return prior

    # ------------------------------------------------------------------ prediction
    def predict_robot(self, forward, left, turn):
        if not self.can_pose:
            raise ValueError("no pose mode")
        self._to_pose()
        s = self.s
        step = TWO_PI / self.bins
        turned = (self.offset + turn) / step
        whole = math.floor(turned)
        new_offset = (turned - whole) * step
        if new_offset >= step:
            new_offset -= step
            whole += 1
        new_offset = max(new_offset, 0.0)
        roll = whole % self.bins
        before = self.p.sum()
        along = math.atan2(left, forward) if math.hypot(forward, left) > 0 else 0.0
        # the step-scaled noise of wheel odometry, in quadrature with the per-step terms
        distance2 = s["distance_std"] ** 2 + (s.get("distance_per_metre", 0.0) * math.hypot(forward, left)) ** 2
        heading_std = math.hypot(s["heading_std"], s.get("heading_per_radian", 0.0) * turn)
        # negligible bins (their largest value after the last update below `negligible` of the
        # belief's largest): shifted without the position blur
        negligible = np.zeros(self.bins, dtype=bool)
        if self.bin_max is not None and s.get("negligible", 0.0) > 0:
            negligible = self.bin_max < s["negligible"] * self.bin_max.max()
        self.bin_max = None
        q = np.zeros_like(self.p)
        for b in range(self.bins):
            theta = self.offset + step * b
            c, sn = math.cos(theta), math.sin(theta)
            mx, my = c * forward - sn * left, sn * forward + c * left
            wx, wy = axis_shares(theta + along)
            sigx = math.sqrt(distance2 * wx + s["position_floor"] ** 2)
            sigy = math.sqrt(distance2 * wy + s["position_floor"] ** 2)
            if negligible[b]:
                sigx = sigy = 0.0
            q[(b + roll) % self.bins] = self._shift_blur(
                self.p[b], mx / self.dx, my / self.dy, sigx / self.dx, sigy / self.dy
            )
        self.offset = new_offset
        sigma_bins = math.hypot(heading_std, s["heading_floor"]) / step
        taps = np.zeros(self.bins)
        if sigma_bins < 1e-6:
            taps[0] = 1.0
        else:
            reach = math.ceil(3.0 * sigma_bins)
            for t in range(-reach, reach + 1):
                taps[t % self.bins] += math.exp(-0.5 * t * t / sigma_bins**2)
            taps = np.where(taps < KERNEL_CUT * taps.max(), 0.0, taps / taps.sum())
        blurred = np.zeros_like(q)
        for d, g in enumerate(taps):
            if g > 0:
                blurred += g * np.roll(q, d, axis=0)  # out[b] += g * q[b - d]
        self.p = self._finish(blurred, before)

    def predict_map(self, dx, dy):
        self._to_position()
        s = self.s
        d = math.hypot(dx, dy)
        direction = math.atan2(dy, dx) if d > 0 else 0.0
        ax, ay = axis_shares(direction)
        cx, cy = axis_shares(direction + 0.5 * math.pi)
        along2, across2 = s["distance_std"] ** 2, (d * s["heading_std"]) ** 2
        sigx = math.sqrt(along2 * ax + across2 * cx + s["position_floor"] ** 2)
        sigy = math.sqrt(along2 * ay + across2 * cy + s["position_floor"] ** 2)
        self.p = self._finish(
            self._shift_blur(self.p[0], dx / self.dx, dy / self.dy, sigx / self.dx, sigy / self.dy)[None], self.p.sum()
        )

    def predict_unknown(self):
        self._to_position()
        sig = self.s["unknown_spread"]
        self.p = self._finish(self._shift_blur(self.p[0], 0.0, 0.0, sig / self.dx, sig / self.dy)[None], self.p.sum())

    # ------------------------------------------------------------------ update
    def update(self, table):
        t = np.asarray(table, dtype=np.float64)
        if not np.isfinite(t).all():
            raise ValueError("table holds NaN or infinity")
        n, _n_shifts = t.shape
        best = np.argmin(t, axis=1)
        self.best_shifts = self.candidates[best]
        if self.learned is not None and 0 < self.learned.sum() < n:
            recalled = self.recalled()  # the looks this frame scores
            raw = t.min(axis=1)
            day = float(np.median(raw[~self.learned]))
            night = float(np.median(raw[self.learned & recalled]))
            evidence = {}  # a day reference's recalled looks' best minimum on the day scale
            if day > 0 and night > 0:
                ratio = day / night
                for i in np.flatnonzero(self.learned & recalled):
                    scaled = float(np.float32(raw[i] * ratio))  # float32, as the core stores it
                    if self.proxy[i] < 0:  # a place learned in a gap: scaled only
                        t[i] = (t[i] * ratio).astype(np.float32)
                    else:
                        evidence[self.proxy[i]] = min(evidence.get(self.proxy[i], math.inf), scaled)
            if evidence:
                neutral = float(np.median(list(evidence.values())))
                for d, value in evidence.items():  # moved by its evidence against the typical
                    t[d] = (t[d] + (value - neutral)).astype(np.float32)
            for i in np.flatnonzero(self.proxy >= 0):  # then every look scores as its day reference
                t[i] = t[self.proxy[i]]
                best[i] = best[self.proxy[i]]
                self.best_shifts[i] = self.best_shifts[self.proxy[i]]
        self.mins = t[np.arange(n), best]
        s_min = self.mins.min()
        spread = float(np.median(self.mins)) - s_min
        settle = self.s.get("settle_frames", 0)
        temper = min(1.0, (self.frames + 1) / settle) if settle > 1 else 1.0
        self.frames += 1
        lam = temper * self.s["likelihood_gain"] / spread if spread > 0 else 0.0
        bins = self.bins if self.pose else 1
        place_scores = np.full((bins, self.places), np.inf)
        if self.pose and self.c:  # a forward camera: each reference in the bins that see it
            theta = self.offset + TWO_PI / self.bins * np.arange(bins)
            delta = np.angle(np.exp(1j * (theta[None, :] - self.headings[:, None])))  # (n, bins) in (-pi, pi]
            x = delta * self.columns / self.fov + self.c  # the column offset's index
            seen = np.abs(x - self.c) <= self.c
            j0 = np.minimum(np.floor(np.where(seen, x, 0)).astype(np.int64), 2 * self.c)
            j1 = np.minimum(j0 + 1, 2 * self.c)
            a = np.where(seen, x, 0) - j0
            rows = np.arange(n)[:, None]
            v = np.where(seen, (1 - a) * t[rows, j0] + a * t[rows, j1], np.inf)
            # a bin spans its step: the best of the columns within half a step of its centre too
            half = 0.5 * TWO_PI / self.bins * self.columns / self.fov
            for j in range(2 * self.c + 1):
                spanned = seen & (np.abs(j - x) <= half + 1e-12)
                v = np.where(spanned, np.minimum(v, t[:, j][:, None]), v)
            np.minimum.at(place_scores.T, self.place_of_ref, v)
            place_scores[np.isinf(place_scores)] = float(np.median(self.mins))  # none in view: no evidence
        elif self.pose:  # every reference and bin at once: the score at the bin's fractional shift
            c = (self.offset - self.headings) * self.columns / TWO_PI  # (n,)
            k = self.columns / self.bins * np.arange(bins)[None, :] + c[:, None]  # (n, bins)
            kf = np.floor(k)
            a = k - kf
            k0 = kf.astype(np.int64) % self.columns
            k1 = (k0 + 1) % self.columns
            rows = np.arange(n)[:, None]
            v = (1 - a) * t[rows, k0] + a * t[rows, k1]
            np.minimum.at(place_scores.T, self.place_of_ref, v)
        else:
            np.minimum.at(place_scores[0], self.place_of_ref, self.mins)
        gain = -lam * math.log2(math.e)
        cap = self.score_cap  # scores beyond s_min + cap spread count as that
        lowest = LOWEST_LOG2
        if cap > 0:
            lowest = max(LOWEST_LOG2, -temper * self.s["likelihood_gain"] * cap * math.log2(math.e))
        y_places = np.maximum(gain * (place_scores - s_min), lowest)  # (bins, places)
        y_fill = np.maximum(gain * (place_scores.max(axis=1) - s_min), lowest)  # (bins,)
        y_cells = (self.w @ y_places.T).T  # (bins, cells)
        y_cells[:, self.outside] = y_fill[:, None]
        y_cells = np.maximum(y_cells, LOWEST_LOG2)
        like = np.exp2(y_cells).reshape(bins, self.h, self.wd)
        post = self.p * like
        total = post.sum()
        self.p = post / total if total > 0 else like / like.sum()
        self.lam = lam
        self.bin_max = self.p.reshape(bins, -1).max(axis=1) if self.pose else None
        self.recall_cell = int(np.argmax(self.p.sum(0)))  # the next frame's recall centre

    def recalled(self):
        """``(N,)`` bool: the references a frame scores: every day reference and look in a gap, and
        of the looks with a day reference (at most as many as the day references) half whose
        place's cell (its largest weight) lies nearest the recall centre (ties: the first), the
        other half the window of the rest (in index order) that moves on by its size each frame."""
        n = len(self.place_of_ref)
        out = np.ones(n, dtype=bool)
        looks = np.flatnonzero(self.learned & (self.proxy >= 0))
        budget = int((~self.learned).sum())
        if len(looks) <= budget:
            return out
        out[looks] = False
        weights = self.w.tocsc()
        cy, cx = divmod(self.recall_cell, self.wd)
        d2 = []
        for i in looks:
            column = weights[:, int(self.place_of_ref[i])]
            cell = (self.h * self.wd) // 2  # a place without weights: the middle cell
            if column.nnz:  # the first cell of the largest weight
                cell = int(np.min(column.indices[column.data == column.data.max()]))
            ry, rx = divmod(cell, self.wd)
            d2.append((self.dx * (rx - cx)) ** 2 + (self.dy * (ry - cy)) ** 2)
        near, turn = budget // 2, budget - budget // 2
        order = sorted(range(len(looks)), key=lambda k: (d2[k], looks[k]))
        out[looks[order[:near]]] = True
        rest = [i for i in looks if not out[i]]
        start = self.frames * turn % len(rest)
        out[[rest[(start + k) % len(rest)] for k in range(turn)]] = True
        return out

    # ------------------------------------------------------------------ estimate
    def estimate(self):
        """(x, y, heading, cov (2, 2), credible_radius, confidence, cell, flat, heading_var)."""
        m = self.p.sum(0)
        total = m.sum()
        xs = self.x0 + self.dx * np.arange(self.wd)
        ys = self.y0 + self.dy * np.arange(self.h)
        gx, gy = np.meshgrid(xs, ys)
        mx, my = (m * gx).sum() / total, (m * gy).sum() / total
        cov = (
            np.array(
                [
                    [(m * (gx - mx) ** 2).sum(), (m * (gx - mx) * (gy - my)).sum()],
                    [(m * (gx - mx) * (gy - my)).sum(), (m * (gy - my) ** 2).sum()],
                ]
            )
            / total
        )
        cell = int(np.argmax(m))
        pj, pi = divmod(cell, self.wd)
        w = self.s["estimate_window"]
        j0, j1, i0, i1 = max(pj - w, 0), min(pj + w + 1, self.h), max(pi - w, 0), min(pi + w + 1, self.wd)
        flat = m.max() <= m.min()
        if flat:
            x, y = mx, my
        else:
            sub = m[j0:j1, i0:i1]
            x = float((sub * gx[j0:j1, i0:i1]).sum() / sub.sum())
            y = float((sub * gy[j0:j1, i0:i1]).sum() / sub.sum())
        d = np.hypot(gx - x, gy - y).ravel()
        order = np.argsort(d, kind="stable")
        cum = np.cumsum(m.ravel()[order])
        k = min(int(np.searchsorted(cum, self.s["credibility"] * total)), len(d) - 1)
        radius = float(d[order[k]])
        confidence = float(m.ravel()[d <= self.s["confidence_radius"]].sum() / total)
        heading = heading_var = math.nan
        if self.pose:
            hist = self.p[:, j0:j1, i0:i1].sum(axis=(1, 2))
            top = int(np.argmax(hist))
            idx = range(self.bins) if self.bins <= 5 else [(top - 2 + t) % self.bins for t in range(5)]
            step = TWO_PI / self.bins
            ss = sum(hist[b] * math.sin(self.offset + step * b) for b in idx)
            cc = sum(hist[b] * math.cos(self.offset + step * b) for b in idx)
            heading = math.atan2(ss, cc)
            mass = self.p.sum(axis=(1, 2))  # the whole belief's heading histogram
            theta = self.offset + step * np.arange(self.bins)
            mean = math.atan2((mass * np.sin(theta)).sum(), (mass * np.cos(theta)).sum())
            heading_var = float((mass * np.angle(np.exp(1j * (theta - mean))) ** 2).sum() / mass.sum())
        return x, y, heading, cov, radius, confidence, cell, bool(flat), heading_var

    def marginal(self) -> np.ndarray:
        m = self.p.sum(0)
        return m / m.sum()
