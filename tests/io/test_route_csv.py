"""Route mode's CSV text (nightloc.io.route_csv): the columns, no-match rows, numbers that
round-trip, and a module that imports no other stage."""

from __future__ import annotations

import ast
import csv
import io
import math
from pathlib import Path

import numpy as np

from nightloc.io import route_csv
from nightloc.io.route_csv import matches_csv, pr_csv


def test_matches_csv_columns_and_unmatched_rows():
    text = matches_csv(
        np.array([2, -1, 0]),
        np.array([0.125, math.nan, 1 / 3]),
        ["q0.png", "q1.png", "q2.png"],
        ["r0.png", "r1.png", "r2.png"],
        confidence=np.array([0.875, 0.0, 2 / 3]),
        off_route=np.array([0.01, 0.5, 0.02]),
        query_times=np.array([1.5, 2.0, math.nan]),
    )
    rows = list(csv.reader(io.StringIO(text)))
    assert rows[0] == ["query", "ref", "score", "query_image", "ref_image", "confidence", "off_route", "timestamp"]
    assert rows[1] == ["0", "2", "0.125", "q0.png", "r2.png", "0.875", "0.01", "1.5"]
    assert rows[2][:5] == ["1", "-1", "nan", "q1.png", ""]
    assert float(rows[3][2]) == 1 / 3 and float(rows[3][5]) == 2 / 3  # repr round-trips
    assert rows[3][7] == "nan"
    numbers = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, usecols=(0, 1, 2))
    assert numbers.shape == (3, 3)


def test_matches_csv_without_the_filter_columns():
    text = matches_csv(np.array([1]), np.array([0.5]), ["q.png"], ["a.png", "b.png"])
    assert text.splitlines() == ["query,ref,score,query_image,ref_image,timestamp", "0,1,0.5,q.png,b.png,nan"]


def test_pr_csv():
    text = pr_csv([0.1, 0.2], [1.0, 0.5], [0.25, 0.75])
    assert text.splitlines() == ["threshold,precision,recall", "0.1,1.0,0.25", "0.2,0.5,0.75"]


def test_route_csv_imports_no_other_stage():
    tree = ast.parse(Path(route_csv.__file__).read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            assert node.level <= 1, f"route_csv imports {'.' * node.level}{node.module}"
            assert node.level == 1 or not (node.module or "").startswith("nightloc"), node.module
