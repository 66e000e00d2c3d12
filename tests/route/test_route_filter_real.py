"""Route mode's targets on the real day/night and summer/winter pairs in ../shared/data (skipped
where absent): default parameters, +-2 frames, causal filter against SeqSLAM."""

from __future__ import annotations

import numpy as np
import pytest

import nightloc
from nightloc import route

from route_support import NORDLAND_GROUP, default_match

PAIRS = {
    # name: (reference, query, targets: best F1, recall at 100 % precision)
    "gardens_point": ("gardens_point/day_right", "gardens_point/night_right", 0.85, 0.30),
    "nordland": ("nordland/summer", "nordland/winter", 0.92, 0.65),
}


def _evaluate(result):
    truth = route.GroundTruth.from_frames(result.n_queries, result.n_refs, 2)
    return route.evaluate_matches(result.refs, result.scores, truth)


@pytest.mark.xdist_group(NORDLAND_GROUP)
@pytest.mark.parametrize("name", sorted(PAIRS))
def test_filter_meets_the_targets_and_beats_seqslam(shared_data, name):
    reference, query, f1_target, r100_target = PAIRS[name]
    refs, queries, result = default_match(shared_data, reference, query)  # match_prepared, default params
    evaluation = _evaluate(result)
    assert evaluation.best_f1 >= f1_target, evaluation.summary()
    assert evaluation.recall_at_100 >= r100_target, evaluation.summary()
    # SeqSLAM on the same prepared frames (centred, ds 10, as before the filter) is far behind: its
    # difference matrix is the filter's (the method changes only the search).
    seqslam = _evaluate(route.match_difference(result.difference, route.RouteParams(method="seqslam")))
    assert evaluation.best_f1 > seqslam.best_f1 + 0.1
    assert evaluation.recall_at_100 > seqslam.recall_at_100 + 0.2
    # Causal: the streaming localizer gives the same answers frame by frame (first 150 frames).
    localizer = nightloc.RouteLocalizer(refs, prepared=True)
    stream = [localizer.update(q, prepared=True) for q in queries[:150]]
    np.testing.assert_array_equal([u.ref for u in stream], result.refs[:150])
    np.testing.assert_array_equal([u.confidence for u in stream], result.confidence[:150])
