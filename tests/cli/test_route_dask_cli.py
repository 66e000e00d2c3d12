"""``nightloc route --dask``: the same outputs as the run on one machine (a LocalCluster of worker
processes on loopback), on a rendered-texture route and on the real Nordland traverses, and one
clear line when dask is missing."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.route.preview import matrix_preview

import route_oracle as ro


def _outputs(out) -> dict:
    """Every summary (without its timings) and matches file of a route run's set, by path."""
    files = {}
    for path in sorted(out.rglob("summary.json")):
        summary = json.loads(path.read_text())
        summary.pop("timings_s", None)
        for result in summary.get("results", {}).values():  # a comparison of methods
            result.pop("search_s")
        files[str(path.relative_to(out))] = summary
    for path in sorted(out.rglob("matches.csv")):
        files[str(path.relative_to(out))] = path.read_text()
    assert files
    return files


def _both(reference, query, tmp_path, *options) -> tuple[dict, dict]:
    single, cluster = tmp_path / "single", tmp_path / "cluster"
    assert main(["route", str(reference), str(query), "--out", str(single), "--no-figures", *options]) == 0
    arguments = ["route", str(reference), str(query), "--out", str(cluster), "--no-figures", *options]
    assert main([*arguments, "--dask", "local", "--threads", "1"]) == 0
    return _outputs(single), _outputs(cluster)


def test_dask_local_equals_one_machine(tmp_path, capsys):
    pytest.importorskip("distributed", reason="dask.distributed is not installed (pip install 'nightloc[dask]')")
    positions = np.arange(0.0, 159.0, 0.6)
    refs, queries, _ = ro.synthetic_route_at(160, positions, seed=14, likeness=0.5, height=24, width=48)
    reference = nightloc.save_traverse(tmp_path / "ref", list(refs))
    query = nightloc.save_traverse(tmp_path / "qry", list(queries))
    single, cluster = _both(
        reference.root, query.root, tmp_path, "--method", "seqslam,filter", "--ground-truth", "none"
    )
    assert single == cluster
    printed = capsys.readouterr().out
    assert "(on the Dask cluster)" in printed


def test_dask_figure_is_the_matrix_picture(tmp_path):
    pytest.importorskip("distributed", reason="dask.distributed is not installed (pip install 'nightloc[dask]')")
    from nightloc import route
    from nightloc.route.dask_backend import dask_stream_match, local_client

    refs, queries, _ = ro.synthetic_route(120, 100, speed=1.0, seed=15)
    expected = route.match_prepared(refs, queries)
    with local_client(1) as client:  # one worker process
        result = dask_stream_match(client, refs, queries, rows_per_band=30)
    np.testing.assert_array_equal(result.refs, expected.refs)
    np.testing.assert_allclose(result.matrix_image, matrix_preview(expected.enhanced), rtol=1e-6, atol=1e-6)
    from nightloc.figures.route import difference_matrix_figure

    [image] = difference_matrix_figure(result).axes[0].get_images()
    np.testing.assert_allclose(image.get_array(), matrix_preview(expected.enhanced).T, rtol=1e-6, atol=1e-6)


@pytest.mark.slow
def test_nordland_dask_local_equals_one_machine(shared_data, tmp_path):
    pytest.importorskip("distributed", reason="dask.distributed is not installed (pip install 'nightloc[dask]')")
    root = shared_data / "nordland"
    if not (root / "summer").is_dir():
        pytest.skip(f"{root} not found")
    single, cluster = _both(root / "summer", root / "winter", tmp_path)
    assert single == cluster
    assert single["summary.json"]["n_refs"] == 3576 and single["summary.json"]["speed_check"]["fits"]


def test_without_dask_one_line_names_the_install(tmp_path, capsys, monkeypatch):
    refs, queries, _ = ro.synthetic_route(40, 30, speed=1.0, seed=16)
    reference = nightloc.save_traverse(tmp_path / "ref", list(refs))
    query = nightloc.save_traverse(tmp_path / "qry", list(queries))
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed raises ImportError
    out = tmp_path / "out"
    assert main(["route", str(reference.root), str(query.root), "--out", str(out), "--dask", "local"]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and 'pip install "nightloc[dask]"' in error[0]
    assert not out.exists()
