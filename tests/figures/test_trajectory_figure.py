"""The trajectory figure: estimates, truth and per-frame errors where the data puts them."""

from __future__ import annotations

import numpy as np
import pytest

from nightloc.figures.trajectory import trajectory_figure


def _walk():
    t = np.linspace(0, np.pi, 30)
    truth = np.column_stack([3 * np.cos(t), 2 * np.sin(t)])
    rng = np.random.default_rng(2)
    estimates = truth + rng.normal(0, 0.2, truth.shape)
    references = np.column_stack([g.ravel() for g in np.meshgrid(np.arange(-3.0, 4.0), np.arange(0.0, 3.0))])
    return references, estimates, truth


def _line(ax, label):
    [line] = [line for line in ax.lines if line.get_label() == label]
    return line


def test_estimates_truth_and_errors_land_on_their_data(tmp_path):
    references, estimates, truth = _walk()
    fig = trajectory_figure(references, estimates, truth, caption="garden/night_query against day_reference")
    track, errors = fig.axes
    np.testing.assert_array_equal(track.collections[0].get_offsets(), references)
    estimate = _line(track, "estimate")
    np.testing.assert_array_equal(np.column_stack(estimate.get_data()), estimates)
    np.testing.assert_array_equal(np.column_stack(_line(track, "truth").get_data()), truth)
    # one segment per frame from the estimate to its truth, separated by NaN
    segments = np.column_stack(_line(track, "error").get_data())
    np.testing.assert_array_equal(segments[0::3], estimates)
    np.testing.assert_array_equal(segments[1::3], truth)
    assert np.isnan(segments[2::3]).all()
    distance = np.hypot(*(estimates - truth).T)
    [per_frame, median] = errors.lines
    np.testing.assert_allclose(per_frame.get_ydata(), distance)
    assert median.get_ydata()[0] == pytest.approx(np.median(distance))
    assert errors.get_title() == "distance error per frame (n=30)"
    assert "garden/night_query" in fig.get_suptitle()
    assert trajectory_figure(references, estimates, path=tmp_path / "t.svg").axes[0].get_legend() is not None
    assert (tmp_path / "t.svg").read_bytes().lstrip().startswith(b"<?xml")


def test_wrong_shapes_are_named():
    references, estimates, truth = _walk()
    with pytest.raises(ValueError, match=r"truth must be \(30, 2\)"):
        trajectory_figure(references, estimates, truth[:-1])
    with pytest.raises(ValueError, match="estimates must be"):
        trajectory_figure(references, estimates[:, 0])
