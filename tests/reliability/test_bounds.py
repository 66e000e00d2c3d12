"""Sizes are checked before memory is taken: every parameter that sizes an allocation is bounded,
with a message naming the bound (the constants of ``nightloc._validate``), or -- where a larger
value means nothing more -- clipped so that memory stays bounded and the answers stay exact.

Old behaviour, for each case: ``clahe_tiles = [100000, 100000]`` asked OpenCV for 361 GB;
``Localizer(map, confidence_radius=1000)`` on a 7 x 5 m map took 20 GiB; a 3 MB map file whose
arrays decompress to 3 GB was read whole (18 s, 3.2 GB) before ``MapFormatError``; ``synth --size
100000x4``, ``seq_len`` x grid, ``--repeats``, ``info --refs`` and parameter files were unbounded.
"""

from __future__ import annotations

import functools
import io
import math
import tracemalloc
import zipfile

import numpy as np
import pytest

import nightloc
from nightloc import MapFormatError, NightlocError, _validate
from nightloc.cli import main
from nightloc.localization import evaluation
from nightloc.localization.heatmap import HeatMapper
from nightloc.synth.render import Camera

from reliability_support import Workspace

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests size the core's buffers.
pytestmark = pytest.mark.sanitize


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    return Workspace(tmp_path_factory.mktemp("bounds"))


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def _map_bomb(ws) -> object:
    """A small zip whose images member inflates to 200 MB (zeros compress ~1000x)."""
    path = ws.fresh("bomb").with_suffix(".map")
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("header.npy", _npy(np.frombuffer(b"{}", np.uint8)))
        archive.writestr("images.npy", _npy(np.zeros((180_000, 24, 48), np.uint8)))
    return path


REFUSED = [
    (
        "CLAHE tiles 100000 x 100000",
        lambda ws: lambda: nightloc.PreparationParams(equalize="clahe", clahe_tiles=(100_000, 100_000)),
        "MAX_CLAHE_TILES",
    ),
    ("heat-map grid of 10**8 cells", lambda ws: lambda: HeatMapper(ws.map.positions, 10_000, 10_000), "MAX_GRID_CELLS"),
    (
        "sequence of 1000 frames on a 2000 x 2000 grid",
        lambda ws: lambda: nightloc.LocalizationParams(seq_len=1000, grid_width=2000, grid_height=2000),
        "MAX_SEQUENCE_CELLS",
    ),
    (
        "compiled sequence of 10**6 frames",
        lambda ws: lambda: HeatMapper(ws.map.positions, 100, 100).sequence(1_000_000),
        "MAX_SEQUENCE_CELLS",
    ),
    ("synthetic camera 100000 x 4", lambda ws: lambda: Camera(100_000, 4), "MAX_CAMERA_SIDE"),
    ("synthetic camera 4096 x 4096", lambda ws: lambda: Camera(4096, 4096), "MAX_CAMERA_RAYS"),
    ("evaluation repeats 10**9", lambda ws: lambda: evaluation.EvaluationSettings(repeats=10**9), "MAX_REPEATS"),
    (
        "map whose arrays inflate 1000x",
        lambda ws: functools.partial(nightloc.ReferenceMap.load, _map_bomb(ws)),
        "MAX_MAP_EXPANSION",
    ),
    (
        "parameter file of 2 MiB",
        lambda ws: functools.partial(nightloc.load_params, ws.write("big.toml", "# comment\n" * 200_000)),
        "MAX_PARAMS_FILE_BYTES",
    ),
]


@pytest.mark.parametrize("case", REFUSED, ids=[c[0] for c in REFUSED])
def test_sizes_are_refused_before_memory_is_taken(ws, case):
    _, make, bound = case
    call = make(ws)  # the test's own inputs (a file to read) are made before memory is traced
    tracemalloc.start()
    try:
        with pytest.raises((ValueError, NightlocError, MapFormatError)) as info:
            call()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert bound in str(info.value), str(info.value)
    assert peak < 48 << 20, f"{peak / 2**20:.0f} MiB taken before the refusal"


def test_an_npy_header_larger_than_its_member_is_refused_unread(ws):
    path = ws.fresh("lying").with_suffix(".map")
    header = np.lib.format.header_data_from_array_1_0(np.zeros((4, 24, 48), np.uint8))
    header["shape"] = (40_000_000, 24, 48)  # 46 GB declared
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, header)
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("header.npy", _npy(np.frombuffer(b"{}", np.uint8)))
        archive.writestr("images.npy", buffer.getvalue() + bytes(4 * 24 * 48))
    tracemalloc.start()
    try:
        with pytest.raises(MapFormatError, match="declares shape"):
            nightloc.ReferenceMap.load(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 << 20


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["synth", "--out", "{tmp}/s", "--size", "100000x4"], "MAX_CAMERA_SIDE"),
        (["synth", "--out", "{tmp}/s", "--size", "4000x4000"], "MAX_CAMERA_RAYS"),
        (["info", "--refs", "1000000000"], "MAX_SPEED_TEST_REFS"),
        (["evaluate", "{trav}", "{trav}", "--out", "{tmp}/e", "--repeats", "1000000000"], "MAX_REPEATS"),
        (["demo", "--out", "{tmp}/d", "--repeats", "1000000000"], "MAX_REPEATS"),
    ],
    ids=["synth side", "synth rays", "info refs", "evaluate repeats", "demo repeats"],
)
def test_command_line_sizes_are_bounded(ws, tmp_path, capsys, argv, words):
    args = [a.format(tmp=tmp_path, trav=ws.traverse.root) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def _diagonal(ref_map):
    span = np.ptp(ref_map.positions, axis=0)
    return float(math.hypot(*span))


def _brute_force_confidence(localizer, heat, cell):
    """(peak - second) / (peak - floor) with ``second`` the hottest cell centre farther than the
    confidence radius from the peak's cell centre: the definition, over every cell."""
    grid = localizer.grid
    centres = grid.centres()
    flat = heat.ravel()
    peak, floor = flat[cell], flat.min()
    far = np.hypot(*(centres - centres[cell]).T) > localizer.params.confidence_radius + 1e-9
    if not far.any():
        return 1.0
    return float(np.clip((peak - flat[far].max()) / (peak - floor), 0.0, 1.0))


@pytest.mark.parametrize("factor", [0.3, 0.9, 20.0, 200.0])
def test_a_confidence_radius_beyond_the_map_takes_bounded_memory_and_gives_exact_answers(ws, factor):
    """The disk around the peak is clipped to the grid's own size: offsets beyond it never meet a
    cell. Checked against the definition on every cell (radius 0.3 and 0.9 of the map's
    diagonal, where the clipping starts -- controls that held before -- and 20x and 200x beyond
    it, which took hundreds of MiB to GiB before)."""
    radius = factor * _diagonal(ws.map)
    tracemalloc.start()
    try:
        localizer = nightloc.Localizer(
            ws.map, grid_width=60, grid_height=40, method="paper", seq_len=3, confidence_radius=radius
        )
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 32 << 20, f"{peak / 2**20:.0f} MiB for a confidence radius of {radius:.0f} m"
    for k, frame in enumerate(ws.frames):
        estimate = localizer.update(frame, None if k == 0 else (0.1, 0.0), return_heatmap=True)
        cell = localizer.mapper._cell_of(estimate.x, estimate.y) if not localizer.params.interpolation else None
        heat = estimate.heatmap
        cell = int(np.argmax(heat)) if cell is None else cell
        assert estimate.confidence == pytest.approx(_brute_force_confidence(localizer, heat, cell), abs=1e-5)


def test_bounds_are_documented_in_one_place():
    """Every bound constant is named in the docstring table of ``nightloc._validate``."""
    names = [name for name in dir(_validate) if name.startswith("MAX_")]
    assert len(names) >= 9
    for name in names:
        assert f"``{name}``" in _validate.__doc__, name
