"""The route filter's figures: drawn, saved atomically, and their content checked against the
data they show."""

from __future__ import annotations

import dataclasses
import re

import cv2
import numpy as np
import pytest

from nightloc import route
from nightloc.figures.route import filter_confidence_figure, pr_comparison_figure, save_route_figures
from nightloc.route.report import route_metrics

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
    assert "route filter, speed motion model 0.5..1.5, sharpness 0.7" in ax.get_title()
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


def test_captions_name_the_speeds_of_the_motion_model_that_ran(results):
    """The speed model runs with filter_speed_min..max (0.5..1.5), not the window's vmin..vmax."""
    result, _ = results["filter"]
    assert result.motion == "speed"
    title = filter_confidence_figure(result).axes[0].get_title()
    assert "speed motion model 0.5..1.5" in title and "0.8" not in title and "1.2" not in title, title
    refs, queries, _ = ro.synthetic_route(60, 50, speed=1.0, seed=3)
    window = route.match_prepared(refs, queries, route.RouteParams(filter_motion="window", vmin=0.7, vmax=1.4))
    assert window.motion == "window"
    assert "speed window 0.7..1.4" in filter_confidence_figure(window).axes[0].get_title()
    changed = dataclasses.replace(result, params=dataclasses.replace(result.params, filter_speed_max=2.0))
    assert "speed motion model 0.5..2" in filter_confidence_figure(changed).axes[0].get_title()


def test_the_confidence_figure_draws_the_level_summary_json_gives_and_names_its_scale(results):
    result, evaluation = results["filter"]
    summary = route_metrics(result, evaluation)  # what the command writes to summary.json
    assert summary["score_scale"] == "1 - confidence"
    assert summary["confidence_at_100_precision"] == pytest.approx(1.0 - summary["threshold_at_100_precision"])
    [level] = [
        line for line in filter_confidence_figure(result, evaluation).axes[0].lines if "100%" in line.get_label()
    ]
    label = level.get_label()
    shown = re.search(r"confidence >= (\d\.\d+)\s+\(score = 1 - confidence <= (\d\.\d+)\)", label)
    assert shown, label
    assert float(shown.group(1)) == pytest.approx(summary["confidence_at_100_precision"], abs=5e-5)
    assert float(shown.group(2)) == pytest.approx(summary["threshold_at_100_precision"], abs=5e-5)
    assert level.get_ydata()[0] == summary["confidence_at_100_precision"]
    seqslam = route_metrics(*results["seqslam"])
    assert seqslam["confidence_at_100_precision"] is None and seqslam["score_scale"] == "uniqueness ratio"
