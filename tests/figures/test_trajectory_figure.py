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
    [per_frame, median, lost] = errors.lines
    np.testing.assert_allclose(per_frame.get_ydata(), distance)
    assert median.get_ydata()[0] == pytest.approx(np.median(distance))
    assert lost.get_ydata()[0] == 1.0 and "longest run" in lost.get_label()
    assert errors.get_title() == "distance error per frame (n=30)"
    assert "garden/night_query" in fig.get_suptitle()
    assert trajectory_figure(references, estimates, path=tmp_path / "t.svg").axes[0].get_legend() is not None
    assert (tmp_path / "t.svg").read_bytes().lstrip().startswith(b"<?xml")


def test_confidence_and_the_tail_are_drawn_beside_the_errors():
    references, estimates, truth = _walk()
    estimates[12:16] += 5.0  # four frames lost: frames 13-16, all from the 10th on
    confidence = np.linspace(0.2, 0.9, 30)
    fig = trajectory_figure(references, estimates, truth, confidence=confidence)
    errors = fig.axes[1]
    [trust] = fig.axes[2].lines
    np.testing.assert_allclose(trust.get_ydata(), confidence)
    assert fig.axes[2].get_ylim() == (0, 1.05)
    lost = next(line for line in errors.lines if "longest run" in line.get_label())
    assert "longest run 4" in lost.get_label() and "19.0 % over" in lost.get_label()  # 4 of the 21 from the 10th
    with pytest.raises(ValueError, match="confidence must have one value per estimate"):
        trajectory_figure(references, estimates, truth, confidence=confidence[:-1])


def test_wrong_shapes_are_named():
    references, estimates, truth = _walk()
    with pytest.raises(ValueError, match=r"truth must be \(30, 2\)"):
        trajectory_figure(references, estimates, truth[:-1])
    with pytest.raises(ValueError, match="estimates must be"):
        trajectory_figure(references, estimates[:, 0])


def test_a_log_without_truth_fits_the_view_caps_the_disks_and_keeps_the_title_on_the_page():
    """A real robot's log has no truth and a lost filter's credible radius reaches 100+ m: the
    view fits the trajectory, the disks are drawn at most a share of it, and a long caption
    wraps inside the figure (it was clipped)."""
    from matplotlib.patches import Circle

    from nightloc.figures.trajectory import MAX_DRAWN_RADIUS_SHARE

    t = np.linspace(0, 2 * np.pi, 60)
    estimates = np.column_stack([10 + 2 * np.cos(t), 20 + 1.5 * np.sin(t)])
    radius = np.where(np.arange(60) < 5, 180.0, 0.3)
    references = np.column_stack([np.linspace(-50, 50, 40), np.linspace(-30, 60, 40)])
    caption = (
        "600 frames of a_rather_long_night_log_folder_name against 1234 references; odometry: the log's, "
        "noise 0.1,0.02; disks: credible radius (95%); parameters from garden_params.toml"
    )
    fig = trajectory_figure(references, estimates, credible_radius=radius, caption=caption)
    [ax] = fig.axes
    fig.canvas.draw()
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    assert x0 <= estimates[:, 0].min() and x1 >= estimates[:, 0].max()
    assert y0 <= estimates[:, 1].min() and y1 >= estimates[:, 1].max()
    assert max(x1 - x0, y1 - y0) < 3 * 4.0 + 2, "the view must fit the 4 m trajectory, not the map or the disks"
    disks = [artist for artist in ax.get_children() if isinstance(artist, Circle)]
    assert len(disks) == 60
    largest = max(disk.get_radius() for disk in disks)
    assert largest <= MAX_DRAWN_RADIUS_SHARE * max(x1 - x0, y1 - y0) + 1e-9
    assert sorted(disk.get_radius() for disk in disks)[0] == pytest.approx(0.3)
    assert "drawn up to" in " ".join(text.get_text() for text in ax.get_legend().get_texts())
    page = fig.bbox
    title = fig._suptitle.get_window_extent()
    assert title.x0 >= page.x0 and title.x1 <= page.x1 and title.y1 <= page.y1, (title, page)
    assert "garden_params.toml" in fig.get_suptitle()
