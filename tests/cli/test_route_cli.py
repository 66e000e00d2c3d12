"""``nightloc route``: outputs, ground-truth choice, atomic writes and clear errors; and the
real Nordland traverses (summer reference, winter query)."""

from __future__ import annotations

import csv
import json
import os

import cv2
import pytest

import nightloc
from nightloc import route
from nightloc.cli import main

import route_oracle as ro


def write_folder(folder, images, names=None, poses=None):
    (folder / "images").mkdir(parents=True)
    names = names or [f"frame{i:04d}.png" for i in range(len(images))]
    for name, image in zip(names, images):
        assert cv2.imwrite(str(folder / "images" / name), cv2.cvtColor(image, cv2.COLOR_GRAY2BGR))
    if poses is not None:
        lines = ["image,x,y"] + [f"{n},{x},{y}" for n, (x, y) in zip(names, poses)]
        (folder / "poses.csv").write_text("\n".join(lines) + "\n")
    return folder


@pytest.fixture
def synthetic_traverses(tmp_path):
    refs, queries, _truth = ro.synthetic_route(120, 100, speed=1.0, seed=11)
    return write_folder(tmp_path / "day", refs), write_folder(tmp_path / "night", queries), refs, queries


def read_csv(path):
    with open(path, newline="") as stream:
        return list(csv.reader(stream))


def test_route_command_writes_matches_pr_and_figures(synthetic_traverses, tmp_path, capsys):
    day, night, refs, queries = synthetic_traverses
    out = tmp_path / "out"
    # frame0000.png ... in both: positional names, taken as ground truth only when asked for
    args = ["route", str(day), str(night), "--out", str(out), "--preset", "openseqslam", "--ground-truth", "names"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "recall at 100% precision" in printed and "ground truth from names" in printed
    rows = read_csv(out / "matches.csv")
    assert rows[0] == ["query", "ref", "score", "query_image", "ref_image", "timestamp"] and len(rows) == 101
    expected = route.match_prepared(nightloc.block_normalize(refs), nightloc.block_normalize(queries), "openseqslam")
    for q, (query, ref, score, query_image, ref_image, _) in enumerate(rows[1:]):
        assert int(query) == q and query_image == f"frame{q:04d}.png"
        if expected.refs[q] < 0:
            assert ref == "-1" and score == "nan" and ref_image == ""
        else:
            assert int(ref) == expected.refs[q] and float(score) == expected.scores[q]
            assert ref_image == f"frame{expected.refs[q]:04d}.png"
    pr = read_csv(out / "pr.csv")
    assert pr[0] == ["threshold", "precision", "recall"] and len(pr) > 10
    thresholds = [float(row[0]) for row in pr[1:]]
    assert thresholds == sorted(thresholds)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["ground_truth"] == "names" and summary["recall_at_100_precision"] > 0.8
    assert summary["method_params"]["divisor"] == "references"
    assert summary["figures"] == ["difference_matrix.png", "pr_curve.png", "correspondence.png"]
    for name in summary["figures"]:
        assert cv2.imread(str(out / name)).shape[2] == 3
    assert not [p for p in os.listdir(out) if p.endswith(".tmp")]


def test_route_command_options(synthetic_traverses, tmp_path):
    day, night, _, _ = synthetic_traverses
    out = tmp_path / "causal"
    assert main(["route", str(day), str(night), "--out", str(out), "--ground-truth", "frames"]) == 0
    assert (out / "pr.csv").is_file()  # an earlier run's output, which the next run must not leave behind
    args = [
        "route",
        str(day),
        str(night),
        "--out",
        str(out),
        "--method",
        "seqslam",
        "--mode",
        "causal",
        "--ds",
        "6",
        "--vmin",
        "0.9",
        "--vmax",
        "1.1",
        "--ground-truth",
        "none",
        "--no-figures",
        "--threads",
        "1",
    ]
    assert main(args) == 0
    rows = read_csv(out / "matches.csv")
    assert [r[1] for r in rows[1:6]] == ["-1"] * 5 and rows[6][1] != "-1"  # causal: ds-1 undefined
    assert not (out / "pr.csv").exists() and not (out / "difference_matrix.png").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["method_params"]["mode"] == "causal" and summary["method_params"]["ds"] == 6


def test_route_command_positions_ground_truth(tmp_path):
    refs, queries, truth = ro.synthetic_route(80, 70, speed=1.0, seed=12)
    ref_xy = [(float(i) * 2.0, 0.0) for i in range(80)]
    query_xy = [(float(t) * 2.0 + 0.3, 0.5) for t in truth]
    day = write_folder(tmp_path / "day", refs, poses=ref_xy)
    night = write_folder(tmp_path / "night", queries, names=[f"n{i}.png" for i in range(70)], poses=query_xy)
    out = tmp_path / "out"
    assert main(["route", str(day), str(night), "--out", str(out), "--tolerance", "5", "--no-figures"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["ground_truth"] == "positions" and summary["tolerance"] == 5.0
    assert summary["recall_at_100_precision"] > 0.8


def test_route_command_errors_leave_nothing_half_written(synthetic_traverses, tmp_path, capsys):
    day, night, _, _ = synthetic_traverses
    out = tmp_path / "out"
    assert main(["route", str(day), str(tmp_path / "missing"), "--out", str(out)]) == 2
    assert "error" in capsys.readouterr().err
    assert not out.exists()
    assert main(["route", str(day), str(night), "--out", str(out), "--ds", "1"]) == 2
    assert "ds must" in capsys.readouterr().err
    a_file = tmp_path / "file.txt"
    a_file.write_text("x")
    assert main(["route", str(day), str(night), "--out", str(a_file)]) == 2
    assert main(["route", str(day), str(night), "--out", str(out), "--ground-truth", "positions"]) == 2
    assert "poses" in capsys.readouterr().err
    # A truncated image is named in the error.
    broken = sorted((night / "images").iterdir())[3]
    broken.write_bytes(broken.read_bytes()[:40])
    assert main(["route", str(day), str(night), "--out", str(out)]) == 2
    assert broken.name in capsys.readouterr().err
    assert not out.exists() or not list(out.iterdir())


def test_params_file(synthetic_traverses, tmp_path):
    day, night, _, _ = synthetic_traverses
    params = tmp_path / "p.toml"
    nightloc.save_params(
        params, [route.RouteParams(ds=8, mode="causal"), nightloc.PreparationParams(wrap=False, width=32, height=16)]
    )
    out = tmp_path / "out"
    assert main(["route", str(day), str(night), "--out", str(out), "--params", str(params), "--no-figures"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["preparation"]["width"] == 32
    # a filter run lists the filter's settings only: none of SeqSLAM's (ds, mode, uniqueness_radius)
    listed = json.dumps({key: value for key, value in summary.items() if key != "preparation"})
    assert '"ds"' not in listed and '"mode"' not in listed and "uniqueness_radius" not in listed
    assert summary["method_params"]["filter_sharpness"] == route.RouteParams().filter_sharpness
    assert (
        main(["route", str(day), str(night), "--out", str(out), "--params", str(params), "--preset", "openseqslam"])
        == 2
    )


@pytest.mark.slow
def test_nordland_full_route(shared_data, tmp_path, capsys):
    root = shared_data / "nordland"
    if not (root / "summer").is_dir():
        pytest.skip(f"{root} not found")
    out = tmp_path / "nordland"
    assert (
        main(["route", str(root / "summer"), str(root / "winter"), "--out", str(out), "--preset", "openseqslam"]) == 0
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_refs"] == summary["n_queries"] == 3576 and summary["ground_truth"] == "names"
    assert round(summary["recall_at_100_precision"], 3) == 0.355  # measured; docs/route_mode.md
    rows = read_csv(out / "matches.csv")
    assert len(rows) == 3577


def test_route_command_on_videos(tmp_path):
    refs, queries, _ = ro.synthetic_route(90, 80, speed=1.0, seed=13)

    def video(path, frames, repeat):
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (frames.shape[2], frames.shape[1]))
        if not writer.isOpened():
            pytest.skip("this OpenCV build cannot write MJPG videos")
        for frame in frames:
            for _ in range(repeat):  # every frame `repeat` times: --frame-step recovers the route
                writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
        writer.release()
        return path

    day = video(tmp_path / "day.avi", refs, 2)
    night = video(tmp_path / "night.avi", queries, 2)
    out = tmp_path / "out"
    assert (
        main(
            [
                "route",
                str(day),
                str(night),
                "--out",
                str(out),
                "--frame-step",
                "2",
                "--no-figures",
                "--ground-truth",
                "frames",
            ]
        )
        == 0
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_refs"] == 90 and summary["n_queries"] == 80
    assert summary["recall_at_100_precision"] > 0.7


def test_route_command_compares_methods(synthetic_traverses, tmp_path, capsys):
    """``--method seqslam,filter``: both sets from one difference matrix, a comparison summary and
    table; the filter's set equals the default run's; a later single-method run into the same
    folder removes the comparison's sets."""
    day, night, _, _ = synthetic_traverses
    out = tmp_path / "both"
    both = ["--method", "seqslam,filter", "--ground-truth", "names"]  # the names number the frames alike
    assert main(["route", str(day), str(night), "--out", str(out), *both]) == 0
    printed = capsys.readouterr().out
    assert "method" in printed and "R@100P" in printed
    comparison = json.loads((out / "summary.json").read_text())
    assert comparison["methods"] == ["seqslam", "filter"]
    for method in ("seqslam", "filter"):
        summary = json.loads((out / method / "summary.json").read_text())
        assert summary["method"] == method and summary["method_params"]["method"] == method
        assert comparison["results"][method]["best_f1"] == summary["best_f1"]
        assert 0 <= summary["correct_any_score"] <= 1
    filtered = read_csv(out / "filter" / "matches.csv")
    assert filtered[0] == ["query", "ref", "score", "query_image", "ref_image", "confidence", "off_route", "timestamp"]
    assert read_csv(out / "seqslam" / "matches.csv")[0] == [
        "query",
        "ref",
        "score",
        "query_image",
        "ref_image",
        "timestamp",
    ]
    # The filter from the comparison run equals a plain default run.
    single = tmp_path / "single"
    assert main(["route", str(day), str(night), "--out", str(single), "--no-figures"]) == 0
    assert read_csv(single / "matches.csv") == filtered
    summary = json.loads((single / "summary.json").read_text())
    assert summary["method"] == "filter" and "filter_sharpness" in summary["method_params"]
    assert "ds" not in summary["method_params"] and summary["preparation"]["equalize"] == "none"
    if "pr_comparison.png" in comparison["figures"]:
        assert cv2.imread(str(out / "pr_comparison.png")).shape[2] == 3
        assert "filter_confidence.png" in json.loads((out / "filter" / "summary.json").read_text())["figures"]
    assert main(["route", str(day), str(night), "--out", str(out), "--no-figures"]) == 0
    assert not any((out / method / "matches.csv").exists() for method in ("seqslam", "filter"))
    assert json.loads((out / "summary.json").read_text())["method"] == "filter"
    assert main(["route", str(day), str(night), "--out", str(tmp_path / "bad"), "--method", "filter,magic"]) == 2
    assert "unknown method 'magic'" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()


def test_route_command_gardens_point_comparison(shared_data, tmp_path, capsys):
    root = shared_data / "gardens_point"
    if not (root / "day_right").is_dir():
        pytest.skip(f"{root} not found")
    out = tmp_path / "gp"
    args = ["route", str(root / "day_right"), str(root / "night_right"), "--out", str(out)]
    # ImageNNN.jpg in both folders: frame-aligned, but positional names give no ground truth unless asked.
    assert main([*args, "--method", "seqslam,filter", "--no-figures", "--ground-truth", "names"]) == 0
    results = json.loads((out / "summary.json").read_text())["results"]
    assert results["filter"]["best_f1"] >= 0.85 and results["filter"]["recall_at_100_precision"] >= 0.30
    # SeqSLAM on the same (windowed) difference matrix: far behind the filter.
    assert results["seqslam"]["best_f1"] < results["filter"]["best_f1"] - 0.25
