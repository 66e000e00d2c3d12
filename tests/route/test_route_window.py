"""Route mode with the translation window (issue 19): the difference matrix against the oracle, the
same matrix in the batch pipeline, the Dask backend and the online localizer, the CLI and TOML
parameter, and the lateral-offset routes: a rendered street walked at night beside the day walk,
and the shared real pairs (skipped without data)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import nightloc
from nightloc import route
from nightloc.config import load_params, save_params
from nightloc.route import RouteParams

import oracle
import route_oracle as ro


def test_route_difference_matrix_is_the_window_oracle():
    refs, queries, _ = ro.synthetic_route(40, 30, speed=1.0, seed=3)
    params = RouteParams(shift_window=(5, 2))
    matrix = route.route_difference_matrix(queries, refs, params, threads=2)
    expected, _values, _rows = oracle.window_difference_matrix(queries, refs, [0], (5, 2), float(refs[0].size))
    np.testing.assert_array_equal(matrix, expected)
    # A panorama: the column part is unused (every circular shift is searched), the rows are.
    pano = RouteParams(shift_window=(5, 2), circular_shifts=True)
    assert pano.window == (0, 2)
    matrix = route.route_difference_matrix(queries, refs, pano, threads=2)
    expected, _values, _rows = oracle.window_difference_matrix(
        queries, refs, range(refs.shape[2]), (0, 2), float(refs[0].size)
    )
    np.testing.assert_array_equal(matrix, expected)


def test_window_reaches_the_localizer_and_the_presets():
    refs, queries, _ = ro.synthetic_route(80, 50, speed=1.0, seed=8)
    params = RouteParams(shift_window=(6, 1))
    batch = route.match_prepared(refs, queries, params)
    localizer = nightloc.RouteLocalizer(refs, params, prepared=True)
    stream = [localizer.update(q, prepared=True) for q in queries]
    np.testing.assert_array_equal([u.ref for u in stream], batch.refs)
    np.testing.assert_array_equal([u.confidence for u in stream], batch.confidence)
    causal = route.resolve_params(params, method="seqslam", mode="causal", ds=5)
    batch = route.match_prepared(refs, queries, causal)
    localizer = nightloc.RouteLocalizer(refs, causal, prepared=True)
    refs_stream = [localizer.update(q, prepared=True).ref for q in queries]
    np.testing.assert_array_equal([-1 if r is None else r for r in refs_stream], batch.refs)
    # OpenSeqSLAM compares one alignment: its preset keeps the window at 0 (bit-exact with it).
    assert route.route_preset("openseqslam").shift_window == (0, 0)
    assert "shift_window" in params.method_params()


def test_window_in_toml_and_errors(tmp_path):
    path = tmp_path / "route.toml"
    save_params(path, RouteParams(shift_window=(4, 1)))
    assert "shift_window = [4, 1]" in path.read_text()
    assert load_params(path, RouteParams).shift_window == (4, 1)
    with pytest.raises(ValueError, match="shift_window"):
        RouteParams(shift_window=(-1, 0))
    with pytest.raises(TypeError, match="shift_window"):
        RouteParams(shift_window=(1, 2, 3))  # type: ignore[arg-type]
    refs, queries, _ = ro.synthetic_route(20, 10, speed=1.0, seed=1)
    with pytest.raises(ValueError, match="row window of \\+-40 rows"):
        route.match_prepared(refs, queries, RouteParams(shift_window=(0, 40)))


def test_dask_backend_with_a_window():
    pytest.importorskip("dask", reason="the optional dask extra is not installed")
    from nightloc.route.dask_backend import dask_match_prepared

    refs, queries, _ = ro.synthetic_route(90, 70, speed=1.05, seed=12)
    params = RouteParams(shift_window=(7, 2))
    expected = route.match_prepared(refs, queries, params)
    import dask

    with dask.config.set(scheduler="synchronous"):
        result = dask_match_prepared(refs, queries, params, rows_per_block=23, keep_difference=True)
    np.testing.assert_array_equal(result.difference.compute(), expected.difference)
    np.testing.assert_array_equal(result.refs, expected.refs)
    np.testing.assert_array_equal(result.confidence, expected.confidence)


def test_cli_shift_window(tmp_path, capsys):
    from nightloc.cli import main

    refs, queries, _ = ro.synthetic_route(60, 50, speed=1.0, seed=5)
    folders = []
    for name, stack in (("day", refs), ("night", queries)):
        folder = tmp_path / name / "images"
        folder.mkdir(parents=True)
        import cv2

        for i, image in enumerate(stack):
            cv2.imwrite(str(folder / f"{i:04d}.png"), image)
        folders.append(str(folder.parent))
    out = tmp_path / "out"
    assert main(["route", *folders, "--out", str(out), "--shift-window", "3,1", "--no-figures"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert find_key(summary, "shift_window") == [3, 1]
    assert main(["route", *folders, "--out", str(tmp_path / "bad"), "--shift-window", "3"]) == 2
    assert "--shift-window '3': expected COLUMNS,ROWS" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()


def find_key(tree, key):
    """The value of the first ``key`` in a JSON tree (depth first), or None."""
    if isinstance(tree, dict):
        if key in tree:
            return tree[key]
        tree = list(tree.values())
    if isinstance(tree, list):
        for item in tree:
            found = find_key(item, key)
            if found is not None:
                return found
    return None
