"""Figures of an evaluation: the data lands where it should (checked through matplotlib's own
artists and transforms), box plots show n, noise ticks name Table III, the heat map's truth marker
is visible over the peak, and the chosen frame says why."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from matplotlib.text import Text

import nightloc
from nightloc.figures._common import DPI
from nightloc.figures.evaluation import (
    explain_heatmap_frame,
    heatmap_figure,
    interpolation_figure,
    noise_figure,
    pick_heatmap_frame,
    save_evaluation_figures,
    seq_len_figure,
)
from nightloc.localization.evaluation import ERRORS_HEADER, Evaluation, EvaluationSettings, QueryMatches, replay
from nightloc.localization.heatmap import HeatGrid

N_FRAMES = 20

# The paper's Table III, written out independently of nightloc.motion.odometry.
TABLE_III = {0: "none", 1: "0.1 m, 0.02 rad", 2: "0.25 m, 0.05 rad", 3: "0.5 m, 0.1 rad"}


def _matches(n_frames: int = N_FRAMES) -> QueryMatches:
    return QueryMatches(
        "garden/night_query",
        tuple(f"{i:06d}.png" for i in range(n_frames)),
        np.zeros((n_frames, 2)),
        None,
        (),
    )


def _evaluation(seq_lengths=(1, 3, 7), noise_models=(0, 1, 2, 3), interpolation=(True, False), repeats=2, seed=0):
    """An Evaluation of made-up errors: shorter sequences and more noise err more."""
    rng = np.random.default_rng(seed)
    settings = EvaluationSettings(seq_lengths, noise_models, interpolation, repeats)
    rows = {name: [] for name in ERRORS_HEADER}
    for n in seq_lengths:
        for model in noise_models:
            for interp in interpolation:
                for repeat in range(settings.repeats_of(model)):
                    errors = rng.gamma(2.0, (0.6 + 0.3 * model + (0 if interp else 0.4)) / n, N_FRAMES)
                    for frame, error in enumerate(errors):
                        values = ("garden/night_query", f"{frame:06d}.png", n, model, interp, repeat)
                        values += (0.0, 0.0, 0.0, 0.0, float(error), 0, "paper")
                        for name, value in zip(ERRORS_HEADER, values):
                            rows[name].append(value)
    return Evaluation({k: np.array(v) for k, v in rows.items()}, settings, [_matches()])


def _medians(ax) -> np.ndarray:
    """``(boxes, 2)``: x centre and median of each box's median line, left to right."""
    lines = [line for line in ax.lines if line.get_label() == "_median"]
    points = [(float(np.mean(line.get_xdata())), float(line.get_ydata()[0])) for line in lines]
    return np.array(sorted(points)).reshape(-1, 2)


def _ticks(ax):
    return [t.get_text() for t in ax.get_xticklabels()]


def _texts(fig):
    return " ".join(t.get_text() for t in fig.findobj(Text))


def test_seq_len_boxes_sit_at_each_length_with_its_median_and_n():
    ev = _evaluation()
    fig = seq_len_figure(ev)
    [ax] = fig.axes
    expected = [np.median(ev.errors(seq_len=n, noise_model=0, interpolation=True)) for n in (1, 3, 7)]
    np.testing.assert_allclose(_medians(ax), np.column_stack([[1.0, 2.0, 3.0], expected]))
    assert _ticks(ax) == [f"{n}\nn={N_FRAMES}" for n in (1, 3, 7)]
    assert ax.get_ylim()[1] >= ev.errors().max()  # every outlier is inside the axes
    assert "garden/night_query" in ax.get_title() and "noise model 0 (none)" in ax.get_xlabel()


def test_noise_ticks_name_table_iii_and_count_every_draw():
    ev = _evaluation(repeats=3)
    fig = noise_figure(ev)  # at 7 frames, the paper's
    [ax] = fig.axes
    ticks = _ticks(ax)
    for model, words in TABLE_III.items():
        n = N_FRAMES * (1 if model == 0 else 3)  # model 0 is noise-free: one draw
        assert ticks[model].startswith(f"model {model}\n") and words in ticks[model] and ticks[model].endswith(f"n={n}")
    expected = [np.median(ev.errors(seq_len=7, noise_model=m, interpolation=True)) for m in range(4)]
    np.testing.assert_allclose(_medians(ax)[:, 1], expected)
    assert "7-frame sequences" in ax.get_xlabel() and "Table III" in ax.get_xlabel()


def test_interpolation_boxes_pair_on_and_off_per_length():
    ev = _evaluation()
    fig = interpolation_figure(ev)
    [ax] = fig.axes
    medians = _medians(ax)
    assert len(medians) == 6
    for i, n in enumerate((1, 3, 7)):
        on, off = medians[2 * i], medians[2 * i + 1]
        assert on[0] < i + 1 < off[0]  # on left of the tick, off right of it
        assert on[1] == pytest.approx(np.median(ev.errors(seq_len=n, noise_model=0, interpolation=True)))
        assert off[1] == pytest.approx(np.median(ev.errors(seq_len=n, noise_model=0, interpolation=False)))
    assert _ticks(ax) == [f"{n}\nn={N_FRAMES}" for n in (1, 3, 7)]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["interpolation on", "interpolation off"]


def test_boxes_leave_out_empty_groups_but_still_count_them():
    ev = _evaluation(seq_lengths=(1, 2), noise_models=(0,), interpolation=(True,))
    ev.columns["noise_model"][ev.columns["seq_len"] == 2] = 9  # no rows left for length 2, noise 0
    [ax] = noise_figure(ev, seq_len=2).axes
    assert _medians(ax).size == 0 and _ticks(ax) == ["model 0\nnone\nn=0"]


def test_chosen_frame_is_the_largest_drop_and_says_so():
    ev = _evaluation(seq_lengths=(1, 7), noise_models=(0,), interpolation=(True,))
    single = ev.errors(seq_len=1)
    seven = ev.errors(seq_len=7)
    single[:] = 1.0
    seven[:] = 0.9
    single[3], seven[3] = 9.0, 0.1  # the largest drop, but without a whole sequence behind it
    single[11], seven[11] = 5.0, 0.5
    ev.columns["error_m"][ev.select(seq_len=1)] = single
    ev.columns["error_m"][ev.select(seq_len=7)] = seven
    assert pick_heatmap_frame(ev) == 11
    text = explain_heatmap_frame(ev, 11)
    assert text.startswith("Frame chosen where the sequence helps most")
    assert "5.00 m with 1 frame" in text and "0.50 m with 7 frames" in text and f"frames 6-{N_FRAMES - 1}" in text
    assert explain_heatmap_frame(ev, 11, requested=True).startswith("Frame requested: error 5.00 m")
    assert explain_heatmap_frame(ev, 4).startswith("Frame 4: error 1.00 m")
    with pytest.raises(ValueError, match="outside the evaluated query frames"):
        explain_heatmap_frame(ev, N_FRAMES)


# --- the heat map -----------------------------------------------------------------------------


def _heat_scene():
    """A 5 x 4 lattice of references 1 m apart and a query walking along y = 1 to x = 2, where a
    reference stands: scores grow with the distance from the truth, so the heat peaks at it."""
    xs, ys = np.meshgrid(np.arange(5.0), np.arange(4.0))
    positions = np.column_stack([xs.ravel(), ys.ravel()])
    images = np.zeros((len(positions), 24, 48), np.uint8)
    ref_map = nightloc.ReferenceMap(images, positions)
    truths = np.column_stack([np.linspace(0.2, 2.0, 7), np.ones(7)])
    results = []
    for truth in truths:
        scores = (10 + 20 * np.hypot(*(positions - truth).T)).astype(np.float32)
        results.append(
            nightloc.MatchResult(
                int(np.argmin(scores)), scores, np.zeros(len(positions), np.int32), np.zeros(len(positions)), 48
            )
        )
    matches = QueryMatches("walk", tuple(f"{i}.png" for i in range(7)), truths, None, tuple(results))
    return ref_map, matches


def test_the_sequence_panel_marks_the_sequences_reference_not_the_single_frames_best_match():
    ref_map, matches = _heat_scene()
    frame, far = 6, len(ref_map) - 1  # a look-alike far away wins the single frame only
    scores = matches.results[frame].scores.copy()
    scores[far] = scores.min() - 1
    results = list(matches.results)
    results[frame] = dataclasses.replace(results[frame], index=far, scores=scores)
    matches = dataclasses.replace(matches, results=tuple(results))
    sequence = replay(ref_map, matches, frame, 4)
    assert sequence.ref_index != far  # the sequence is not fooled
    fig = heatmap_figure(ref_map, matches, frame, seq_len=4)
    single, fused = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    for ax, reference in ((single, far), (fused, sequence.ref_index)):
        line = _line(ax, "best reference")
        assert (line.get_xdata()[0], line.get_ydata()[0]) == pytest.approx(tuple(ref_map.positions[reference]))


def _pixels(fig) -> np.ndarray:
    """The figure rendered by Agg, ``(H, W, 3)`` RGB; the layout is frozen after the first draw
    (constrained layout moves things by a pixel or so on each draw)."""
    fig.canvas.draw()
    fig.set_layout_engine("none")
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].astype(int)


def _line(ax, label):
    [line] = [line for line in ax.lines if line.get_label() == label]
    return line


def test_heat_map_panels_put_every_marker_at_its_data():
    ref_map, matches = _heat_scene()
    frame = 6
    fig = heatmap_figure(ref_map, matches, frame, seq_len=4, caption="Frame requested: test")
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    assert len(panels) == 2
    estimates = [replay(ref_map, matches, frame, 1), replay(ref_map, matches, frame, 4)]
    grid = HeatGrid.spanning(ref_map.positions, 100, 100, margin=0.25)
    result = matches.results[frame]
    for ax, est in zip(panels, estimates):
        [image] = ax.get_images()
        np.testing.assert_array_equal(image.get_array(), est.heatmap)
        assert tuple(image.get_extent()) == pytest.approx(grid.extent) and image.origin == "lower"
        [circles] = ax.collections
        np.testing.assert_array_equal(circles.get_offsets(), ref_map.positions)
        assert int(np.argmax(circles.get_sizes())) == result.index  # the best match has the largest circle
        assert np.all(np.diff(circles.get_sizes()[np.argsort(result.scores)]) <= 0)  # size falls with the score
        # the single frame's best match; the sequence's reported reference (the one closest to its estimate)
        best = result.index if est.frames == 1 else est.ref_index
        nearest = int(np.argmin(np.hypot(*(ref_map.positions - (est.x, est.y)).T)))
        assert est.frames == 1 or best == nearest
        for label, where in (
            ("truth", matches.positions[frame]),
            ("best reference", ref_map.positions[best]),
            ("estimate", (est.x, est.y)),
        ):
            line = _line(ax, label)
            assert (line.get_xdata()[0], line.get_ydata()[0]) == pytest.approx(tuple(where))
            # drawn inside the panel, above the heat map
            display = ax.transData.transform(where)
            assert ax.get_window_extent().contains(*display)
            assert line.get_zorder() > image.get_zorder() and line.get_zorder() > circles.get_zorder()
        error = np.hypot(est.x - matches.positions[frame][0], est.y - matches.positions[frame][1])
        assert ax.get_title().endswith(f"error {error:.2f} m")
    assert [p.get_title().split(":")[0] for p in panels] == ["single frame", "4-frame sequence"]
    assert "Frame requested: test" in _texts(fig) and "walk" in _texts(fig)


def test_truth_marker_stays_visible_over_the_heat_peak():
    ref_map, matches = _heat_scene()
    frame = 6
    estimate = replay(ref_map, matches, frame, 4)
    grid = HeatGrid.spanning(ref_map.positions, 100, 100, margin=0.25)
    truth = matches.positions[frame]
    column = int(round((truth[0] - grid.x0) / grid.dx))
    row = int(round((truth[1] - grid.y0) / grid.dy))
    assert estimate.heatmap[row, column] >= 0.97 * estimate.heatmap.max()  # the truth sits on the peak

    fig = heatmap_figure(ref_map, matches, frame, seq_len=4)
    panel = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"][1]
    with_truth = _pixels(fig)
    marker = _line(panel, "truth")
    reach = marker.get_markersize() * DPI / 72  # the cross's full size in pixels; its half plus edges is less
    marker.set_visible(False)
    without_truth = _pixels(fig)
    changed = np.any(with_truth != without_truth, axis=2)
    rows, cols = np.nonzero(changed)
    x, y = panel.transData.transform(truth)
    height = with_truth.shape[0]
    # the truth's pixels are where the truth is, and there are many of them: it is not hidden
    assert rows.size > 100
    assert np.abs(cols - x).max() <= reach and np.abs((height - rows) - y).max() <= reach
    # red arms with a white edge: the white tells it from jet's red peak (jet has no white)
    drawn = with_truth[changed]
    assert np.sum(np.all(drawn >= 235, axis=1)) > 20
    assert np.sum((drawn[:, 0] > 200) & (drawn[:, 1] < 60) & (drawn[:, 2] < 60)) > 20


def test_save_evaluation_figures_names_files_by_format_and_captions_the_choice(tmp_path):
    ref_map, matches = _heat_scene()
    from nightloc.localization.evaluation import evaluate

    ev = evaluate(ref_map, matches, EvaluationSettings(seq_lengths=(1, 4), noise_models=(0, 1), interpolation=(True,)))
    paths = save_evaluation_figures(ev, ref_map, tmp_path, prefix="w_", figure_format="svg")
    frame = pick_heatmap_frame(ev, seq_len=4)
    assert [p.name for p in paths] == ["w_error_vs_seq_len.svg", "w_error_vs_noise.svg", f"w_heatmap_frame{frame}.svg"]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in paths)
    assert "Frame chosen where the sequence helps most" in paths[-1].read_text()  # SVG text stays text
    assert [p.name for p in save_evaluation_figures(ev, ref_map, tmp_path, heatmap_frames=[2, 5])][-2:] == [
        "heatmap_frame2.png",
        "heatmap_frame5.png",
    ]
    from figure_support import png_size

    width, height = png_size((tmp_path / "heatmap_frame2.png").read_bytes())
    assert width == 11 * DPI and height > 3 * DPI


def test_confidence_figure_counts_the_confidently_wrong_frames_and_bins_the_calibration(tmp_path):
    from nightloc.figures.filter import confidence_figure

    errors = np.array([0.1, 0.2, 1.5, 2.0, 0.3, 1.2, 0.05])
    confidence = np.array([0.95, 0.99, 0.95, 0.2, 0.55, 0.91, 0.05])  # frames 2 and 5: confidently wrong
    path = tmp_path / "trust.png"
    fig = confidence_figure({"a": (errors[:4], confidence[:4]), "b": (errors[4:], confidence[4:])}, "t", path)
    assert path.stat().st_size > 0
    scatter, calibration = fig.axes
    assert "28.57% of 7 frames" in scatter.get_title()  # 2 of 7
    labels = [t.get_text() for t in scatter.get_legend().get_texts()]
    assert labels == ["a (1 of 4)", "b (1 of 3)"]
    x, y = calibration.lines[1].get_data()  # per tenth of confidence: the share within 1 m
    np.testing.assert_allclose(x, [0.05, 0.25, 0.55, 0.95])
    np.testing.assert_allclose(y, [1.0, 0.0, 1.0, 2 / 4])
