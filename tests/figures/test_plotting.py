"""nightloc.plotting: pixels land where the data says, PNGs are valid and written atomically."""

from __future__ import annotations

import os

import cv2
import numpy as np
import pytest

from nightloc.figures.plotting import Figure, apply_colormap, box_statistics, nice_ticks, save_png

RED_BGR = (40, 39, 214)


def _rows_with_colour(image: np.ndarray, bgr, columns: slice, tol: int = 30) -> np.ndarray:
    close = np.all(np.abs(image[:, columns].astype(int) - np.array(bgr)) <= tol, axis=2)
    return np.flatnonzero(close.any(axis=1))


def test_box_statistics_match_numpy_percentiles_and_tukey_whiskers():
    sample = np.array([1.0, 2, 3, 4, 5, 6, 7, 8, 100])
    stats = box_statistics(sample)
    q1, med, q3 = np.percentile(sample, [25, 50, 75])
    assert (stats.q1, stats.median, stats.q3) == (q1, med, q3)
    assert stats.whisker_low == 1 and stats.whisker_high == 8  # 100 is beyond q3 + 1.5 IQR = 13
    assert stats.outliers.tolist() == [100.0] and stats.count == 9
    with pytest.raises(ValueError, match="finite"):
        box_statistics([np.nan])


def test_box_median_line_lands_at_its_y_pixel():
    fig = Figure(400, 300)
    ax = fig.axes()
    ax.set_ylim(0, 10)
    ax.boxplot([[2.0, 3.0, 6.0, 7.0, 8.0]], median_color="red")  # median 6
    image = fig.render()
    _, py = ax.to_pixel(1.0, 6.0)
    x0, _, x1, _ = ax.plot_box
    rows = _rows_with_colour(image, RED_BGR, slice(x0, x1))
    assert rows.size and abs(rows.mean() - py) <= 1.0
    # the box itself spans the quartiles: black edges at q1 = 3 and q3 = 7
    _, q1 = ax.to_pixel(1.0, 3.0)
    _, q3 = ax.to_pixel(1.0, 7.0)
    column = int(round(ax.to_pixel(1.0, 0)[0]))
    dark = np.flatnonzero(image[:, column - 12 : column - 8].max(axis=2).min(axis=1) < 100)
    assert np.any(np.abs(dark - q1) <= 1) and np.any(np.abs(dark - q3) <= 1)


def test_heat_map_hottest_cell_drawn_where_its_data_lies():
    values = np.zeros((20, 30))
    values[15, 4] = 1.0  # row 15 from the bottom, column 4
    fig = Figure(500, 400)
    ax = fig.axes()
    ax.image(values, extent=(0.0, 3.0, 0.0, 2.0), cmap="jet")
    image = fig.render()
    hot = apply_colormap(np.array([1.0]), "jet", 0, 1)[0]
    x0, y0, x1, y1 = ax.plot_box
    area = image[y0:y1, x0:x1].astype(int)
    mask = np.all(np.abs(area - hot) <= 2, axis=2)
    ys, xs = np.nonzero(mask)
    assert xs.size > 0
    # cell (col 4, row 15) covers x in [0.4, 0.5], y in [1.5, 1.6]
    cx, cy = ax.to_pixel(0.45, 1.55)
    assert abs(xs.mean() + x0 - cx) <= 1.0 and abs(ys.mean() + y0 - cy) <= 1.0


def test_heat_map_nan_is_grey_and_colour_map_endpoints():
    colours = apply_colormap(np.array([0.0, 0.5, 1.0, np.nan]), "jet")
    assert tuple(colours[3]) == (200, 200, 200)
    assert tuple(colours[0]) == tuple(cv2.applyColorMap(np.array([[0]], np.uint8), cv2.COLORMAP_JET)[0, 0])
    assert tuple(colours[2]) == tuple(cv2.applyColorMap(np.array([[255]], np.uint8), cv2.COLORMAP_JET)[0, 0])
    with pytest.raises(ValueError, match="colour map"):
        apply_colormap(np.zeros(3), "nope")


def test_scatter_circle_sizes_and_crosses_drawn_at_points():
    fig = Figure(400, 400)
    ax = fig.axes()
    ax.set_xlim(0, 10).set_ylim(0, 10).set_grid(False)
    ax.scatter([2.0, 8.0], [2.0, 8.0], size=[4.0, 12.0], color="green", filled=True)
    ax.scatter([5.0], [5.0], size=6, color="red", marker="x", thickness=2)
    image = fig.render()
    green = (44, 160, 44)
    for (x, y), radius in (((2.0, 2.0), 4.0), ((8.0, 8.0), 12.0)):
        px, py = ax.to_pixel(x, y)
        window = image[int(py) - 20 : int(py) + 21, int(px) - 20 : int(px) + 21].astype(int)
        area = np.all(np.abs(window - green) <= 40, axis=2).sum()
        assert abs(area - np.pi * radius**2) <= 0.35 * np.pi * radius**2
    px, py = ax.to_pixel(5.0, 5.0)
    assert np.all(np.abs(image[int(round(py)), int(round(px))].astype(int) - RED_BGR) <= 60)
    # a cross: its diagonal is drawn, its horizontal arm is not
    assert np.all(np.abs(image[int(round(py)) - 4, int(round(px)) - 4].astype(int) - RED_BGR) <= 80)
    assert image[int(round(py)), int(round(px)) + 5].min() > 200


def test_line_plot_passes_through_its_points():
    fig = Figure(300, 300)
    ax = fig.axes()
    ax.set_xlim(0, 1).set_ylim(0, 1).set_grid(False)
    ax.plot([0.0, 1.0], [0.0, 1.0], color="blue", thickness=3)
    image = fig.render()
    for t in (0.25, 0.5, 0.75):
        px, py = ax.to_pixel(t, t)
        assert image[int(round(py)), int(round(px))].max() < 200  # coloured, not white


def test_grouped_boxplot_places_series_side_by_side_with_legend():
    fig = Figure(600, 300)
    ax = fig.axes()
    rng = np.random.default_rng(0)
    stats = ax.grouped_boxplot(
        {"on": [rng.random(10), rng.random(10)], "off": [rng.random(10), rng.random(10)]}, ["1", "7"]
    )
    assert set(stats) == {"on", "off"} and len(stats["on"]) == 2
    image = fig.render()
    assert image.shape == (300, 600, 3)


def test_save_png_is_valid_png_of_requested_size_and_atomic(tmp_path):
    fig = Figure(321, 123, rows=1, cols=2, title="t")
    fig.axes(0, 0).plot([0, 1], [1, 2], label="a")
    fig.axes(0, 0).legend()
    path = fig.save(tmp_path / "figure.png")
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    decoded = cv2.imread(str(path))
    assert decoded.shape == (123, 321, 3)
    assert os.listdir(tmp_path) == ["figure.png"]  # no temporary left behind
    with pytest.raises(FileNotFoundError, match="does not exist"):  # outputs never create their parent folders
        save_png(tmp_path / "made" / "x.png", decoded)
    with pytest.raises(ValueError, match="uint8"):
        save_png(tmp_path / "y.png", decoded.astype(np.float32))
    assert os.listdir(tmp_path) == ["figure.png"]


def test_nice_ticks_are_round_and_cover_range():
    ticks = nice_ticks(0.0, 7.3)
    assert ticks[0] == 0.0 and ticks[-1] <= 7.3 and np.allclose(np.diff(ticks), ticks[1] - ticks[0])
    assert (ticks[1] - ticks[0]) in (1.0, 2.0)


def test_bad_arguments_are_clear_errors():
    fig = Figure(200, 200)
    ax = fig.axes()
    with pytest.raises(ValueError, match="same length"):
        ax.plot([1, 2], [1])
    with pytest.raises(ValueError, match="marker"):
        ax.scatter([1], [1], marker="*")
    with pytest.raises(ValueError, match="colour"):
        ax.plot([1], [1], color="nope")
    with pytest.raises(ValueError, match="extent"):
        ax.image(np.zeros((2, 2)), extent=(1, 0, 0, 1))
    with pytest.raises(IndexError):
        fig.axes(1, 0)
    with pytest.raises(ValueError, match="width"):
        Figure(10, 200)
