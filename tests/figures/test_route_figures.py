"""Route-mode figures: matches where the matrix says, the PR curve as computed, captions that
name the data and the preset."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import nightloc
from nightloc import route
from nightloc.figures.route import (
    correspondence_figure,
    difference_matrix_figure,
    pr_curve_figure,
    route_caption,
    save_route_figures,
)

import route_oracle as ro


@pytest.fixture(scope="module")
def matched():
    refs, queries, truth = ro.synthetic_route(90, 80, speed=1.0, seed=3)
    result = route.match_prepared(nightloc.block_normalize(refs), nightloc.block_normalize(queries), "openseqslam")
    evaluation = route.evaluate_matches(
        result.refs, result.scores, route.GroundTruth.from_frames(80, 90, tolerance=2, correspondence=truth)
    )
    return result, evaluation


def test_matches_are_dots_on_their_cells_coloured_by_correctness(matched):
    result, evaluation = matched
    fig = difference_matrix_figure(result, evaluation)
    ax = fig.axes[0]
    [image] = ax.get_images()
    assert tuple(image.get_extent()) == (0, result.n_queries, 0, result.n_refs) and image.origin == "lower"
    # the image's row r, column q is the enhanced matrix at (query q, reference r)
    np.testing.assert_array_equal(image.get_array(), result.enhanced.T)
    correct, wrong = ax.collections
    defined = np.flatnonzero(result.refs >= 0)
    good = evaluation.correct[defined]
    expected = np.column_stack([defined + 0.5, result.refs[defined] + 0.5])
    np.testing.assert_array_equal(correct.get_offsets(), expected[good])
    np.testing.assert_array_equal(wrong.get_offsets(), expected[~good])
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        f"correct ({good.sum()})",
        f"wrong ({(~good).sum()})",
    ]
    # without ground truth, one colour for every match
    [plain] = difference_matrix_figure(result).axes[0].collections
    np.testing.assert_array_equal(plain.get_offsets(), expected)


def test_pr_curve_is_the_evaluation_curve_from_full_precision(matched):
    _, evaluation = matched
    ax = pr_curve_figure(evaluation).axes[0]
    curve, at_100, best = ax.lines
    np.testing.assert_array_equal(curve.get_xdata(), np.concatenate([[0.0], evaluation.curve.recall]))
    np.testing.assert_array_equal(curve.get_ydata(), np.concatenate([[1.0], evaluation.curve.precision]))
    assert (at_100.get_xdata()[0], at_100.get_ydata()[0]) == (evaluation.recall_at_100, 1.0)
    assert (best.get_xdata()[0], best.get_ydata()[0]) == (evaluation.best_f1_recall, evaluation.best_f1_precision)
    assert f"{evaluation.recall_at_100:.3f}" in at_100.get_label()


def test_correspondences_highlight_true_positives_at_full_precision(matched):
    result, evaluation = matched
    ax = correspondence_figure(result, evaluation).axes[0]
    everything, accepted = ax.collections
    defined = np.flatnonzero(result.refs >= 0)
    np.testing.assert_array_equal(everything.get_offsets(), np.column_stack([defined, result.refs[defined]]))
    keep = (result.scores[defined] <= evaluation.threshold_at_100) & evaluation.correct[defined]
    np.testing.assert_array_equal(accepted.get_offsets()[:, 0], defined[keep])
    [truth] = ax.lines
    assert np.array_equal(truth.get_ydata(), np.where(evaluation.true_refs >= 0, evaluation.true_refs, np.nan), True)


def test_caption_names_the_data_the_preset_and_what_changed(matched, tmp_path):
    result, _ = matched
    text = route_caption(result, tmp_path / "nordland" / "summer", "winter", "openseqslam", "names, ±2 frames")
    assert "reference nordland/summer (90 frames) vs query winter (80 frames)" in text
    assert "preset openseqslam;" in text and "ds 10, speeds 0.8-1.2, centred" in text and "names, ±2 frames" in text
    changed = dataclasses.replace(result, params=dataclasses.replace(result.params, ds=6, mode="causal"))
    assert "preset openseqslam with ds=6, mode=causal; SeqSLAM ds 6" in route_caption(changed, preset="openseqslam")
    # without a name, the closest preset
    assert "preset openseqslam;" in route_caption(result)
    nightloc_params = dataclasses.replace(result, params=route.RouteParams(vmax=1.5))
    assert "preset nightloc with vmax=1.5" in route_caption(nightloc_params)


def test_save_route_figures_writes_each_format_with_the_caption(matched, tmp_path):
    result, evaluation = matched
    paths = save_route_figures(
        result, evaluation, tmp_path, "svg", reference="day", query="night", preset="openseqslam"
    )
    assert [p.name for p in paths] == ["difference_matrix.svg", "pr_curve.svg", "correspondence.svg"]
    for path in paths:
        assert "reference day (90 frames) vs query night (80 frames)" in path.read_text()
    (tmp_path / "none").mkdir()  # outputs never create their folder's parents
    assert [p.name for p in save_route_figures(result, None, tmp_path / "none")] == ["difference_matrix.png"]
