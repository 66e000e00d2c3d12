"""The API's edges: inputs that used to give silent wrong answers or confusing errors.

Old behaviour, case by case: ``add_translated`` with ``out`` aliasing ``source`` gave wrong values
silently; odometry given as ``memoryview(b'ab')`` was taken as (97, 98) m; a masked array's mask
was ignored; a (H, W, 2) grey + alpha frame became H prepared frames; ``copy.copy(localizer)``
shared the compiled sequence with the original; one ``Localizer`` updated from several threads
raised IndexErrors; folder listings skipped ``.gif`` frames that load fine by name; a folder name
that is not valid UTF-8 failed only after every frame was prepared.
"""

from __future__ import annotations

import copy
import os
import sys
import threading

import cv2
import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.io.images import IMAGE_SUFFIXES
from nightloc.localization.sequence import PaddedLayout, add_translated

from heat_oracle import add_translated_opencv, scratch
from reliability_support import Workspace, random_frames

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core.
pytestmark = pytest.mark.sanitize


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    return Workspace(tmp_path_factory.mktemp("edges"))


# --------------------------------------------------------------------------------------------
# aliasing


def test_add_translated_refuses_out_aliasing_source():
    layout = PaddedLayout(20, 30, np.float32)
    rng = np.random.default_rng(0)
    source = layout.pad(rng.uniform(0, 1, (20, 30)).astype(np.float32))
    for alias in (source, source[:], source.reshape(20, 31).reshape(-1)):
        with pytest.raises(ValueError, match="share memory"):
            add_translated(layout, alias, source, 1.5, -2.25)
    expected = layout.zeros()
    add_translated_opencv(layout, expected, source.copy(), 1.5, -2.25, scratch(layout))
    out = layout.zeros()
    add_translated(layout, out, source.copy(), 1.5, -2.25)  # a copy gives the oracle's answer
    np.testing.assert_allclose(layout.view(out), layout.view(expected), atol=1e-6)


# --------------------------------------------------------------------------------------------
# only real numbers as odometry


NOT_ODOMETRY = {
    "memoryview of bytes": memoryview(b"ab"),
    "bytearray": bytearray(b"ab"),
    "complex pair": (1 + 2j, 0.5),
    "complex array": np.array([1 + 1j, 2]),
    "bool pair": (True, False),
    "bool array": np.array([True, False]),
    "strings": ["1", "2"],
    "object array": np.array([1.0, None], dtype=object),
    "masked pair": np.ma.masked_array([1.0, 2.0], mask=[False, True]),
}


@pytest.mark.parametrize("odometry", list(NOT_ODOMETRY))
def test_odometry_must_be_real_numbers(ws, odometry):
    """(Tuples of booleans or complex numbers were refused before; arrays and buffers were not.)"""
    localizer = nightloc.Localizer(ws.map, grid_width=30, grid_height=20)
    first = localizer.update(ws.frames[0])
    with pytest.raises(TypeError, match=r"odometry|dx|masked"):
        localizer.update(ws.frames[1], NOT_ODOMETRY[odometry])
    # the refused update changed nothing: the next one fuses two frames, as on a fresh localizer
    fresh = nightloc.Localizer(ws.map, grid_width=30, grid_height=20)
    fresh.update(ws.frames[0])
    assert localizer.update(ws.frames[1], (0.1, 0.2)) == fresh.update(ws.frames[1], (0.1, 0.2))
    assert first.frames == 1


def test_real_number_odometry_of_any_numeric_type_is_accepted(ws):
    """The control: the stricter check still takes every real-number pair."""
    answers = []
    for pair in ((0.5, -0.25), np.array([0.5, -0.25]), np.array([1, -1], np.int8) / np.array([2, 4]), [0.5, -0.25]):
        localizer = nightloc.Localizer(ws.map, grid_width=30, grid_height=20)
        localizer.update(ws.frames[0])
        answers.append(localizer.update(ws.frames[1], pair))
    assert all(answer == answers[0] for answer in answers)


# --------------------------------------------------------------------------------------------
# masked arrays


MASKED = np.ma.masked_array(np.zeros((24, 48), np.uint8), mask=np.eye(24, 48, dtype=bool))
MASKED_CALLS = [
    ("prepare", lambda ws: nightloc.prepare(np.ma.masked_array(ws.frames[0], mask=ws.frames[0] > 200))),
    ("match query", lambda ws: nightloc.match(MASKED, ws.map.images)),
    ("patch_normalize", lambda ws: nightloc.patch_normalize(MASKED)),
    ("ReferenceMap positions", lambda ws: nightloc.ReferenceMap(ws.map.images, np.ma.masked_invalid(ws.positions))),
    (
        "save_traverse positions",
        lambda ws: nightloc.save_traverse(ws.fresh("t"), ws.frames, np.ma.masked_invalid(ws.positions)),
    ),
    ("Localizer frame", lambda ws: nightloc.Localizer(ws.map).update(np.ma.masked_array(ws.frames[0]))),
]


@pytest.mark.parametrize("case", MASKED_CALLS, ids=[c[0] for c in MASKED_CALLS])
def test_masked_arrays_are_refused(ws, case):
    with pytest.raises(TypeError, match="masked array"):
        case[1](ws)


# --------------------------------------------------------------------------------------------
# grey + alpha


def test_grey_plus_alpha_frames_are_one_frame_with_the_alpha_dropped(ws):
    grey = cv2.cvtColor(ws.frames[0], cv2.COLOR_BGR2GRAY)
    alpha = np.random.default_rng(2).integers(0, 256, grey.shape, dtype=np.uint8)
    frame = np.dstack([grey, alpha])  # (H, W, 2)
    prepared = nightloc.prepare(frame)
    assert prepared.shape == (24, 48)
    np.testing.assert_array_equal(prepared, nightloc.prepare(grey))
    stack = nightloc.prepare(np.stack([frame, frame]))  # (N, H, W, 2): N frames
    assert stack.shape == (2, 24, 48)
    np.testing.assert_array_equal(stack[1], prepared)
    assert ws.map.match(frame).index == ws.map.match(grey).index


# --------------------------------------------------------------------------------------------
# localizers: copies and threads


def _run(localizer, frames, steps):
    return [localizer.update(f, None if s is None else tuple(s)) for f, s in zip(frames, steps)]


METHODS = {"paper": {"method": "paper", "seq_len": 4}, "filter": {"method": "filter"}}


def _state_of(localizer):
    return localizer._sequence if localizer.method == "paper" else localizer._filter.core


@pytest.mark.parametrize("method", list(METHODS))
def test_a_copied_localizer_is_independent(ws, method):
    steps = [None, (0.2, 0.1), (0.1, -0.3), (0.0, 0.2), (-0.1, 0.1), (0.3, 0.0)]
    options = METHODS[method]
    original = nightloc.Localizer(ws.map, grid_width=40, grid_height=30, **options)
    _run(original, ws.frames[:3], steps[:3])
    for clone in (copy.copy(original), copy.deepcopy(original)):
        assert _state_of(clone) is not _state_of(original)
        _run(clone, ws.frames[::-1], steps)  # the copy goes its own way ...
    # ... and the original answers as if no copy had been made (oracle: a localizer never copied)
    oracle = nightloc.Localizer(ws.map, grid_width=40, grid_height=30, **options)
    expected = _run(oracle, ws.frames, steps)
    assert _run(original, ws.frames[3:], steps[3:]) == expected[3:]
    # and a copy continues exactly like its original from the state it was copied in
    first = nightloc.Localizer(ws.map, grid_width=40, grid_height=30, **options)
    _run(first, ws.frames[:3], steps[:3])
    second = copy.copy(first)
    assert _run(second, ws.frames[3:], steps[3:]) == expected[3:]


@pytest.mark.parametrize("method", list(METHODS))
def test_a_localizer_used_from_two_threads_raises_one_clear_error(ws, monkeypatch, method):
    """An update running in one thread makes another thread's update raise RuntimeError at once
    (before any state changes); the localizer then goes on exactly as one never disturbed."""
    options = METHODS[method]
    localizer = nightloc.Localizer(ws.map, grid_width=40, grid_height=30, **options)
    localizer.update(ws.frames[0])
    inside, release = threading.Event(), threading.Event()
    owner, name = (localizer.mapper, "place_excess") if method == "paper" else (localizer._filter, "step_image")
    real = getattr(owner, name)

    def slow(*args):
        inside.set()
        release.wait(30)
        return real(*args)

    monkeypatch.setattr(owner, name, slow)
    answers = []
    worker = threading.Thread(target=lambda: answers.append(localizer.update(ws.frames[1], (0.1, 0.0))))
    worker.start()
    assert inside.wait(30)
    with pytest.raises(RuntimeError, match="another thread") as info:
        localizer.update(ws.frames[2], (0.1, 0.0))
    assert "\n" not in str(info.value)
    with pytest.raises(RuntimeError, match="another thread"):
        localizer.reset()
    release.set()
    worker.join(30)
    monkeypatch.undo()
    oracle = nightloc.Localizer(ws.map, grid_width=40, grid_height=30, **options)
    expected = _run(oracle, ws.frames[:3], [None, (0.1, 0.0), (0.1, 0.0)])
    assert answers == [expected[1]]
    assert localizer.update(ws.frames[2], (0.1, 0.0)) == expected[2]


# --------------------------------------------------------------------------------------------
# folder listings and file names


def _decodable_suffixes() -> list[str]:
    """Suffixes this OpenCV both writes and decodes back to 8-bit pixels (an independent probe)."""
    image = np.random.default_rng(0).integers(0, 256, (16, 24, 3), dtype=np.uint8)
    found = []
    for suffix in (".png", ".jpg", ".bmp", ".tif", ".webp", ".ppm", ".pnm", ".sr", ".ras", ".gif", ".pam", ".avif"):
        try:
            ok, encoded = cv2.imencode(suffix, image)
        except cv2.error:
            continue
        decoded = cv2.imdecode(encoded, cv2.IMREAD_ANYCOLOR | cv2.IMREAD_ANYDEPTH) if ok else None
        if decoded is not None and decoded.dtype == np.uint8:
            found.append(suffix)
    return found


def test_folder_listings_take_every_format_opencv_reads(tmp_path):
    suffixes = _decodable_suffixes()
    assert ".png" in suffixes
    missing = [s for s in suffixes if s not in IMAGE_SUFFIXES]
    assert missing == [], f"OpenCV reads {missing}, but folder listings skip them"
    if ".gif" not in suffixes:
        pytest.skip("this OpenCV cannot write GIF")
    folder = tmp_path / "gifs" / "images"
    folder.mkdir(parents=True)
    for i, frame in enumerate(random_frames(4, seed=9)):
        cv2.imencode(".gif", frame)[1].tofile(folder / f"{i}.gif")
    traverse = nightloc.load_traverse(tmp_path / "gifs")
    assert traverse.names == ("0.gif", "1.gif", "2.gif", "3.gif")
    assert traverse.read(2).shape == (30, 60, 3)


@pytest.mark.skipif(sys.platform != "linux", reason="needs a file system that stores names as bytes")
def test_a_folder_name_that_is_not_utf8_works_end_to_end(ws, tmp_path, capsys):
    """A traverse folder named b"caf\\xe9" (Latin-1): build-map, evaluate and route run, and the map
    remembers the folder's exact bytes (old: build-map failed after preparing every frame)."""
    name = os.fsdecode(b"caf\xe9")
    root = tmp_path / name
    nightloc.save_traverse(root, ws.frames * 3, np.tile(ws.positions, (3, 1)) + np.repeat(np.arange(3), 6)[:, None])
    listed = tmp_path / os.fsdecode(b"route-\xff")
    listed.mkdir()
    for i, frame in enumerate(ws.frames * 3):
        cv2.imencode(".png", frame)[1].tofile(listed / os.fsdecode(b"img-%02d-\xe9.png" % i))
    assert main(["build-map", str(root), str(tmp_path / "m.map")]) == 0
    loaded = nightloc.ReferenceMap.load(tmp_path / "m.map")
    assert os.fsencode(loaded.source) == os.fsencode(str(root))
    out = tmp_path / os.fsdecode(b"r\xe9sultats")
    argv = ["evaluate", str(tmp_path / "m.map"), str(root), "--out", str(out)]
    assert main([*argv, "--seq-lengths", "1", "--noise-models", "0", "--no-figures"]) == 0
    assert main(["route", str(listed), str(listed), "--out", str(tmp_path / "r"), "--ds", "4", "--no-figures"]) == 0
    rows = (tmp_path / "r" / "matches.csv").read_bytes().splitlines()
    assert rows[1].split(b",")[3] == b"img-00-\xe9.png"  # the file's own bytes
    capsys.readouterr()


def _route_answers(localizer, frames):
    return [(u.ref, u.score) for u in (localizer.update(f, prepared=True) for f in frames)]


@pytest.mark.parametrize("method", ["filter", "seqslam"])
def test_a_copied_route_localizer_is_independent(method):
    """``copy.copy`` / ``copy.deepcopy`` of a RouteLocalizer mid-route: the copy goes its own way and
    the original answers as if no copy had been made (before: the copy shared the window/belief)."""
    rng = np.random.default_rng(3)
    refs = rng.integers(0, 256, (30, 24, 48), dtype=np.uint8)
    route = [refs[i] for i in range(8, 20)]
    detour = [refs[i] for i in (27, 3, 15, 22, 9, 1, 28, 12, 5, 19, 2, 24)]
    kwargs = {"method": method, "prepared": True, "threads": 1, "params": nightloc.RouteParams(ds=4)}
    original = nightloc.RouteLocalizer(refs, **kwargs)
    _route_answers(original, route[:6])
    for clone in (copy.copy(original), copy.deepcopy(original)):
        _route_answers(clone, detour)
    oracle = nightloc.RouteLocalizer(refs, **kwargs)
    _route_answers(oracle, route[:6])
    assert _route_answers(original, route[6:]) == _route_answers(oracle, route[6:])
    # a copy continues exactly like its original from the state it was copied in
    first = nightloc.RouteLocalizer(refs, **kwargs)
    _route_answers(first, route[:5])
    second = copy.copy(first)
    assert _route_answers(second, route[5:]) == _route_answers(first, route[5:])


def test_a_route_localizer_used_from_two_threads_raises_one_clear_error(monkeypatch):
    """An update running in one thread makes another thread's update (or reset) raise RuntimeError
    at once; the localizer then goes on exactly as one never disturbed."""
    rng = np.random.default_rng(4)
    refs = rng.integers(0, 256, (20, 24, 48), dtype=np.uint8)
    frames = [refs[i] for i in (5, 6, 7)]
    localizer = nightloc.RouteLocalizer(refs, prepared=True, threads=1)
    localizer.update(frames[0], prepared=True)
    inside, release = threading.Event(), threading.Event()
    real = localizer._update

    def slow_update(*args):
        inside.set()
        release.wait(30)
        return real(*args)

    monkeypatch.setattr(localizer, "_update", slow_update)
    answers = []
    worker = threading.Thread(target=lambda: answers.append(localizer.update(frames[1], prepared=True)))
    worker.start()
    assert inside.wait(30)
    with pytest.raises(RuntimeError, match="another thread") as info:
        localizer.update(frames[2], prepared=True)
    assert "\n" not in str(info.value)
    with pytest.raises(RuntimeError, match="another thread"):
        localizer.reset()
    release.set()
    worker.join(30)
    monkeypatch.undo()
    oracle = nightloc.RouteLocalizer(refs, prepared=True, threads=1)
    expected = [oracle.update(f, prepared=True) for f in frames]
    assert answers == [expected[1]]
    assert localizer.update(frames[2], prepared=True) == expected[2]
