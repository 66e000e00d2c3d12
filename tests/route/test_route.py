"""Route mode (1D SeqSLAM): the compiled kernels against the numpy oracle, the OpenSeqSLAM preset
against OpenSeqSLAM's own outputs (golden files), and the pipeline's checks and presets."""

from __future__ import annotations

import dataclasses
import json

import cv2
import numpy as np
import pytest

import nightloc
from nightloc import _core, route
from nightloc.route import RouteParams

import oracle
import route_oracle as ro

F32 = np.float32


def random_matrix(rng, rows, cols, scale=40.0):
    return (rng.random((rows, cols)) * scale).astype(F32)


# ------------------------------------------------------------------------------------------
# contrast enhancement


@pytest.mark.parametrize("shape", [(1, 2), (3, 7), (9, 11), (20, 64), (5, 300)])
@pytest.mark.parametrize("radius", [1, 5, 7])
def test_enhancement_matches_oracle(shape, radius):
    rng = np.random.default_rng(shape[0] * 1000 + shape[1] + radius)
    d = random_matrix(rng, *shape)
    if shape[1] >= 8:
        d[0, :8] = 5.0  # a flat window: 0/0 = NaN, as in OpenSeqSLAM
    z = ro.enhance_zscores(d, radius)
    for offset, expected in (
        ("none", z),
        ("global_min", (z - F32(np.nanmin(z))).astype(F32)),
        ("bound", (z + F32(_core.zscore_bound(radius))).astype(F32)),
    ):
        got = route.enhance_contrast(
            d, dataclasses.replace(RouteParams(), enhance_radius=radius), offset=offset, threads=2
        )
        np.testing.assert_array_equal(got, expected)
    if shape[1] >= 8:
        assert np.isnan(got[0, 0])
    # In place gives the same bits.
    in_place = d.copy()
    route.enhance_contrast(in_place, dataclasses.replace(RouteParams(), enhance_radius=radius), out=in_place)
    np.testing.assert_array_equal(in_place, (z - F32(np.nanmin(z))).astype(F32))


def test_enhancement_bound_bounds_zscores():
    # The most extreme window: one outlier among equal values reaches exactly the bound.
    d = np.zeros((1, 11), F32)
    d[0, 5] = 100.0
    z = route.enhance_contrast(d, offset="none")
    assert abs(float(z[0, 5]) - 10 / np.sqrt(11)) < 1e-5
    rng = np.random.default_rng(3)
    causal = route.enhance_contrast(random_matrix(rng, 50, 200), "openseqslam", offset="bound")
    assert np.nanmin(causal) >= 0.0


def test_enhancement_blocks_match_one_call():
    rng = np.random.default_rng(5)
    d = random_matrix(rng, 700, 1600)  # several row blocks of route.pipeline.BLOCK_CELLS
    whole, added = _core.enhance_contrast(d, 5, "global_min", 2)
    np.testing.assert_array_equal(route.enhance_contrast(d, threads=2), whole)
    assert float(np.nanmin(whole)) == 0.0 and added > 0


# ------------------------------------------------------------------------------------------
# trajectory search


@pytest.mark.parametrize("mode", ["centred", "causal"])
@pytest.mark.parametrize(("ds", "vmin", "vmax"), [(10, 0.8, 1.2), (7, 0.8, 1.2), (4, 0.5, 2.0), (2, 1.0, 1.0)])
def test_search_matches_oracle(mode, ds, vmin, vmax):
    rng = np.random.default_rng(ds * 17 + int(vmax * 10))
    dd = random_matrix(rng, 37, 45, scale=4.0)
    dd[4, 9] = np.nan  # ignored by the minima
    dd[6, 3:6] = dd[6, 2]  # ties: the first minimum wins
    params = RouteParams(ds=ds, vmin=vmin, vmax=vmax, uniqueness_radius=4, mode=mode)
    refs, scores = route.trajectory_search(dd, params, threads=3)
    oracle_search = ro.find_matches_centred if mode == "centred" else ro.find_matches_causal
    expected_refs, expected_scores = oracle_search(dd, ds, vmin, vmax, rwindow=8)
    np.testing.assert_array_equal(refs, expected_refs)
    np.testing.assert_array_equal(scores, expected_scores)
    half = params.effective_ds // 2
    if mode == "centred":
        assert (refs[:half] == -1).all() and (refs[len(refs) - half :] == -1).all()
        assert (refs[half : len(refs) - half] >= 0).all()
    else:
        assert (refs[: ds - 1] == -1).all() and (refs[ds - 1 :] >= 0).all()


def test_search_blocks_and_threads_agree():
    rng = np.random.default_rng(8)
    dd = random_matrix(rng, 600, 90, scale=4.0)
    one = route.trajectory_search(dd, threads=1)
    many = route.trajectory_search(dd, threads=4)
    np.testing.assert_array_equal(one[0], many[0])
    np.testing.assert_array_equal(one[1], many[1])


def test_plan_follows_octave_ranges():
    plan = _core.trajectory_plan(10, 0.8, 1.2, 5, False)
    assert plan["ds"] == 10 and plan["frames"] == 11
    assert plan["speeds"] == [0.8, 0.9, 1.0, 1.1, 1.2]
    np.testing.assert_array_equal(plan["offsets"], ro.velocity_offsets(10, 0.8, 1.2, 11))
    assert plan["columns"] == list(range(-5, 6))
    odd = _core.trajectory_plan(7, 0.8, 1.2, 5, False)  # OpenSeqSLAM forces ds even
    assert odd["ds"] == 8 and odd["frames"] == 9
    causal = _core.trajectory_plan(7, 0.8, 1.2, 5, True)
    assert causal["ds"] == 7 and causal["columns"] == list(range(-6, 1))
    assert (causal["offsets"][:, -1] == 0).all() and (causal["offsets"] <= 0).all()


def test_search_recovers_a_known_trajectory():
    # The query drives the route at 1.1 references per frame: the cheapest cells lie on it.
    n_query, n_ref = 80, 120
    q = np.arange(n_query)[:, None]
    r = np.arange(n_ref)[None, :]
    dd = (np.abs(r - 1.1 * q - 4) + 1).astype(F32)
    for mode in ("centred", "causal"):
        refs, scores = route.trajectory_search(dd, RouteParams(mode=mode))
        defined = np.flatnonzero(refs >= 0)
        truth = np.rint(1.1 * defined + 4)
        inside = truth < n_ref - 10
        assert np.abs(refs[defined][inside] - truth[inside]).max() <= 1
        assert (scores[defined][inside] < 0.8).all()


# ------------------------------------------------------------------------------------------
# difference matrix, pipeline, synthetic route


@pytest.mark.parametrize("divisor", ["pixels", "references"])
@pytest.mark.parametrize("circular", [False, True])
def test_route_difference_matrix_matches_oracle(divisor, circular):
    rng = np.random.default_rng(4)
    refs = rng.integers(0, 256, (23, 6, 8), dtype=np.uint8)
    queries = rng.integers(0, 256, (9, 6, 8), dtype=np.uint8)
    params = RouteParams(divisor=divisor, circular_shifts=circular, shift_window=(0, 0))
    got = route.route_difference_matrix(queries, refs, params, threads=2)
    shifts = np.arange(8) if circular else np.array([0])
    sums = np.stack([ro_min_sums(q, refs, shifts) for q in queries])
    scale = 23.0 if divisor == "references" else 48.0
    np.testing.assert_array_equal(got, oracle.scores_from_sums(sums, scale))
    # The default window, (8, 2) clipped to these 6 x 8 images: (7, 2); a panorama's is (0, 0).
    window = (0, 0) if circular else (7, 2)
    assert RouteParams(circular_shifts=circular).window_for(6, 8) == window
    got = route.route_difference_matrix(queries, refs, RouteParams(divisor=divisor, circular_shifts=circular))
    expected = oracle.window_difference_matrix(queries, refs, shifts, window, scale)[0]
    np.testing.assert_array_equal(got, expected)


def ro_min_sums(query, refs, shifts):
    return oracle.rotational_sums(query, refs, shifts).min(axis=1)


def test_synthetic_route_is_localized():
    refs, queries, truth = ro.synthetic_route(300, 240, speed=1.1, seed=1)
    for divisor in ("pixels", "references"):
        params = RouteParams(divisor=divisor)
        prepared_refs = nightloc.block_normalize(refs)
        prepared_queries = nightloc.block_normalize(queries)
        result = route.match_prepared(prepared_refs, prepared_queries, params)
        ok = (result.refs >= 0) & (truth >= 0)
        assert np.mean(np.abs(result.refs[ok] - truth[ok]) <= 2) > 0.95
        gt = route.GroundTruth.from_frames(len(queries), len(refs), 2, truth)
        assert route.evaluate_matches(result.refs, result.scores, gt).recall_at_100 > 0.8


def test_keep_difference_false_enhances_in_place():
    refs, queries, _ = ro.synthetic_route(80, 60, speed=1.0, seed=2)
    kept = route.match_prepared(refs, queries)
    lean = route.match_prepared(refs, queries, keep_difference=False)
    assert lean.difference is None and kept.difference is not None
    np.testing.assert_array_equal(kept.enhanced, lean.enhanced)
    np.testing.assert_array_equal(kept.refs, lean.refs)
    np.testing.assert_array_equal(kept.scores, lean.scores)
    assert set(kept.timings) == {"difference", "enhancement", "search", "speed_check"}


def test_match_route_prepares_frames():
    refs, queries, _truth = ro.synthetic_route(120, 100, speed=1.0, seed=3)
    colour_refs = np.repeat(refs[..., None], 3, axis=3)
    result = route.match_route(colour_refs, list(queries), "openseqslam")
    direct = route.match_prepared(nightloc.block_normalize(refs), nightloc.block_normalize(queries), "openseqslam")
    np.testing.assert_array_equal(result.refs, direct.refs)
    assert "preparation" in result.timings


# ------------------------------------------------------------------------------------------
# OpenSeqSLAM exactness (golden outputs of OpenSeqSLAM under Octave on Nordland)


def _golden(shared_data):
    folder = shared_data / "golden" / "openseqslam_A"
    if not folder.is_dir():
        pytest.skip(f"golden OpenSeqSLAM outputs not found at {folder}")
    params = json.loads((folder / "params.json").read_text())
    return folder, params


def test_openseqslam_preset_is_exact(shared_data):
    folder, info = _golden(shared_data)
    root = shared_data / "nordland"
    preparer = route.RoutePreparer(route.route_preset("openseqslam"))
    refs = preparer([cv2.imread(str(root / name), cv2.IMREAD_COLOR) for name in info["reference_files"]])
    queries = preparer([cv2.imread(str(root / name), cv2.IMREAD_COLOR) for name in info["query_files"]])
    np.testing.assert_array_equal(refs, np.load(folder / "pre_ref_all.npy"))
    np.testing.assert_array_equal(queries, np.load(folder / "pre_query_all.npy"))

    result = route.match_prepared(refs, queries, "openseqslam")
    np.testing.assert_array_equal(result.difference, np.load(folder / "D.npy").T)
    np.testing.assert_array_equal(result.enhanced, np.load(folder / "DD.npy").T)
    golden_refs = np.load(folder / "matches_ref_1based.npy")
    golden_scores = np.load(folder / "matches_score.npy")
    np.testing.assert_array_equal(np.where(result.refs >= 0, result.refs + 1.0, np.nan), golden_refs)
    np.testing.assert_array_equal(result.scores, golden_scores)

    # The documented figures: recall 0.402 at 100 % precision, best F1 0.641 (P 0.93, R 0.49).
    truth = route.GroundTruth.from_frames(len(queries), len(refs), 2)
    evaluation = route.evaluate_matches(result.refs, result.scores, truth)
    assert round(evaluation.recall_at_100, 3) == 0.402
    assert round(evaluation.best_f1, 3) == 0.641
    assert round(evaluation.best_f1_precision, 2) == 0.93 and round(evaluation.best_f1_recall, 2) == 0.49


def test_octave_rgb2gray_matches_oracle(shared_data):
    rng = np.random.default_rng(9)
    rgb = rng.integers(0, 256, (40, 50, 3), dtype=np.uint8)
    expected = oracle.octave_rgb2gray(rgb)
    np.testing.assert_array_equal(route.octave_rgb2gray(rgb, "rgb"), expected)
    np.testing.assert_array_equal(route.octave_rgb2gray(np.ascontiguousarray(rgb[..., ::-1])), expected)
    grey = rgb[..., 0].copy()
    assert route.octave_rgb2gray(grey) is grey
    image = cv2.imread(str(shared_data / "nordland" / "summer" / "images-10010.png"), cv2.IMREAD_COLOR)
    np.testing.assert_array_equal(route.octave_rgb2gray(image), oracle.octave_rgb2gray(image[..., ::-1]))
    # OpenCV's fixed-point grey differs: the reason the preset has its own conversion.
    assert not np.array_equal(cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY), expected)


# ------------------------------------------------------------------------------------------
# parameters and bad input


def test_presets_and_params():
    assert route.route_preset("openseqslam").divisor == "references"
    assert route.resolve_params("openseqslam", ds=7).effective_ds == 8
    assert route.resolve_params(None, mode="causal", ds=7).effective_ds == 7
    with pytest.raises(ValueError, match="unknown route preset"):
        route.route_preset("seqslam2")
    with pytest.raises(ValueError, match="vmin"):
        RouteParams(vmin=1.5, vmax=1.2)
    with pytest.raises(ValueError, match="ds must"):
        RouteParams(ds=1)
    with pytest.raises(TypeError):
        route.resolve_params(None, speed=2)
    with pytest.raises((TypeError, ValueError)):
        RouteParams(mode="forward")


def test_params_toml_roundtrip(tmp_path):
    path = tmp_path / "route.toml"
    params = RouteParams(ds=8, mode="causal", vmin=0.5)
    nightloc.save_params(path, [params, nightloc.PreparationParams(wrap=False)])
    assert nightloc.load_params(path, RouteParams) == params
    path.write_text("[route]\nds = 8\nspeed = 3\n")
    with pytest.raises(ValueError, match="speed"):
        nightloc.load_params(path, RouteParams)


def test_bad_inputs_are_clear_errors():
    rng = np.random.default_rng(0)
    refs = rng.integers(0, 256, (30, 8, 8), dtype=np.uint8)
    with pytest.raises(TypeError, match="uint8"):
        route.match_prepared(refs.astype(np.float32), refs)
    with pytest.raises(ValueError, match="empty"):
        route.match_prepared(refs, refs[:0])
    with pytest.raises(ValueError, match="8x8"):
        route.match_prepared(refs, rng.integers(0, 256, (30, 8, 9), dtype=np.uint8))
    with pytest.raises(ValueError, match="too few"):
        route.match_prepared(refs[:8], refs, RouteParams(method="seqslam"))  # 8 references, uniqueness window 11
    d = random_matrix(rng, 10, 20)
    with pytest.raises(TypeError, match="float32"):
        route.enhance_contrast(d.astype(np.float64))
    with pytest.raises(ValueError, match="C-contiguous"):
        route.enhance_contrast(np.asfortranarray(random_matrix(rng, 10, 20)))
    with pytest.raises(ValueError, match="2-D"):
        route.trajectory_search(d[0])
    with pytest.raises(ValueError, match="at least 2 references"):
        route.enhance_contrast(d[:, :1].copy())
    with pytest.raises(ValueError, match="shape"):
        route.enhance_contrast(d, out=np.empty((10, 21), F32))
    with pytest.raises(ValueError, match="does not resize"):
        route.RoutePreparer(route.route_preset("openseqslam"))([np.zeros((8, 8), np.uint8), np.zeros((8, 9), np.uint8)])
    with pytest.raises(TypeError):
        route.match_route(42, refs)


def test_nan_and_inf_follow_octave_semantics():
    # NaN cells (flat windows) and huge values must not crash and must match the oracle.
    rng = np.random.default_rng(12)
    dd = random_matrix(rng, 30, 40, scale=4.0)
    dd[10:14, :] = np.nan
    dd[20, 5] = np.inf
    refs, scores = route.trajectory_search(dd, RouteParams(uniqueness_radius=3))
    expected_refs, expected_scores = ro.find_matches_centred(dd, rwindow=6)
    np.testing.assert_array_equal(refs, expected_refs)
    np.testing.assert_array_equal(scores, expected_scores)


def test_memory_is_at_most_two_matrices():
    """Array memory allocated by the pipeline (numpy and the core's outputs, traced by
    tracemalloc): the two (n_query, n_ref) float32 matrices, one with keep_difference=False."""
    import tracemalloc

    refs, queries, _ = ro.synthetic_route(1200, 1100, speed=1.0, seed=30)
    matrix = 1100 * 1200 * 4
    for keep, limit in ((True, 2.1), (False, 1.1)):
        tracemalloc.start()
        try:
            result = route.match_prepared(refs, queries, "openseqslam", keep_difference=keep)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak <= limit * matrix, (keep, peak / matrix)
        del result
