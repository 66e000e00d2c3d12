"""The streaming, causal RouteLocalizer: frame by frame it gives exactly the batch causal result,
which itself equals the numpy oracle of causal trajectories."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

import nightloc
from nightloc import route
from nightloc.route import RouteParams

import route_oracle as ro


def stream(localizer, frames, prepared=True):
    updates = [localizer.update(frame, prepared=prepared) for frame in frames]
    refs = np.array([-1 if u.ref is None else u.ref for u in updates], dtype=np.int64)
    scores = np.array([u.score for u in updates])
    return updates, refs, scores


@pytest.mark.parametrize("ds", [3, 8, 10])
def test_streaming_equals_batch_causal_and_oracle(ds):
    refs, queries, truth = ro.synthetic_route(150, 120, speed=0.9, seed=ds)
    params = RouteParams(method="seqslam", mode="causal", ds=ds)
    batch = route.match_prepared(refs, queries, params)
    localizer = nightloc.RouteLocalizer(refs, params, prepared=True)
    updates, stream_refs, stream_scores = stream(localizer, queries)
    np.testing.assert_array_equal(stream_refs, batch.refs)
    np.testing.assert_array_equal(stream_scores, batch.scores)
    # The first ds-1 frames have no match yet; from frame ds-1 on, every frame has one.
    assert all(u.ref is None and math.isnan(u.score) for u in updates[: ds - 1])
    assert all(u.matched for u in updates[ds - 1 :])
    assert [u.index for u in updates] == list(range(len(queries)))
    # The batch causal mode against the independent oracle.
    expected_refs, expected_scores = ro.find_matches_causal(ro.enhance_causal(batch.difference), ds)
    np.testing.assert_array_equal(batch.refs, expected_refs)
    np.testing.assert_array_equal(batch.scores, expected_scores)
    # Causal trajectories end at the current frame: the match is where the robot is now.
    ok = (batch.refs >= 0) & (truth >= 0)
    assert np.mean(np.abs(batch.refs[ok] - truth[ok]) <= 2) > 0.9


def test_localizer_needs_no_future_frames():
    # Each answer depends only on the frames so far: the prefix of a stream gives the same answers.
    refs, queries, _ = ro.synthetic_route(100, 60, speed=1.0, seed=4)
    full = stream(nightloc.RouteLocalizer(refs, "nightloc", prepared=True), queries)[1]
    prefix = stream(nightloc.RouteLocalizer(refs, "nightloc", prepared=True), queries[:30])[1]
    np.testing.assert_array_equal(full[:30], prefix)


def test_reset_and_raw_frames():
    refs, queries, _ = ro.synthetic_route(90, 40, speed=1.0, seed=5)
    colour = np.repeat(queries[..., None], 3, axis=3)
    localizer = nightloc.RouteLocalizer(np.repeat(refs[..., None], 3, axis=3), preset="openseqslam")
    assert localizer.params.mode == "causal"
    first = stream(localizer, colour, prepared=False)[1]
    localizer.reset()
    assert localizer.frames_seen == 0
    again = stream(localizer, colour, prepared=False)[1]
    np.testing.assert_array_equal(first, again)
    prepared = nightloc.RouteLocalizer(nightloc.block_normalize(refs), preset="openseqslam", prepared=True)
    np.testing.assert_array_equal(stream(prepared, nightloc.block_normalize(queries))[1], first)
    assert localizer.update(colour[0]).accepted(10.0) is True  # after a full window again
    localizer.reset()
    assert localizer.update(colour[0]).accepted(10.0) is False


def test_localizer_errors():
    refs, queries, _ = ro.synthetic_route(40, 10, speed=1.0, seed=6)
    localizer = nightloc.RouteLocalizer(refs, prepared=True)
    with pytest.raises(ValueError, match="references are"):
        localizer.update(queries[0][:, :-8].copy(), prepared=True)
    with pytest.raises(TypeError, match="uint8"):
        localizer.update(queries[0].astype(np.float32), prepared=True)
    with pytest.raises(ValueError, match="needs at least"):
        nightloc.RouteLocalizer(refs[:10], method="seqslam", prepared=True)
    with pytest.raises(TypeError, match="not both"):
        nightloc.RouteLocalizer(refs, RouteParams(), preset="nightloc", prepared=True)


def test_streaming_on_nordland(shared_data):
    root = shared_data / "nordland"
    if not root.is_dir():
        pytest.skip(f"{root} not found")
    names = [f"images-{10 * i:05d}.png" for i in range(1001, 1201)]

    def read(season):
        return [cv2.imread(str(root / season / name), cv2.IMREAD_COLOR) for name in names]

    summer, winter = read("summer"), read("winter")
    localizer = nightloc.RouteLocalizer(summer, preset="openseqslam")
    _updates, refs, scores = stream(localizer, winter, prepared=False)
    batch = route.match_route(summer, winter, route.resolve_params("openseqslam", mode="causal"))
    np.testing.assert_array_equal(refs, batch.refs)
    np.testing.assert_array_equal(scores, batch.scores)
    evaluation = route.evaluate_matches(refs, scores, route.GroundTruth.from_frames(200, 200, 2))
    assert evaluation.recall_at_100 > 0.2
