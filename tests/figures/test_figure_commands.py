"""``--figure-format`` on the commands that write figures: the files come in the format asked,
an earlier run's figures in another format are removed, a bad format is a one-line error."""

from __future__ import annotations

import json

import pytest

from nightloc.cli import main

import route_oracle as ro
from figure_support import pdf_size, png_size, svg_size
from synth_support import default_synth_data


def _evaluate(folders, out, *extra):
    return main(
        [
            "evaluate",
            str(folders["day_reference"]),
            str(folders["night_query"]),
            "--out",
            str(out),
            "--seq-lengths",
            "1,7",
            "--noise-models",
            "0,2",
            "--heatmap-frames",
            "9",
            *extra,
        ]
    )


def test_evaluate_writes_svg_then_png_and_drops_the_other_format(tmp_path, capsys):
    folders = default_synth_data()["garden"]
    out = tmp_path / "out"
    assert _evaluate(folders, out, "--figure-format", "svg") == 0
    figures = ["error_vs_seq_len", "error_vs_noise", "error_vs_interpolation", "heatmap_frame9"]
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [".nightloc-output.json", "errors.csv", "summary.csv", *(f"{f}.svg" for f in figures)]
    )
    for name in figures:
        width, height = svg_size((out / f"{name}.svg").read_bytes())
        assert width > 300 and height > 200
    assert "Frame requested" in (out / "heatmap_frame9.svg").read_text()
    assert ".svg" in capsys.readouterr().out
    assert _evaluate(folders, out) == 0  # png by default
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [".nightloc-output.json", "errors.csv", "summary.csv", *(f"{f}.png" for f in figures)]
    )
    assert png_size((out / "heatmap_frame9.png").read_bytes())[0] == 1100


def test_route_writes_pdf_figures_and_lists_them(tmp_path):
    import cv2

    refs, queries, _ = ro.synthetic_route(70, 60, speed=1.0, seed=5)
    for name, images in (("day", refs), ("night", queries)):
        (tmp_path / name / "images").mkdir(parents=True)
        for i, image in enumerate(images):
            assert cv2.imwrite(str(tmp_path / name / "images" / f"f{i:04d}.png"), image)
    out = tmp_path / "out"
    argv = ["route", str(tmp_path / "day"), str(tmp_path / "night"), "--out", str(out), "--ds", "6"]
    argv += ["--ground-truth", "names"]  # f0000.png ... in both: positional names, used when asked for
    assert main([*argv, "--figure-format", "pdf"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    # The default method is the route filter: its confidence figure comes last.
    assert summary["figures"] == [
        "difference_matrix.pdf",
        "pr_curve.pdf",
        "correspondence.pdf",
        "filter_confidence.pdf",
    ]
    for name in summary["figures"]:
        width, height = pdf_size((out / name).read_bytes())
        assert width > 300 and height > 250
    assert main(argv) == 0
    assert not list(out.glob("*.pdf")) and len(list(out.glob("*.png"))) == 4


@pytest.mark.parametrize("command", ["evaluate", "route", "demo"])
def test_an_unknown_format_is_refused_before_any_work(tmp_path, capsys, command):
    args = {"evaluate": ["a", "b"], "route": ["a", "b"], "demo": []}[command]
    with pytest.raises(SystemExit) as stopped:
        main([command, *args, "--out", str(tmp_path / "o"), "--figure-format", "gif"])
    assert stopped.value.code == 2
    assert "--figure-format" in capsys.readouterr().err and not (tmp_path / "o").exists()
