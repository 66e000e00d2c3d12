"""Figure files: valid PNG / PDF / SVG of the figure's size, written atomically and reproducibly;
and nothing on the robot's path imports matplotlib."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from matplotlib.figure import Figure

from nightloc.figures import FORMATS
from nightloc.figures._common import DPI, figure_path, new_figure, save_figure

from figure_support import pdf_size, png_size, svg_size


def _figure(width=4.0, height=3.0) -> Figure:
    fig, ax = new_figure(width, height)
    ax.plot([0, 1, 2], [0, 1, 4], label="line")
    ax.imshow(np.arange(12.0).reshape(3, 4), extent=(0, 2, 0, 4))
    ax.set_title("title")
    return fig


@pytest.mark.parametrize("fmt", FORMATS)
def test_each_format_is_a_valid_file_of_the_figure_size(tmp_path, fmt):
    fig = _figure(4.0, 3.0)
    path = save_figure(fig, tmp_path / f"f.{fmt}")
    data = path.read_bytes()
    if fmt == "png":
        assert png_size(data) == (4 * DPI, 3 * DPI)
    elif fmt == "pdf":
        assert pdf_size(data) == pytest.approx((4 * 72, 3 * 72))
    else:
        assert svg_size(data) == pytest.approx((4 * 72, 3 * 72))
    assert sorted(os.listdir(tmp_path)) == [f"f.{fmt}"]  # no temporary left behind


def test_format_from_argument_or_suffix_and_clear_errors(tmp_path):
    fig = _figure()
    assert save_figure(fig, tmp_path / "a.SVG").read_bytes().lstrip().startswith(b"<?xml")
    assert save_figure(fig, tmp_path / "b.pdf", "PDF").read_bytes().startswith(b"%PDF")
    assert figure_path(tmp_path, "c", "svg") == tmp_path / "c.svg"
    with pytest.raises(ValueError, match=r"\.png, \.pdf or \.svg"):
        save_figure(fig, tmp_path / "d.jpg")
    with pytest.raises(ValueError, match=r"does not end in \.png"):
        save_figure(fig, tmp_path / "e.pdf", "png")
    with pytest.raises(ValueError, match="png, pdf, svg"):
        figure_path(tmp_path, "f", "gif")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.SVG", "b.pdf"]


def test_a_failed_save_leaves_the_previous_file_and_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "fig.png"
    save_figure(_figure(), target)
    before = target.read_bytes()

    def broken(self, stream, **kwargs):
        stream.write(b"half a figure")
        raise RuntimeError("renderer crashed")

    monkeypatch.setattr(Figure, "savefig", broken)
    with pytest.raises(RuntimeError, match="renderer crashed"):
        save_figure(_figure(5.0, 2.0), target)
    assert target.read_bytes() == before
    assert os.listdir(tmp_path) == ["fig.png"]


def test_the_file_appears_by_rename_from_a_hidden_temporary_in_the_same_folder(tmp_path, monkeypatch):
    renames = []
    real_replace = os.replace

    def spy(src, dst):
        renames.append((os.fspath(src), os.fspath(dst)))
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", spy)
    save_figure(_figure(), tmp_path / "x.svg")
    [(src, dst)] = renames
    assert os.path.dirname(src) == str(tmp_path) and os.path.basename(src).startswith(".x.svg.")
    assert dst == str(tmp_path / "x.svg")


@pytest.mark.parametrize("fmt", FORMATS)
def test_the_same_figure_gives_the_same_bytes(tmp_path, fmt):
    first = save_figure(_figure(), tmp_path / f"1.{fmt}").read_bytes()
    second = save_figure(_figure(), tmp_path / f"2.{fmt}").read_bytes()
    assert first == second


def test_figures_need_no_pyplot_and_leave_global_style_alone():
    import matplotlib as mpl

    size = mpl.rcParams["font.size"]
    fig = _figure()
    assert fig.get_layout_engine() is not None  # constrained layout
    assert mpl.rcParams["font.size"] == size
    fig.canvas.draw()  # the Agg canvas renders without a display


ROBOT_PATH = textwrap.dedent(
    """
    import sys
    import numpy as np
    import nightloc
    from nightloc import route

    rng = np.random.default_rng(0)
    camera = rng.integers(0, 256, size=(16, 96, 192, 3), dtype=np.uint8)
    refs = nightloc.prepare(camera[:12])
    ref_map = nightloc.ReferenceMap(refs, [[float(i), 0.0] for i in range(12)])
    localizer = nightloc.Localizer(ref_map, method="paper", seq_len=3)
    for frame in camera[12:]:
        localizer.update(frame, (1.0, 0.0))
    ref_map = nightloc.ReferenceMap(refs, [[float(i), 0.0] for i in range(12)], np.zeros(12))
    localizer = nightloc.Localizer(ref_map)  # the Bayes filter
    for frame in camera[12:]:
        localizer.update(frame, nightloc.RobotMotion(1.0, 0.0, 0.1))
    nightloc.match(refs[0], refs)
    route_localizer = nightloc.RouteLocalizer(camera[:12], nightloc.RouteParams(ds=2, mode="causal"))
    for frame in camera[12:]:
        route_localizer.update(frame)
    import nightloc.cli, nightloc.figures  # the command line and the figures package itself
    print(sorted(name for name in sys.modules if name.split(".")[0] == "matplotlib"))
    """
)


def test_the_robot_path_and_the_cli_do_not_import_matplotlib():
    done = subprocess.run([sys.executable, "-c", ROBOT_PATH], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
