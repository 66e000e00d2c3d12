"""Learned appearances as evidence about their day images (experience maps): the helper against
hand arithmetic, and both methods choosing the day image's place when a learned night look scores
lower only because it is a night image."""

from __future__ import annotations

import numpy as np
import pytest

import nightloc
from nightloc.io.appearances import Appearances, LearnedNight
from nightloc.localization.day_scale import learned_mask, learned_proxies, on_day_scale
from nightloc.matching.sad import MatchResult

WIDTH, HEIGHT = 16, 8


def _experience_map() -> nightloc.ReferenceMap:
    """Four day places on a 2 m square and one night look learned at place 3 (x = 2, y = 2)."""
    rng = np.random.default_rng(5)
    positions = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [2.0, 2.0], [2.0, 2.0]])
    images = rng.integers(0, 256, (5, HEIGHT, WIDTH), dtype=np.uint8)
    night = LearnedNight(1, "night1", "2026-01-01T00:00:00Z", 10, 10, 1, 0, 0)
    appearances = Appearances(
        night=[0, 0, 0, 0, 1], confidence=[0, 0, 0, 0, 0.9], time=[0, 0, 0, 0, 3.0], matches=[0] * 5, nights=(night,)
    )
    params = nightloc.PreparationParams(width=WIDTH, height=HEIGHT)
    return nightloc.ReferenceMap(images, positions, np.zeros(5), params=params, appearances=appearances)


def test_learned_looks_move_their_day_references_by_their_evidence():
    scores = np.array([10, 12, 14, 5, 7, 4], dtype=np.float32)
    learned = np.array([0, 0, 0, 1, 1, 1], dtype=np.uint8)
    places = np.array([0, 1, 2, 2, 1, 3])  # reference 5: a look learned in a gap (no day image)
    proxies = learned_proxies(learned, places, None)
    assert proxies.tolist() == [-1, -1, -1, 2, 1, -1]
    # day median 12, learned median 5: on the day scale 12, 16.8, 9.6; the evidence of day
    # references 2 and 1 is 12 and 16.8, their median 14.4: reference 2 moves down by 2.4 (its night
    # look matches better than the typical one), reference 1 up by 2.4; each look then scores as
    # its day reference; the gap's look keeps its scaled score
    expected = np.float32([10, 12 + 2.4, 14 - 2.4, 14 - 2.4, 12 + 2.4, 4 * 2.4])
    np.testing.assert_allclose(on_day_scale(scores, learned, proxies), expected, rtol=1e-6)
    table = np.array([[10, 11], [12, 13], [14, 15], [5, 9], [8, 7], [4, 6]], dtype=np.float32)
    out = on_day_scale(table, learned, proxies)
    np.testing.assert_allclose(out[2], [14 - 2.4, 15 - 2.4], rtol=1e-6)
    np.testing.assert_array_equal(out[3], out[2])  # a look: its day reference's row
    np.testing.assert_allclose(out[5], [4 * 2.4, 6 * 2.4], rtol=1e-6)
    assert on_day_scale(scores, None, proxies) is scores  # a day map: the scores themselves
    assert on_day_scale(scores, np.ones(6, np.uint8), proxies) is scores  # nothing but learned: as they are
    with pytest.raises(ValueError, match="one value per reference"):
        on_day_scale(scores, learned[:3], proxies)


def test_a_look_belongs_to_the_day_reference_of_its_place_nearest_in_heading():
    # a forward camera's place: day views at 0, 90, 180 and -90 degrees; looks at 80 and -170 degrees
    places = np.zeros(6, int)
    headings = np.radians([0.0, 90.0, 180.0, -90.0, 80.0, -170.0])
    learned = np.array([0, 0, 0, 0, 1, 1], np.uint8)
    assert learned_proxies(learned, places, headings).tolist() == [-1, -1, -1, -1, 1, 2]


def test_a_day_map_has_no_learned_mask():
    ref_map = _experience_map()
    np.testing.assert_array_equal(learned_mask(ref_map), [0, 0, 0, 0, 1])
    day = nightloc.ReferenceMap(ref_map.images[:4], ref_map.positions[:4], np.zeros(4), params=ref_map.params)
    assert learned_mask(day) is None


def _frame_scores() -> np.ndarray:
    """The day image of place 0 matches best (10); the night look at place 3 scores 6 only
    because it is a night image (the frame's day scores have median 14.5, its learned one 6: on
    the day scale 14.5, and its lead of 1.5 over place 3's day image tempered: 15.4)."""
    return np.array([10.0, 14.0, 15.0, 16.0, 6.0], dtype=np.float32)


def test_the_filter_prefers_the_day_image_to_a_night_look_on_the_night_scale():
    ref_map = _experience_map()
    loc = nightloc.Localizer(ref_map, odometry_noise=0)
    table = np.repeat(_frame_scores()[:, None], WIDTH, axis=1)
    for k in range(6):
        estimate = loc.update_table(table, None if k == 0 else (0.0, 0.0))
    assert np.hypot(estimate.x, estimate.y) < 0.5, (estimate.x, estimate.y)  # place 0, not place 3
    assert estimate.score == pytest.approx(10.0)  # the learned look's score on the day scale: 14.5


def test_the_paper_method_prefers_the_day_image_to_a_night_look_on_the_night_scale():
    ref_map = _experience_map()
    loc = nightloc.Localizer(ref_map, method="paper", seq_len=3)
    scores = _frame_scores()
    result = MatchResult(4, scores, np.zeros(5, np.int32), np.zeros(5), WIDTH)
    for k in range(3):
        estimate = loc.update_match(result, None if k == 0 else (0.0, 0.0))
    assert np.hypot(estimate.x, estimate.y) < 0.5, (estimate.x, estimate.y)


def test_the_core_refuses_learned_flags_that_do_not_fit_the_map():
    core = nightloc.Localizer(_experience_map())._filter.core
    with pytest.raises(ValueError, match="one flag per reference"):
        core.set_learned(np.zeros(3, np.uint8))
    with pytest.raises(ValueError, match=r"0 \(day map\) or 1"):
        core.set_learned(np.array([0, 0, 0, 0, 2], np.uint8))
    core.set_learned(np.zeros(0, np.uint8))  # none: a day map's filter
