"""The season study (nightloc.studies.season) on a tiny rendered season: its records against the
localizer and the learning run directly, the CSV, the summary and the figure."""

from __future__ import annotations

import math

import numpy as np
import pytest

import nightloc
from nightloc.experience.learning import learn, localize_night
from nightloc.figures.season import season_figure
from nightloc.localization.tail import tail_metrics
from nightloc.motion.odometry import traverse_odometry
from nightloc.studies.season import SeasonSettings, read_csv, run_season, season_summary, write_csv
from nightloc.synth import Camera, make_dataset


@pytest.fixture(scope="module")
def season(tmp_path_factory):
    """Four garden nights at 48 x 24, a test drive every second night, night 3 in another garden."""
    out = tmp_path_factory.mktemp("season") / "garden"
    make_dataset(
        "garden", out, seed=2, camera=Camera(48, 24), threads=1, season=4, test_every=2, bad_nights="3:other_garden"
    )
    return out


@pytest.fixture(scope="module")
def records(season):
    return run_season(season, SeasonSettings(odometry=("wheel", "robot1"), draws=1))


def _direct(ref_map, folder):
    """The drive localized as ``localize --learn`` does it, with its own wheel odometry."""
    log = nightloc.load_traverse(folder)
    run = localize_night(
        ref_map,
        (log.read(i) for i in range(len(log))),
        traverse_odometry(log),
        nightloc.Localizer(ref_map),
        names=log.names,
        timestamps=log.timestamps,
    )
    xy = np.array([[e.x, e.y] for e in run.estimates])
    return run, tail_metrics(np.hypot(*(xy - log.positions).T))


def test_the_wheel_chain_is_localize_learn_night_after_night(season, records):
    day = nightloc.ReferenceMap.build(season / "day_reference")
    wheel = [r for r in records if r.odometry == "wheel"]
    current = day
    for night in (1, 2):
        run, tail = _direct(current, season / f"season_{night:03d}")
        row = next(r for r in wheel if (r.night, r.drive, r.map) == (night, "learn", "learned"))
        assert row.references == len(current) and row.median_m == pytest.approx(tail.median_m)
        assert row.p95_m == pytest.approx(tail.p95_m) and row.frames == len(run.estimates)
        current, report = learn(current, run)
        assert (row.trusted, row.added, row.new_places, row.evicted) == (
            report.trusted,
            report.appearances,
            report.places,
            report.evicted,
        )
        day_row = next(r for r in wheel if (r.night, r.drive, r.map) == (night, "learn", "day"))
        assert day_row.median_m == pytest.approx(_direct(day, season / f"season_{night:03d}")[1].median_m)
    # the test drive of night 2 against the map that learned night 1 only (before tonight's learning)
    test = next(r for r in wheel if (r.night, r.drive, r.map) == (2, "test", "learned"))
    learned_once = next(r for r in wheel if (r.night, r.drive, r.map) == (2, "learn", "learned"))
    assert test.references == learned_once.references


def test_a_night_in_another_garden_has_no_error_and_counts_what_it_adds_as_wrong(records):
    foreign = [r for r in records if r.night == 3]
    assert foreign and all(r.bad == "other_garden" and math.isnan(r.median_m) for r in foreign)
    for r in foreign:
        if r.map == "learned":
            assert r.wrong == r.added + r.new_places
    assert not any(r.drive == "test" for r in foreign)  # a bad night has no test drive


def test_the_records_round_trip_through_the_csv_and_sum_up(records, tmp_path):
    path = write_csv(records, tmp_path / "season.csv")
    back = read_csv(path)
    assert len(back) == len(records)
    for a, b in zip(back, records, strict=True):
        for field in ("night", "odometry", "drive", "map", "references", "added", "bad"):
            assert getattr(a, field) == getattr(b, field)
        assert a.median_m == pytest.approx(b.median_m, rel=1e-5, nan_ok=True)
    summary = season_summary(records, first_test_night=2)
    assert set(summary) == {"wheel", "robot1"}
    wheel = summary["wheel"]
    tests = [r for r in records if (r.odometry, r.drive, r.night) == ("wheel", "test", 4)]
    day, learned = (next(r for r in tests if r.map == m) for m in ("day", "learned"))
    assert wheel["median_excess_m"] >= learned.median_m - day.median_m - 1e-12
    last = max(
        (r for r in records if (r.odometry, r.drive, r.map) == ("wheel", "learn", "learned")), key=lambda r: r.night
    )
    assert wheel["growth"][0]["references"] == last.references + last.added + last.new_places - last.evicted
    fig = season_figure(back, "tiny season", tmp_path / "season.png")
    assert (tmp_path / "season.png").stat().st_size > 0 and len(fig.axes) == 4


def test_the_settings_are_checked(season):
    with pytest.raises(ValueError, match=r"wheel or robot0\.\.robot3"):
        SeasonSettings(odometry=("map1",))
    with pytest.raises(ValueError, match="not a season dataset"):
        run_season(season / "day_reference")
