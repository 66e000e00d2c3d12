"""Experience maps: what a localized night adds to a map (appearances, new places, the cap)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import nightloc
from nightloc.errors import MapFormatError
from nightloc.experience.learning import (
    LearningParams,
    LocalizedNight,
    learn,
    place_spacing,
    trusted_frames,
)
from nightloc.io.appearances import Appearances, LearnedNight
from nightloc.localization.heatmap import HeatMapper
from nightloc.localization.localizer import Estimate

from oracle import rotational_sad

SHAPE = (24, 48)


def _day_map(seed: int = 0) -> nightloc.ReferenceMap:
    """12 places on a 1 m grid (4 x 3), random prepared images, heading 0."""
    rng = np.random.default_rng(seed)
    xs, ys = np.meshgrid(np.arange(4.0), np.arange(3.0))
    positions = np.column_stack([xs.ravel(), ys.ravel()])
    images = rng.integers(0, 256, (len(positions), *SHAPE), dtype=np.uint8)
    return nightloc.ReferenceMap(images, positions, np.zeros(len(positions)), source="day")


def _estimate(x: float, y: float, confidence: float = 0.95, radius: float = 0.2, heading: float = 0.1) -> Estimate:
    return Estimate(x, y, heading, 0, confidence, 10, 0, 0.0, credible_radius=radius, method="filter")


def _night(ref_map, images, poses, confidence=0.95, radius=0.2, source="night") -> LocalizedNight:
    """A night of prepared ``images`` at ``poses`` (x, y), its score medians from the numpy oracle."""
    images = np.asarray(images, dtype=np.uint8)
    mins = [rotational_sad(q, ref_map.images, range(SHAPE[1])).min(axis=1) for q in images]
    looks = None if ref_map.appearances is None else ref_map.appearances.night > 0
    estimates = tuple(_estimate(x, y, confidence, radius) for x, y in poses)
    return LocalizedNight(
        images,
        estimates,
        np.asarray([float(np.median(m)) for m in mins]),
        tuple(f"{k:06d}.png" for k in range(len(images))),
        np.arange(len(images), dtype=np.float64) * 0.5 + 1.0,
        source,
        ref_map.fingerprint,
        ref_map.params,
        learned_medians=None if looks is None else np.asarray([float(np.median(m[looks])) for m in mins]),
        best_looks=None if looks is None else np.asarray([np.flatnonzero(looks)[np.argmin(m[looks])] for m in mins]),
    )


def _settled(poses_after):
    """Five frames at (0, 0) then ``poses_after``: with ``settled_frames=5`` the fifth frame is the
    first trusted (the run of five confident frames counts it)."""
    return [(0.0, 0.0)] * 5 + list(poses_after)


def _learned_once(seed: int):
    """The day map, a night over its 12 places (after five settling frames) of random looks at
    ``poses``, the map that learned it and the generator: ``(day, poses, looks, once, rng)``."""
    day = _day_map()
    rng = np.random.default_rng(seed)
    poses = _settled([(x + 0.1, y) for x in range(4) for y in range(3)])
    looks = rng.integers(0, 256, (len(poses), *SHAPE), dtype=np.uint8)
    once, _ = learn(day, _night(day, looks, poses))
    return day, poses, looks, once, rng


def test_trusted_frames_need_a_settled_run_of_confident_tight_frames():
    params = LearningParams(min_confidence=0.8, max_credible_radius=0.5, settled_frames=3)
    conf = [0.9, 0.9, 0.9, 0.9, 0.5, 0.9, 0.9, 0.9, 0.9, 0.9]
    radius = [0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.9, 0.1, 0.1]
    estimates = [_estimate(0, 0, c, r) for c, r in zip(conf, radius)]
    expected = [False, False, True, True, False, False, False, False, False, False]
    assert trusted_frames(estimates, params).tolist() == expected
    assert trusted_frames([_estimate(0, 0, 0.9, math.nan)] * 6, params).tolist() == [False] * 6


def test_place_spacing_is_the_median_nearest_neighbour_distance():
    positions = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [3.0, 0.0], [3.0, 2.0]])
    # places (0,0) (1,0) (3,0) (3,2): nearest 1, 1, 2, 2 -> median 1.5
    assert place_spacing(positions) == pytest.approx(1.5)


def test_a_new_look_becomes_an_appearance_at_the_place_and_a_gap_a_new_place():
    day = _day_map()
    rng = np.random.default_rng(1)
    night_look = rng.integers(0, 256, (8, *SHAPE), dtype=np.uint8)
    # frames 0-4 at place (0, 0), frame 4 the first trusted; 5 is 0.2 m off place (2, 1); 6 is 0.45 m
    # off (3, 2), within half the 1 m spacing: both belong to their places; 7 lies 4 m beyond the map: a gap.
    poses = _settled([(2.2, 1.0), (3.0, 2.45), (7.0, 1.0)])
    night = _night(day, night_look, poses)
    new, report = learn(day, night)
    assert len(day) == 12 and day.appearances is None  # the day map is unchanged
    assert report.trusted == 4 and report.first_trusted == 4 and report.places == 1
    # candidates: the frame nearest each place: (0,0) frame 4, (2,1) frame 5, (3,2) frame 6
    assert report.appearances == 3 and report.known == 0 and report.evicted == 0
    assert len(new) == 12 + 4
    learned = new.positions[12:]
    np.testing.assert_array_equal(learned[:3], [[0.0, 0.0], [2.0, 1.0], [3.0, 2.0]])  # at the places, exactly
    np.testing.assert_array_equal(learned[3], [7.0, 1.0])  # the gap's new place at the localizer's pose
    np.testing.assert_array_equal(new.images[12:15], night_look[[4, 5, 6]])
    assert new.names[12:] == ("night1/000004.png", "night1/000005.png", "night1/000006.png", "night1/000007.png")
    rec = new.appearances
    assert rec.night.tolist() == [0] * 12 + [1] * 4
    assert rec.origins("surveyed")[:1] == ["survey"] and rec.origins("surveyed")[-1] == "learned"
    np.testing.assert_array_equal(rec.time[12:], [3.0, 3.5, 4.0, 4.5])
    assert rec.nights[0].night == 1 and rec.nights[0].trusted == 4 and rec.nights[0].places == 1
    assert rec.day_fingerprint == day.fingerprint
    # the heat map groups an appearance with its place: one place more (the gap), not four
    assert len(np.unique(HeatMapper(new.positions).place_of_ref)) == 13
    # every trusted frame near a place counted one match for the place's best (only) appearance
    assert rec.matches[0] == 1 and rec.matches[6] == 1 and rec.matches[11] == 1 and rec.matches[12:].sum() == 0


def test_a_frame_between_places_gives_each_of_them_a_look():
    # a drive along y = 0 whose poses fall halfway between the 1 m places: (0.5, 0), (1.5, 0),
    # (2.5, 0) are 0.5 m from two places each. Within 0.75 spacings every place of the row gets a
    # look, its nearest frame's (the first of equals); within 0.4 (the poses' 0.5 m beyond it) none.
    day = _day_map()
    rng = np.random.default_rng(5)
    poses = _settled([(0.5, 0.0), (1.5, 0.0), (2.5, 0.0)])
    images = rng.integers(0, 256, (len(poses), *SHAPE), dtype=np.uint8)
    night = _night(day, images, poses)
    new, report = learn(day, night, LearningParams(attach_fraction=0.75))
    learned = {tuple(p): name for p, name in zip(new.positions[12:].tolist(), new.names[12:], strict=True)}
    # place (0, 0): frames 4 (0 m) -- the nearest; (1, 0): frames 5 and 6 at 0.5 m -- the first;
    # (2, 0): frames 6 and 7 -- the first; (3, 0): frame 7
    assert learned == {
        (0.0, 0.0): "night1/000004.png",
        (1.0, 0.0): "night1/000005.png",
        (2.0, 0.0): "night1/000006.png",
        (3.0, 0.0): "night1/000007.png",
    }
    assert report.appearances == 4 and report.places == 0
    # each frame counted one match at every place it belongs to: frame 6 at (1, 0) and (2, 0)
    assert new.appearances.matches[[1, 2]].tolist() == [2, 2]
    _, narrow = learn(day, night, LearningParams(attach_fraction=0.4))
    assert narrow.appearances == 1  # only place (0, 0), where frames 0-4 stand


def test_learning_the_same_night_again_adds_nothing():
    day = _day_map()
    rng = np.random.default_rng(2)
    poses = _settled([(x + 0.1, y) for x in range(4) for y in range(3)])
    images = rng.integers(0, 256, (len(poses), *SHAPE), dtype=np.uint8)
    once, first = learn(day, _night(day, images, poses))
    assert first.appearances == 12
    twice, second = learn(once, _night(once, images, poses))
    assert second.appearances == 0 and second.places == 0 and second.known == 12
    assert len(twice) == len(once) and second.growth == 0.0
    # the learned looks were the best match of their frames this time
    assert twice.appearances.matches[12:].sum() >= 12
    assert [n.night for n in twice.appearances.nights] == [1, 2]


def test_a_frame_like_the_day_image_is_known_and_not_learned():
    day = _day_map()
    images = np.repeat(day.images[:1], 6, axis=0)  # the day's own look of place (0, 0)
    new, report = learn(day, _night(day, images, [(0.0, 0.0)] * 6))
    assert report.known == 1 and report.appearances == 0 and len(new) == len(day)
    assert new.appearances.matches[0] == 2  # frames 4 and 5 (the settled ones) matched it


def test_the_cap_evicts_the_least_matched_learned_appearance_never_the_day_one():
    day = _day_map()
    rng = np.random.default_rng(3)
    params = LearningParams(max_learned=2)
    current = day
    looks = []
    for k in range(3):  # three nights, each a new look of place (1, 1)
        # night 1's look (black) is never the best match of later frames: it is the least useful
        look = np.zeros((1, *SHAPE), np.uint8) if k == 0 else rng.integers(0, 256, (1, *SHAPE), dtype=np.uint8)
        looks.append(look[0])
        images = np.repeat(look, 5, axis=0)
        current, report = learn(current, _night(current, images, [(1.0, 1.0)] * 5), params)
    rec = current.appearances
    at_place = np.flatnonzero((current.positions == (1.0, 1.0)).all(axis=1))
    assert rec.night[at_place].tolist() == [0, 2, 3]  # night 1's look was matched least (ties: oldest) and went
    assert report.evicted == 1 and current.appearances.nights[2].evicted == 1
    np.testing.assert_array_equal(current.images[at_place[1:]], looks[1:])


def test_a_night_that_never_settles_adds_nothing():
    day = _day_map()
    images = np.zeros((6, *SHAPE), np.uint8)
    new, report = learn(day, _night(day, images, [(0.0, 0.0)] * 6, confidence=0.3))
    assert new is day and report.trusted == 0 and report.first_trusted is None
    assert "learned nothing" in report.line() and "never settled" in report.line()


def test_a_night_of_another_map_or_camera_is_refused():
    day, other = _day_map(0), _day_map(5)
    night = _night(other, other.images[:6], [(0.0, 0.0)] * 6)
    with pytest.raises(MapFormatError, match="localized against another map"):
        learn(day, night)
    forward = dataclasses.replace(night, params=nightloc.PreparationParams(wrap=False), map_fingerprint=day.fingerprint)
    with pytest.raises(MapFormatError, match="other parameters"):
        learn(day, forward)


def test_experience_map_round_trips_as_format_4_and_a_day_map_stays_format_3(tmp_path):
    import json
    import zipfile

    day = _day_map()
    rng = np.random.default_rng(4)
    new, _ = learn(day, _night(day, rng.integers(0, 256, (6, *SHAPE), dtype=np.uint8), [(0.0, 0.0)] * 6))
    day_file, new_file = day.save(tmp_path / "day.map"), new.save(tmp_path / "new.map")
    for file, version in ((day_file, 3), (new_file, 4)):
        with zipfile.ZipFile(file) as archive:
            header = json.loads(np.load(archive.open("header.npy")).tobytes())
        assert header["format_version"] == version
    loaded = nightloc.ReferenceMap.load(new_file)
    assert loaded == new and isinstance(loaded.appearances, Appearances)
    assert loaded.appearances.nights == new.appearances.nights
    assert nightloc.ReferenceMap.load(day_file).appearances is None


def test_learning_params_are_checked():
    with pytest.raises(ValueError, match="attach_fraction"):
        LearningParams(attach_fraction=2.0, gap_fraction=1.0)
    with pytest.raises(ValueError, match="max_learned"):
        LearningParams(max_learned=0)


def test_a_damaged_experience_record_is_refused(tmp_path):
    import json

    day = _day_map()
    rng = np.random.default_rng(6)
    new, _ = learn(day, _night(day, rng.integers(0, 256, (6, *SHAPE), dtype=np.uint8), [(0.0, 0.0)] * 6))
    file = new.save(tmp_path / "new.map")
    with np.load(file) as archive:
        arrays = {name: archive[name] for name in archive.files}
    header = json.loads(arrays["header"].tobytes())
    header["experience"]["nights"] = []  # a learned appearance of night 1, but no night in the history
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    with open(tmp_path / "bad.map", "wb") as stream:
        np.savez(stream, **arrays)
    with pytest.raises(MapFormatError, match="night 1 but the history lists 0 nights"):
        nightloc.ReferenceMap.load(tmp_path / "bad.map")


def test_a_map_pickled_before_experience_maps_unpickles_as_a_day_map():
    import pickle

    day = _day_map()
    state = day.__getstate__()
    del state["_appearances"]
    old = object.__new__(nightloc.ReferenceMap)
    old.__setstate__(state)
    assert old.appearances is None and old == day
    assert pickle.loads(pickle.dumps(day)) == day


def test_the_backward_run_is_the_filter_over_the_reversed_drive():
    from nightloc.experience.learning import backward_estimates
    from nightloc.motion.odometry import true_robot_motions

    day = _day_map()
    path = np.array([[0.0, 0.0], [0.6, 0.2], [1.2, 0.5], [1.9, 0.9], [2.4, 1.4], [2.9, 2.0], [3.0, 2.0]])
    headings = np.arctan2(*np.diff(path, axis=0, prepend=[[-1.0, 0.0]]).T[::-1])
    nearest = [int(np.argmin(np.hypot(*(day.positions - p).T))) for p in path]
    images = day.images[nearest]
    motions = true_robot_motions(path, headings)
    back, predicted = backward_estimates(nightloc.Localizer(day, odometry_noise=1), images, motions)
    assert predicted[-1] is None and all(b.shape == (100, 100) for b in predicted[:-1])
    # the same filter driven along the path reversed, with that drive's own true motions
    reverse = nightloc.Localizer(day, odometry_noise=1)
    reversed_motions = true_robot_motions(path[::-1], headings[::-1])
    direct = [reverse.update(images[::-1][k], reversed_motions[k] if k else None) for k in range(len(path))][::-1]
    for a, b in zip(back, direct, strict=True):
        assert (a.x, a.y, a.confidence) == pytest.approx((b.x, b.y, b.confidence), abs=1e-6)


def _loop_drive(day: nightloc.ReferenceMap, frames: int) -> tuple[np.ndarray, list]:
    """``frames`` frames once round a loop through ``_day_map``'s places: the nearest place's
    image per frame and the drive's true robot-frame motions (the first unknown)."""
    from nightloc.motion.odometry import true_robot_motions

    t = np.linspace(0.0, 2 * np.pi, frames)
    path = np.column_stack([1.5 + 1.3 * np.cos(t), 1.0 + 0.9 * np.sin(t)])
    headings = np.arctan2(*np.diff(path, axis=0, prepend=path[-2:-1]).T[::-1])
    nearest = [int(np.argmin(np.hypot(*(day.positions - p).T))) for p in path]
    return day.images[nearest], [None, *true_robot_motions(path, headings)[1:]]


def test_a_long_night_recomputes_its_beliefs_from_bounded_checkpoints(monkeypatch):
    """A learner over its belief budget keeps the filter's state every few frames (fewer as the
    night grows) and smooths exactly as one that kept every belief (the oracle: the forward
    beliefs by hand, then backward_estimates and smoothed_estimates)."""
    from nightloc.experience import learning

    monkeypatch.setattr(learning, "CHECKPOINT_FRAMES", 2)
    monkeypatch.setattr(learning, "MAX_CHECKPOINTS", 3)
    day = _day_map()
    rng = np.random.default_rng(3)
    clean, motions = _loop_drive(day, 23)
    noise = rng.integers(-20, 21, clean.shape)
    images = np.clip(clean.astype(int) + noise, 0, 255).astype(np.uint8)

    forward = nightloc.Localizer(day, odometry_noise=1)
    beliefs = []
    for image, motion in zip(images, motions, strict=True):
        forward.update_table(forward.score_table(image, prepared=True), motion)
        beliefs.append(forward.belief)
    back, predicted = learning.backward_estimates(nightloc.Localizer(day, odometry_noise=1), images, motions)
    smoothed = learning.smoothed_estimates(nightloc.Localizer(day, odometry_noise=1), beliefs, predicted)

    kept = learning.NightLearner(day, nightloc.Localizer(day, odometry_noise=1))
    bounded = learning.NightLearner(day, nightloc.Localizer(day, odometry_noise=1), belief_budget=3 * beliefs[0].nbytes)
    for image, motion in zip(images, motions, strict=True):
        kept.step(image, motion, prepared=True)
        bounded.step(image, motion, prepared=True)
    assert kept._beliefs is not None and bounded._beliefs is None
    assert len(bounded._checkpoints) <= 3 and bounded._checkpoint_spacing == 8  # 2 -> 4 -> 8 frames
    for night in (kept.night(), bounded.night(), bounded.night()):
        assert night.backward == back and night.smoothed == smoothed
    assert len({(e.x, e.y) for e in smoothed}) > 5  # the night goes round: the smoother moves


def _moved_night(learner, images, motions, noise_changes: bool) -> None:
    """Steps ``learner`` through the frames, moving its localizer between frames as a node does:
    a wrong initial pose before frame 6, a relocalization before frame 13 and, with
    ``noise_changes``, noise model 3 for frames 9..19."""
    for k, (image, motion) in enumerate(zip(images, motions, strict=True)):
        if k == 6:
            learner.localizer.set_pose(3.0, 0.0, 0.0)  # a wrong initial pose: the night recovers
        if k == 13:
            learner.localizer.reset()
        if noise_changes:
            learner.localizer.noise = 3 if 9 <= k < 20 else 1
        learner.step(image, motion, prepared=True)


def test_a_bounded_learner_replays_what_moved_its_localizer_between_frames(monkeypatch):
    """A set pose, a reset and a new noise model between frames (the node's initial pose,
    relocalization and per-frame covariance) are in the recomputed beliefs as in the kept ones."""
    from nightloc.experience import learning

    monkeypatch.setattr(learning, "CHECKPOINT_FRAMES", 4)
    monkeypatch.setattr(learning, "MAX_CHECKPOINTS", 2)
    day = _day_map(1)
    images, motions = _loop_drive(day, 30)
    learners = [
        learning.NightLearner(day, nightloc.Localizer(day, odometry_noise=1)),
        learning.NightLearner(day, nightloc.Localizer(day, odometry_noise=1), belief_budget=0),
    ]
    for learner in learners:
        _moved_night(learner, images, motions, noise_changes=True)
    kept, bounded = learners
    pinned = [frame for frame, _, pin in bounded._checkpoints if pin]
    assert pinned == [6, 13] and bounded._checkpoint_spacing == 16
    a, b = kept.night(), bounded.night()
    assert a.smoothed == b.smoothed and a.backward == b.backward and a.estimates == b.estimates
    # the noise models are the frames' own: all at model 1 the smoother differs
    for learner in learners:
        assert learner.localizer.noise == nightloc.Localizer(day, odometry_noise=1).noise
    steady = learning.NightLearner(day, nightloc.Localizer(day, odometry_noise=1))
    _moved_night(steady, images, motions, noise_changes=False)
    assert steady.night().backward != a.backward


def test_a_learner_refuses_a_negative_belief_budget():
    with pytest.raises(ValueError, match="belief_budget"):
        nightloc.experience.learning.NightLearner(_day_map(), belief_budget=-1)


def test_a_night_is_trusted_both_ways_unless_the_runs_disagree():
    from nightloc.experience.learning import trust_night

    day = _day_map()
    params = LearningParams(settled_frames=3)
    night = _night(day, day.images[:8], [(1.0, 1.0)] * 8)
    unsure = _estimate(1.0, 1.0, confidence=0.2, radius=3.0)
    sure = _estimate(1.0, 1.0)
    forward = [unsure] * 3 + [sure] * 5  # the forward run settles at frame 5 (three in a row)
    backward = [sure] * 8
    backward[6] = _estimate(3.0, 2.0)  # confident, 2.2 m from the forward run's estimate
    one_way = dataclasses.replace(night, estimates=tuple(forward))
    assert trust_night(one_way, params, agree=1.0)[0].tolist() == [False] * 5 + [True] * 3
    both = dataclasses.replace(night, estimates=tuple(forward), backward=tuple(backward))
    trusted, chosen = trust_night(both, params, agree=1.0)
    # frames 0-2: trusted by the backward run alone (it settled going backwards); frame 6: the two
    # runs are both confident and 2.2 m apart; frames 4-5 and 7 are trusted by both
    assert trusted.tolist() == [True, True, True, True, True, True, False, True]
    assert chosen[0] is backward[0] and chosen[7] is forward[7]


def test_the_retention_policies_order_a_places_learned_looks():
    from nightloc.experience.learning import RETENTION_POLICIES

    # three looks: night 1 matched 5 times, night 2 matched once, night 4 matched 3 times; tonight is night 6
    record = Appearances(
        night=[0, 1, 2, 4], confidence=[0, 0.9, 0.95, 0.9], time=[0.0] * 4, matches=[9, 5, 1, 3],
        nights=tuple(LearnedNight(k, f"n{k}", "2026-01-01T00:00:00Z", 1, 1, 1, 0, 0) for k in (1, 2, 3, 4, 5)),
    )  # fmt: skip
    matches = record.matches
    looks = [1, 2, 3]
    assert RETENTION_POLICIES["usage"].order(looks, record, matches, 6) == [2, 3, 1]  # 1, 3, 5 matches
    assert RETENTION_POLICIES["recency"].order(looks, record, matches, 6) == [1, 2, 3]  # nights 1, 2, 4
    # matches per night since learned: 5 / 5 = 1.0, 1 / 4 = 0.25, 3 / 2 = 1.5
    assert RETENTION_POLICIES["usage_rate"].order(looks, record, matches, 6) == [2, 1, 3]
    with pytest.raises(ValueError, match="retention must be one of usage, recency, usage_rate"):
        LearningParams(retention="newest")


def test_a_night_unlike_every_learned_look_is_not_learned():
    day, poses, looks, once, rng = _learned_once(8)
    # the same places again, their frames a little noisier: they match the learned looks
    noisy = np.clip(looks.astype(int) + rng.integers(-8, 9, looks.shape), 0, 255).astype(np.uint8)
    again = _night(once, noisy, poses)
    _, report = learn(once, again)
    assert not report.refused
    # another garden: frames at the same estimated poses that match no learned look
    foreign = _night(once, rng.integers(0, 256, looks.shape, dtype=np.uint8), poses)
    same, report = learn(once, foreign)
    assert same is once and report.appearances == 0 and report.trusted > 0
    assert "not a night of this map's places" in report.line() and "max_look_ratio 0.85" in report.line()
    # a map without learned looks has no such check: the day map learns the foreign night
    assert learn(day, _night(day, foreign.images, poses))[1].appearances > 0


def test_a_night_whose_frames_match_looks_of_other_places_is_not_learned():
    _, poses, _, once, _ = _learned_once(9)
    look_at = {tuple(p): once.images[i] for i, p in enumerate(once.positions.tolist()) if once.appearances.night[i]}
    # every frame shows the learned look of a place two metres and one row away (not a
    # neighbour): its best learned look is never at or beside its place
    elsewhere = np.stack([look_at[((round(x) + 2) % 4, (round(y) + 1) % 3)] for x, y in poses]).astype(np.uint8)
    lenient = LearningParams(max_look_ratio=10.0)  # the ratio check out of the way
    same, report = learn(once, _night(once, elsewhere, poses), lenient)
    assert same is once and report.appearances == 0 and report.trusted > 0
    assert "only 0% of its frames" in report.line() and "min_look_hits 0.8" in report.line()
    # the same frames at the places whose looks they show: every best look is at its place
    moved = [((round(x) + 2) % 4 + 0.1, (round(y) + 1) % 3) for x, y in poses]
    _, report = learn(once, _night(once, elsewhere, moved), lenient)
    assert not report.refused
