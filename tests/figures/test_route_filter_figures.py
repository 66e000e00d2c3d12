"""The route filter's figures: drawn, saved atomically, and their content checked against the
data they show."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from nightloc import route
from nightloc.figures.route import filter_confidence_figure, pr_comparison_figure, save_route_figures

import route_oracle as ro


@pytest.fixture(scope="module")
def results():
    refs, queries, _ = ro.synthetic_route(120, 100, speed=1.0, seed=13)
    truth = route.GroundTruth.from_frames(100, 120, 2)
    out = {}
    for method in ("filter", "seqslam"):
        result = route.match_prepared(refs, queries, route.RouteParams(method=method))
        out[method] = (result, route.evaluate_matches(result.refs, result.scores, truth))
    return out


def test_filter_confidence_figure(results, tmp_path):
    result, evaluation = results["filter"]
    fig = filter_confidence_figure(result, evaluation)
    ax = fig.axes[0]
    assert "route filter, sharpness 0.7" in ax.get_title()
    # Two scatters (correct, wrong) hold every query's confidence once.
    shown = np.concatenate([c.get_offsets()[:, 1] for c in ax.collections])
    np.testing.assert_allclose(np.sort(shown), np.sort(result.confidence))
    np.testing.assert_allclose(ax.lines[-1].get_ydata(), result.off_route)
    path = tmp_path / "confidence.png"
    filter_confidence_figure(result, evaluation, path)
    image = cv2.imread(str(path))
    assert image is not None and image.shape[2] == 3 and image.shape[1] > 800
    with pytest.raises(ValueError, match="route filter"):
        filter_confidence_figure(results["seqslam"][0], results["seqslam"][1])


def test_pr_comparison_figure_and_saved_set(results, tmp_path):
    evaluations = {method: evaluation for method, (_, evaluation) in results.items()}
    fig = pr_comparison_figure(evaluations)
    labels = [line.get_label() for line in fig.axes[0].lines]
    assert [label.split(":")[0] for label in labels] == ["filter", "seqslam"]
    assert f"{evaluations['filter'].best_f1:.3f}" in labels[0]
    np.testing.assert_allclose(fig.axes[0].lines[0].get_xdata()[1:], evaluations["filter"].curve.recall)
    paths = save_route_figures(*results["filter"], tmp_path)
    assert paths[-1].name == "filter_confidence.png"
    assert all(cv2.imread(str(p)) is not None for p in paths)
    svg = save_route_figures(*results["filter"], tmp_path, "svg")
    assert svg[-1].name == "filter_confidence.svg" and svg[-1].read_text().lstrip().startswith("<?xml")
    pr_comparison_figure(evaluations, tmp_path / "comparison.pdf")
    assert (tmp_path / "comparison.pdf").read_bytes().startswith(b"%PDF")
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
