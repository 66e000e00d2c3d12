"""The compiled heat-map kernels against numpy/scipy oracles and the OpenCV formulation.

* translation: ``scipy.ndimage.map_coordinates`` (bilinear, zero beyond the grid) in float64,
  and :func:`add_translated_opencv` (the three-pass formulation nightloc used before) in float32;
* the sequence's frame maps: scipy's float32 CSR product (bit for bit);
* the sequence sum: :func:`heat_oracle.fuse` in float64;
* the localizer's peak, runner-up and estimate: :meth:`HeatMapper.estimate` (numpy) on the same
  fused map, field for field.

Every SIMD path must give the same values as the scalar one.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import map_coordinates

import nightloc
from nightloc import _core
from nightloc.localization.heatmap import HeatMapper
from nightloc.localization.localizer import Localizer
from nightloc.localization.sequence import PaddedLayout, add_translated, cumulative_offsets
from nightloc.matching.sad import MatchResult

from heat_oracle import add_translated_opencv, fuse, scratch

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize


def _oracle(heat, sx, sy):
    jj, ii = np.mgrid[0 : heat.shape[0], 0 : heat.shape[1]]
    return map_coordinates(heat, [jj - sy, ii - sx], order=1, mode="grid-constant", cval=0.0)


def _shifts(rng, n):
    for k in range(n):
        sx, sy = rng.uniform(-25, 25, 2)
        if k % 4 == 0:
            sx = float(np.round(sx))
        if k % 9 == 0:
            sy = float(np.round(sy))
        yield float(sx), float(sy)


def test_translation_matches_scipy_and_opencv(simd_path):
    rng = np.random.default_rng(40)
    worst64 = worst32 = worst_cv = 0.0
    for sx, sy in _shifts(rng, 300):
        h, w = (int(v) for v in rng.integers(1, 30, 2))
        heat = rng.random((h, w))
        expected = _oracle(heat, sx, sy)
        layout = PaddedLayout(h, w)
        out = layout.zeros()
        add_translated(layout, out, layout.pad(heat), sx, sy)
        worst64 = max(worst64, np.abs(layout.view(out) - expected).max())
        layout32 = PaddedLayout(h, w, np.float32)
        src = layout32.pad(heat.astype(np.float32))
        core, reference = layout32.zeros(), layout32.zeros()
        add_translated(layout32, core, src, sx, sy)
        add_translated_opencv(layout32, reference, src, sx, sy, scratch(layout32))
        worst32 = max(worst32, np.abs(layout32.view(core) - expected).max())
        worst_cv = max(worst_cv, np.abs(layout32.view(core) - layout32.view(reference)).max())
    assert worst64 < 1e-13
    assert worst32 < 1e-6  # float32 weights and sums
    assert worst_cv < 1e-6  # the OpenCV passes round alike (up to an ulp where they contract to FMA)


def test_every_simd_path_translates_identically():
    rng = np.random.default_rng(41)
    cases = [(int(h), int(w), sx, sy) for (h, w), (sx, sy) in zip(rng.integers(1, 130, (30, 2)), _shifts(rng, 30))]
    results = {}
    for path in nightloc.available_simd_backends():
        with nightloc.use_simd_backend(path):
            outputs = []
            for h, w, sx, sy in cases:
                for dtype in (np.float32, np.float64):
                    layout = PaddedLayout(h, w, dtype)
                    out = layout.pad(np.full((h, w), 0.5, dtype))
                    source = layout.pad(np.linspace(0, 1, h * w).reshape(h, w).astype(dtype))
                    add_translated(layout, out, source, sx, sy)
                    outputs.append(out.copy())
            results[path] = outputs
    for path, outputs in results.items():
        for got, want in zip(outputs, results["scalar"]):
            np.testing.assert_array_equal(got, want, err_msg=path)


def test_translation_errors():
    layout = PaddedLayout(4, 5, np.float32)
    out, src = layout.zeros(), layout.zeros()
    with pytest.raises(ValueError, match="finite"):
        add_translated(layout, out, src, float("nan"), 0.0)
    with pytest.raises(TypeError, match="float32"):
        _core.add_translated(out, src.astype(np.float64), 4, 5, 6, 0.0, 0.0)
    with pytest.raises(TypeError, match="float32 or float64"):
        _core.add_translated(out.astype(np.int32), src, 4, 5, 6, 0.0, 0.0)
    with pytest.raises(ValueError, match="fewer"):
        _core.add_translated(out[:10], src, 4, 5, 6, 0.0, 0.0)
    frozen = layout.zeros()
    frozen.setflags(write=False)
    with pytest.raises(ValueError, match="writable"):
        _core.add_translated(frozen, src, 4, 5, 6, 0.0, 0.0)


def _mapper(rng, n=30, **kwargs):
    positions = rng.uniform([0, 0], [8, 6], (n, 2))
    return HeatMapper(positions, grid_width=60, grid_height=45, **kwargs)


@pytest.mark.parametrize("options", [{}, {"outside": "nearest"}, {"interpolation": False}, {"inversion": "zscore"}])
def test_sequence_frames_and_sum_match_scipy_and_fuse(options, simd_path):
    rng = np.random.default_rng(42)
    mapper = _mapper(rng, **options)
    sequence = mapper.sequence(5)
    frames = []
    for _t in range(9):
        scores = rng.uniform(5, 40, mapper.n_refs)
        values, fill = mapper.place_excess(scores)
        sequence.push(values, fill)
        padded, fill2 = mapper.excess(scores)
        assert fill2 == fill
        # the frame's map is scipy's float32 CSR product, bit for bit
        np.testing.assert_array_equal(sequence.frame(-1), mapper.layout.view(padded))
        heat, _ = mapper.heat_map(scores)
        frames.append((heat, fill))
        window = frames[-5:]
        steps = rng.normal(0, 0.5, (len(window) - 1, 2))
        offsets = mapper.grid.to_cells(cumulative_offsets(steps)) if len(window) > 1 else np.zeros((0, 2))
        fill_sum, cell, peak, floor, second = sequence.fuse_peak(np.ascontiguousarray(offsets))
        expected = fuse([h for h, _ in window], np.vstack([offsets, [0.0, 0.0]]), [f for _, f in window])
        np.testing.assert_allclose(sequence.fused() + fill_sum, expected, atol=2e-5)
        assert fill_sum == pytest.approx(sum(f for _, f in window), abs=1e-12)
        assert sequence.size == len(window)
        # the peak of the compiled sum equals numpy's on the same map
        fused = sequence.fused()
        assert (cell, peak, floor) == (int(np.argmax(fused)), float(fused.max()), float(fused.min()))
        assert mapper.estimate_from_peak(cell, peak, floor, second, scores) == mapper.estimate(fused, scores)


def test_sequence_ring_and_errors():
    rng = np.random.default_rng(43)
    mapper = _mapper(rng)
    sequence = mapper.sequence(3)
    assert sequence.size == 0 and sequence.capacity == 3
    with pytest.raises(ValueError, match="empty"):
        sequence.fuse_peak(np.zeros((0, 2)))
    pushed = []
    for _t in range(5):
        values, fill = mapper.place_excess(rng.uniform(5, 40, mapper.n_refs))
        sequence.push(values, fill)
        pushed.append(fill)
    assert sequence.size == 3 and [sequence.fill(k) for k in range(3)] == pushed[-3:]
    assert sequence.fill(-1) == pushed[-1]
    with pytest.raises(IndexError):
        sequence.frame(3)
    with pytest.raises(ValueError, match="one row per earlier frame"):
        sequence.fuse_peak(np.zeros((1, 2)))
    with pytest.raises(ValueError, match="finite"):
        sequence.fuse_peak(np.array([[0.0, 1.0], [np.nan, 0.0]]))
    with pytest.raises(TypeError, match="float64"):
        sequence.fuse_peak(np.zeros((2, 2), np.float32))
    with pytest.raises(ValueError, match="entries"):
        sequence.push(np.zeros(mapper._places.shape[0] + 1, np.float32), 0.0)
    with pytest.raises(ValueError, match="finite"):
        sequence.push(np.full(mapper._places.shape[0], np.inf, np.float32), 0.0)
    assert sequence.size == 3 and sequence.fill(-1) == pushed[-1]  # refused frames change nothing
    sequence.clear()
    assert sequence.size == 0


def _result(scores, rng):
    scores = np.asarray(scores, dtype=np.float32)
    shifts = rng.integers(0, 48, scores.size).astype(np.int32)
    headings = shifts * (2 * np.pi / 48)
    headings = np.where(headings > np.pi, headings - 2 * np.pi, headings)
    return MatchResult(int(np.argmin(scores)), scores, shifts, headings, 48)


def test_localizer_estimates_equal_the_numpy_estimate_of_its_fused_map():
    """Peak, runner-up and estimate computed in the core equal HeatMapper.estimate (numpy) on
    the localizer's own fused map, field for field, over a drive with odometry."""
    rng = np.random.default_rng(44)
    positions = np.array([(x, y) for x in np.arange(0, 7.5, 1.5) for y in np.arange(0, 5, 1.25)])
    images = rng.integers(0, 256, (len(positions), 24, 48), dtype=np.uint8)
    ref_map = nightloc.ReferenceMap(images, positions, rng.uniform(-np.pi, np.pi, len(positions)))
    for options in ({}, {"interpolation": False}, {"confidence_radius": 0.3}):
        loc = Localizer(ref_map, method="paper", seq_len=6, **options)
        for t in range(15):
            result = _result(rng.uniform(5, 40, len(positions)), rng)
            est = loc.update_match(result, rng.normal(0, 0.3, 2) if t % 7 else None, return_heatmap=True)
            fused = est.heatmap  # float64 = float32 fused map + fill sum
            expected = loc.mapper.estimate(fused, result.scores)
            assert (est.x, est.y, est.ref_index) == (expected.x, expected.y, expected.ref_index)
            assert est.confidence == pytest.approx(expected.confidence, abs=1e-6)


def test_localizers_pickle_and_copy_mid_sequence():
    """A localizer's compiled sequence is saved with it (pickle, copy.deepcopy): the copies give
    the same estimates and heat maps as the original from there on."""
    import copy
    import pickle

    rng = np.random.default_rng(45)
    positions = rng.uniform([0, 0], [7, 5], (20, 2))
    images = nightloc.prepare(rng.integers(0, 256, (20, 48, 96), dtype=np.uint8))
    ref_map = nightloc.ReferenceMap(images, positions, rng.uniform(-3, 3, 20))
    loc = Localizer(ref_map, method="paper", seq_len=4)
    frames = [rng.integers(0, 256, (120, 240, 3), dtype=np.uint8) for _ in range(8)]
    for frame in frames[:5]:
        loc.update(frame, (0.1, 0.05))
    copies = [pickle.loads(pickle.dumps(loc)), copy.deepcopy(loc)]
    for frame in frames[5:]:
        est = loc.update(frame, (0.1, 0.05), return_heatmap=True)
        for other in copies:
            got = other.update(frame, (0.1, 0.05), return_heatmap=True)
            assert (got.x, got.y, got.confidence, got.frames) == (est.x, est.y, est.confidence, est.frames)
            np.testing.assert_array_equal(got.heatmap, est.heatmap)
    weights = pickle.loads(pickle.dumps(loc.mapper._core_weights))
    values = rng.random(weights.places).astype(np.float32)
    np.testing.assert_array_equal(weights.interpolate(values), loc.mapper._core_weights.interpolate(values))
