"""Evaluation: end to end on the synthetic world, the CLI's outputs and columns, and its errors."""

from __future__ import annotations

import csv
import functools
import itertools
from pathlib import Path

import cv2
import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.localization.evaluation import (
    ERRORS_HEADER,
    SUMMARY_HEADER,
    EvaluationSettings,
    evaluate,
    match_traverse,
    replay,
)

from synth_support import default_synth_data


@functools.cache
def _world(world: str):
    folders = default_synth_data()[world]
    ref_map = nightloc.ReferenceMap.build(folders["day_reference"])
    return folders, ref_map, match_traverse(ref_map, folders["night_query"])


@functools.cache
def _evaluation(world: str):
    _, ref_map, matches = _world(world)
    settings = EvaluationSettings(seq_lengths=(1, 7, 10), noise_models=(0, 1, 2, 3), repeats=3)
    return evaluate(ref_map, matches, settings)


@pytest.mark.parametrize("world", ["garden", "living_room"])
def test_sequences_halve_the_error_and_interpolation_lowers_it_further(world):
    ev = _evaluation(world)
    single = ev.median(seq_len=1, noise_model=0, interpolation=True)
    ten = ev.median(seq_len=10, noise_model=0, interpolation=True)
    ten_off = ev.median(seq_len=10, noise_model=0, interpolation=False)
    assert ten <= 0.5 * single, (world, single, ten)
    assert ten < ten_off, (world, ten, ten_off)
    assert ev.median(seq_len=7, noise_model=0, interpolation=True) < ev.median(
        seq_len=7, noise_model=0, interpolation=False
    )


@pytest.mark.parametrize("world", ["garden", "living_room"])
def test_odometry_noise_degrades_gracefully(world):
    ev = _evaluation(world)
    single = ev.median(seq_len=1, noise_model=0, interpolation=True)
    medians = [ev.median(seq_len=10, noise_model=m, interpolation=True) for m in (0, 1, 2, 3)]
    assert all(b >= a - 0.05 for a, b in itertools.pairwise(medians)), medians  # worse with more noise...
    assert medians[3] < single, (medians, single)  # ...but still better than single frames
    assert medians[3] < 1.25


def test_rows_cover_every_configuration_and_errors_are_distances():
    ev = _evaluation("garden")
    _, ref_map, matches = _world("garden")
    n = len(matches.results)
    # noise model 0 runs once, models 1-3 three times each; 3 lengths, 2 interpolation settings
    assert len(ev) == n * 3 * 2 * (1 + 3 * 3)
    c = ev.columns
    np.testing.assert_allclose(c["error_m"], np.hypot(c["x_est"] - c["x_true"], c["y_est"] - c["y_true"]))
    assert set(np.unique(c["repeat"][c["noise_model"] == 0])) == {0}
    assert set(np.unique(c["repeat"][c["noise_model"] == 3])) == {0, 1, 2}
    off = ev.select(interpolation=False)
    np.testing.assert_array_equal(
        np.column_stack([c["x_est"][off], c["y_est"][off]]), ref_map.positions[c["ref_index"][off].astype(int)]
    )
    # single frames without interpolation: the best-matching reference, whatever the noise
    single_off = ev.select(seq_len=1, interpolation=False, noise_model=0)
    assert list(c["ref_index"][single_off]) == [r.index for r in matches.results]


def test_replay_reproduces_a_row_with_its_heat_maps():
    ev = _evaluation("garden")
    _, ref_map, matches = _world("garden")
    frame = 20
    est = replay(ref_map, matches, frame, seq_len=7, noise=3, repeat=2, settings=ev.settings)
    row = ev.select(seq_len=7, noise_model=3, interpolation=True) & (ev.columns["repeat"] == 2)
    x = ev.columns["x_est"][row][frame]
    y = ev.columns["y_est"][row][frame]
    assert (est.x, est.y) == (x, y)
    assert est.heatmap.shape == (100, 100) and est.frames == 7


def test_robot_frame_odometry_mode_runs_and_helps():
    _, ref_map, matches = _world("garden")
    settings = EvaluationSettings(seq_lengths=(1, 10), noise_models=(0, 2), interpolation=(True,), odometry="robot")
    ev = evaluate(ref_map, matches, settings)
    assert ev.median(seq_len=10, noise_model=0) < ev.median(seq_len=1, noise_model=0)


def _read_csv(path: Path):
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    return rows[0], rows[1:]


def test_cli_writes_errors_summary_and_figures(tmp_path, capsys):
    folders, ref_map, matches = _world("garden")
    out = tmp_path / "out"
    argv = [
        "evaluate",
        str(folders["day_reference"]),
        str(folders["night_query"]),
        "--out",
        str(out),
        "--seq-lengths",
        "1,3-4",
        "--noise-models",
        "0,2",
        "--repeats",
        "2",
        "--heatmap-frames",
        "5,12",
    ]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "noise 0 | noise 2" in printed
    header, rows = _read_csv(out / "errors.csv")
    assert tuple(header) == ERRORS_HEADER
    n = len(matches.results)
    assert len(rows) == n * 3 * 2 * (1 + 2)
    assert {r[4] for r in rows} == {"on", "off"} and {r[2] for r in rows} == {"1", "3", "4"}
    assert [r[1] for r in rows[:n]] == list(matches.images)
    assert {r[0] for r in rows} == {"night_query"}
    # the summary is the statistics of the rows (an independent recomputation)
    s_header, s_rows = _read_csv(out / "summary.csv")
    assert tuple(s_header) == SUMMARY_HEADER and len(s_rows) == 3 * 2 * 2
    for seq_len, model, interp, count, median, mean, p90, p95, share, longest, method in s_rows:
        assert method == "paper"
        errors = np.array([float(r[10]) for r in rows if (r[2], r[3], r[4]) == (seq_len, model, interp)])
        assert int(count) == errors.size
        assert float(median) == pytest.approx(np.median(errors), abs=2e-4)
        assert float(mean) == pytest.approx(errors.mean(), abs=2e-4)
        assert float(p90) == pytest.approx(np.percentile(errors, 90), abs=2e-4)
        # the tail: frames from the 10th of each draw (rows of a draw are in frame order)
        runs = [
            [float(r[10]) for r in rows if (r[2], r[3], r[4], r[5]) == (seq_len, model, interp, repeat)][9:]
            for repeat in sorted({r[5] for r in rows if (r[2], r[3], r[4]) == (seq_len, model, interp)})
        ]
        later = np.concatenate(runs)
        assert float(p95) == pytest.approx(np.percentile(later, 95), abs=2e-4)
        assert float(share) == pytest.approx(np.mean(later > 1.0), abs=1e-4)
        worst = 0
        for run in runs:
            streak = 0
            for error in run:
                streak = streak + 1 if error > 1.0 else 0
                worst = max(worst, streak)
        assert int(longest) == worst
    # the same numbers as the API
    api = evaluate(ref_map, matches, EvaluationSettings((1, 3, 4), (0, 2), repeats=2))
    np.testing.assert_allclose([float(r[10]) for r in rows], api.columns["error_m"], atol=1e-4)
    for name in (
        "error_vs_seq_len.png",
        "error_vs_noise.png",
        "error_vs_interpolation.png",
        "heatmap_frame5.png",
        "heatmap_frame12.png",
    ):
        image = cv2.imread(str(out / name))
        assert image is not None and image.shape[2] == 3, name
    # a second run without figures leaves no stale figure behind
    assert main([*argv[:5], "--seq-lengths", "1", "--no-figures"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".nightloc-output.json", "errors.csv", "summary.csv"]


def test_cli_accepts_a_map_file_and_parameter_file(tmp_path, capsys):
    folders, ref_map, _ = _world("living_room")
    map_file = ref_map.save(tmp_path / "room.map")
    params = tmp_path / "p.toml"
    params.write_text("[localization]\ngrid_width = 60\ngrid_height = 30\n")
    out = tmp_path / "out"
    assert (
        main(
            [
                "evaluate",
                str(map_file),
                str(folders["night_query"]),
                "--out",
                str(out),
                "--seq-lengths",
                "1,5",
                "--noise-models",
                "0",
                "--interpolation",
                "on",
                "--params",
                str(params),
                "--no-figures",
            ]
        )
        == 0
    )
    _, rows = _read_csv(out / "summary.csv")
    assert [(r[0], r[2]) for r in rows] == [("1", "on"), ("5", "on")]


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--seq-lengths", "0-3"], "--seq-lengths"),
        (["--seq-lengths", "a"], "not an integer"),
        (["--noise-models", "5"], "table iii"),
        (["--interpolation", "maybe"], "on or off"),
        (["--repeats", "0"], "--repeats"),
        (["--seed", "-2"], "non-negative"),
        (["--heatmap-frames", "999"], "--heatmap-frames"),
    ],
)
def test_cli_bad_options_are_one_line_errors_and_write_nothing(tmp_path, capsys, extra, words):
    folders, _, _ = _world("garden")
    out = tmp_path / "out"
    status = main(["evaluate", str(folders["day_reference"]), str(folders["night_query"]), "--out", str(out), *extra])
    err = capsys.readouterr().err
    assert status == 2 and err.startswith("nightloc evaluate: error:") and err.count("\n") == 1
    assert words.lower() in err.lower()
    assert not out.exists()


def test_cli_query_without_poses_and_output_file_in_the_way(tmp_path, capsys):
    folders, _, _ = _world("garden")
    no_poses = tmp_path / "no_poses"
    (no_poses / "images").mkdir(parents=True)
    for name in ("a.png", "b.png"):
        cv2.imwrite(str(no_poses / "images" / name), np.full((24, 48), 100, np.uint8))
    assert main(["evaluate", str(folders["day_reference"]), str(no_poses), "--out", str(tmp_path / "o")]) == 2
    assert "no poses" in capsys.readouterr().err
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["evaluate", str(folders["day_reference"]), str(folders["night_query"]), "--out", str(blocker)]) == 2
    assert "not a folder" in capsys.readouterr().err
    assert blocker.read_text() == "x"


def test_heatmap_figure_marks_truth_and_estimate_where_they_are():
    from nightloc.figures.evaluation import heatmap_figure, pick_heatmap_frame

    ev = _evaluation("garden")
    _, ref_map, matches = _world("garden")
    frame = pick_heatmap_frame(ev, seq_len=7)
    assert frame >= 6  # a whole 7-frame sequence behind it
    single = ev.errors(seq_len=1, noise_model=0, interpolation=True)
    seven = ev.errors(seq_len=7, noise_model=0, interpolation=True)
    assert single[frame] - seven[frame] == pytest.approx(np.max((single - seven)[6:]))
    fig = heatmap_figure(ref_map, matches, frame, 7)
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    assert len(panels) == 2
    for ax in panels:
        # the red truth cross is drawn at the truth, over the heat map
        [truth] = [line for line in ax.lines if line.get_label() == "truth"]
        assert (truth.get_xdata()[0], truth.get_ydata()[0]) == tuple(matches.positions[frame])
        assert truth.get_color() == "red" and truth.get_zorder() > ax.get_images()[0].get_zorder()


# ----------------------------------------------------------------------------------------------
# the Bayes filter and the query's own odometry log


@functools.cache
def _filter_world(world: str):
    folders = default_synth_data()[world]
    ref_map = nightloc.ReferenceMap.build(folders["day_reference"])
    return folders, ref_map, match_traverse(ref_map, folders["night_query"], tables=True, odometry=True)


def test_filter_rows_hold_every_frame_once_per_draw_and_match_the_localizer():
    _, ref_map, matches = _filter_world("garden")
    settings = EvaluationSettings(
        seq_lengths=(10,), noise_models=(0, 3), interpolation=(True,), repeats=2, methods=("paper", "filter")
    )
    ev = evaluate(ref_map, matches, settings)
    n = len(matches.results)
    filt = ev.select(method="filter")
    assert filt.sum() == n * (1 + 2)  # noise 0 once, noise 3 twice
    assert list(ev.columns["seq_len"][filt][:n]) == list(range(1, n + 1))  # frames seen so far
    assert ev.select(method="paper").sum() == n * (1 + 2)
    # the same estimates as a Localizer driven by hand with the same odometry
    from nightloc.localization.evaluation import simulated_odometry

    odometry = simulated_odometry(matches, 3, 1, settings)
    loc = nightloc.Localizer(ref_map, odometry_noise=3)
    x = [loc.update_table(matches.tables[i], odometry[i]).x for i in range(n)]
    rows = ev.select(method="filter", noise_model=3) & (ev.columns["repeat"] == 1)
    np.testing.assert_array_equal(ev.columns["x_est"][rows], x)
    # the filter beats the paper's 10-frame sum under heavy wheel-free map odometry noise
    later = np.tile(np.arange(n) >= 9, 2)
    paper = ev.columns["error_m"][ev.select(method="paper", noise_model=3)][later]
    mine = ev.columns["error_m"][ev.select(method="filter", noise_model=3)][later]
    assert np.median(mine) < np.median(paper)
    # the comparison table: median and tail of both methods, over the two draws from the 10th frame
    [row] = [line for line in ev.compare_table().splitlines() if line.strip().startswith("3 |")]
    paper_cell, filter_cell = (cell.split() for cell in row.split("|")[1:])
    for cell, errors in ((paper_cell, paper), (filter_cell, mine)):
        assert float(cell[0]) == pytest.approx(np.median(errors), abs=0.006)
        assert float(cell[1]) == pytest.approx(np.percentile(errors, 95), abs=0.006)
        assert float(cell[2]) == pytest.approx(100 * np.mean(errors > 1.0), abs=0.06)


def test_log_odometry_is_the_querys_own_and_equals_exact_wheel_odometry():
    _, ref_map, matches = _filter_world("living_room")
    assert matches.odometry is not None and matches.odometry[0] is None
    log = evaluate(ref_map, matches, EvaluationSettings(odometry="log", methods=("filter",), interpolation=(True,)))
    assert set(log.columns["noise_model"]) == {-1}
    exact = evaluate(
        ref_map,
        matches,
        EvaluationSettings(odometry="robot", noise_models=(0,), methods=("filter",), interpolation=(True,)),
        filter_params=None,
    )
    # the synthetic logs hold the exact wheel odometry; the filter assumes log_noise (model 1) there
    assert np.median(log.columns["error_m"][9:]) < 0.5
    assert exact.columns["error_m"].shape == log.columns["error_m"].shape


def test_cli_method_and_log_odometry(tmp_path, capsys):
    folders, _, _ = _filter_world("garden")
    out = tmp_path / "out"
    argv = ["evaluate", str(folders["day_reference"]), str(folders["night_query"]), "--out", str(out)]
    assert main([*argv, "--method", "paper,filter", "--odometry", "log", "--seq-lengths", "10", "--no-figures"]) == 0
    printed = capsys.readouterr().out
    assert "Bayes filter" in printed and "log" in printed
    header, rows = _read_csv(out / "errors.csv")
    assert header[-1] == "method" and {r[-1] for r in rows} == {"paper", "filter"}
    assert {r[3] for r in rows} == {"-1"}
    _, s_rows = _read_csv(out / "summary.csv")
    assert [r[0] for r in s_rows if r[-1] == "filter"] == ["0", "0"]  # on and off, over all frames
    assert main([*argv, "--method", "filter", "--odometry-noise", "0.2,0.05", "--no-figures"]) == 0
    _, rows = _read_csv(out / "errors.csv")
    assert {r[-1] for r in rows} == {"filter"}


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--method", "kalman"], "--method"),
        (["--odometry-noise", "7"], "noise model"),
        (["--odometry-noise", "a,b"], "--odometry-noise"),
        (["--odometry-noise", "0.1,-1"], "--odometry-noise"),
    ],
)
def test_cli_rejects_bad_method_and_noise(tmp_path, capsys, extra, message):
    folders, _, _ = _filter_world("garden")
    argv = ["evaluate", str(folders["day_reference"]), str(folders["night_query"]), "--out", str(tmp_path / "o")]
    assert main([*argv, *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_log_odometry_without_a_log_is_a_clear_error(tmp_path):
    folders, ref_map, _ = _filter_world("garden")
    query = nightloc.load_traverse(folders["night_query"])
    bare = nightloc.save_traverse(
        tmp_path / "bare", (query.read(i) for i in range(4)), query.positions[:4], query.headings[:4]
    )
    with pytest.raises(nightloc.DatasetError, match=r"odometry\.csv"):
        evaluate(ref_map, bare, EvaluationSettings(odometry="log", methods=("filter",)))


def test_the_filter_evaluates_a_forward_camera_map_with_its_column_window(tmp_path):
    """A forward camera's map with headings: the filter's tables are its column-window tables
    (match_traverse builds them as the filter will read them), and wheel odometry drives it."""
    from nightloc.synth import Camera, make_dataset

    folders = make_dataset("living_room", tmp_path / "fwd", camera=Camera(48, 24), view="forward", threads=1)
    ref_map = nightloc.ReferenceMap.build(folders["day_reference"], params=nightloc.PreparationParams(wrap=False))
    matches = match_traverse(ref_map, folders["night_query"], tables=True)
    window = ref_map.params.width // 4  # the default column window: a quarter of the prepared width
    assert matches.tables.shape == (32, len(ref_map), 2 * window + 1)
    settings = EvaluationSettings(methods=("filter",), noise_models=(0,), odometry="robot", interpolation=(True,))
    evaluation = evaluate(ref_map, matches, settings)
    errors = evaluation.errors(method="filter")
    assert errors.size == 32 and np.isfinite(errors).all() and np.median(errors) < 1.5
