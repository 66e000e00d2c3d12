"""Figures of the synthetic worlds: the panoramas shown are the ones rendered, on azimuth and
elevation axes; the maps put every traverse frame at its position, in metres."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from matplotlib.colors import to_rgba

from nightloc.figures.synth import FIGURE_POSES, TRAVERSE_COLOURS, day_night_figure, main, map_figure
from nightloc.preparation.preparer import prepare
from nightloc.synth.dataset import SynthScene
from nightloc.synth.paths import plan_traverses


def test_day_night_panels_show_the_rendered_and_prepared_frames():
    fig = day_night_figure("garden")
    panels = fig.axes
    assert len(panels) == 4
    scene = SynthScene("garden")
    x, y, heading = FIGURE_POSES["garden"]
    day = scene.frame("day", x, y, heading, scene.frame_rng("figure_day", 0))
    night = scene.frame("night", x, y, heading, scene.frame_rng("figure_night", 0))
    expected = [cv2.cvtColor(day, cv2.COLOR_BGR2RGB), cv2.cvtColor(night, cv2.COLOR_BGR2RGB), *prepare([day, night])]
    for ax, image in zip(panels, expected):
        [shown] = ax.get_images()
        np.testing.assert_array_equal(shown.get_array(), image)
        # columns run clockwise from the heading over 360 degrees; rows from +50 to -30 degrees
        assert tuple(shown.get_extent()) == (0.0, 360.0, -30.0, 50.0) and shown.origin == "upper"
    assert "night, darkness 1" in panels[1].get_title() and "prepared 48x24" in panels[2].get_title()
    assert fig.get_suptitle() == "garden: x = 3.5 m, y = 2.5 m, heading -74 deg"


def test_map_puts_each_traverse_frame_at_its_position():
    fig = map_figure("living_room")
    ax = fig.axes[0]
    plans = plan_traverses("living_room", 0)
    dots = [c for c in ax.collections if c.get_label() and not c.get_label().startswith("_")]
    arrows = [c for c in ax.collections if c not in dots]
    assert len(dots) == len(plans) == len(arrows)
    for plan, dot, arrow in zip(plans, dots, arrows):
        np.testing.assert_allclose(dot.get_offsets(), plan.positions)
        assert dot.get_label() == f"{plan.name.replace('_', ' ')} ({len(plan.positions)} frames)"
        np.testing.assert_allclose(arrow.U, np.cos(plan.headings))
        np.testing.assert_allclose(arrow.V, np.sin(plan.headings))
        np.testing.assert_allclose(dot.get_facecolor()[0], to_rgba(TRAVERSE_COLOURS[plan.name]))
    scene = SynthScene("living_room")
    x0, y0, x1, y1 = scene.world.mapped_area
    [area] = [p for p in ax.patches if p.get_label() == "mapped area"]
    assert (area.get_x(), area.get_y(), area.get_width(), area.get_height()) == pytest.approx(
        (x0, y0, x1 - x0, y1 - y0)
    )
    ground = scene.lighting["day"].ground
    [image] = ax.get_images()
    rows, cols = ground.values.shape[:2]
    assert image.get_extent() == pytest.approx(
        [ground.x0, ground.x0 + cols / ground.pixels_per_metre, ground.y0, ground.y0 + rows / ground.pixels_per_metre]
    )
    assert ax.get_aspect() == 1.0


def test_main_writes_both_worlds_in_the_format_asked(tmp_path, capsys):
    assert main([str(tmp_path), "--figure-format", "pdf"]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == sorted(f"synth_{w}_{k}.pdf" for w in ("garden", "living_room") for k in ("day_night", "map"))
    for name in names:
        assert (tmp_path / name).read_bytes().startswith(b"%PDF")
    assert capsys.readouterr().out.count("\n") == 4
    assert main([]) == 2 and "OUT_DIR" in capsys.readouterr().err
    assert main([str(tmp_path), "--figure-format", "gif"]) == 2
    fresh = tmp_path / "fresh"  # OUT_DIR is created when missing, not its parents
    assert main([str(fresh), "--figure-format", "svg"]) == 0
    assert len(list(fresh.glob("synth_*.svg"))) == 4
    assert main([str(tmp_path / "no" / "such"), "--figure-format", "svg"]) == 2
    assert "parent folder" in capsys.readouterr().err
    assert not (tmp_path / "no").exists()
