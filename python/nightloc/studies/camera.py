"""The camera study: matching resolution x night darkness x sensor pixel -> localization error.

For one synthetic world (:mod:`nightloc.synth`) the study renders every night traverse once as
noiseless scene radiance (the world's full panorama, 192 x 96), then for each darkness level,
sensor and noise draw exposes it with :func:`~nightloc.synth.sensor.capture` (shot noise, read
noise, quantization and tone curve of that pixel), prepares the frames at every matching
resolution (the preparation's ``width`` x ``height``: area binning of the full frame) and
localizes them against the day map of that resolution (built once per world) with the paper's
sequence matching and the grid Bayes filter (:func:`nightloc.localization.evaluation.evaluate`,
simulated map-frame odometry of one Table III noise model, a fresh draw per noise draw).

A sensor is a pixel: its full well (electrons) and read noise (electrons rms). A pixel of ``a``
times the area holds ``a`` times the electrons and collects ``a`` times the photons, so each
sensor meters a scene to 18 % of its own well and ``darkness`` d leaves it ``10**(-2d)`` of those
electrons (:func:`~nightloc.synth.sensor.metered_exposure`); the larger well then means fewer
relative shot noise and read noise. The day map is taken with the world's default camera.

The patch-normalization window spans the same angle at every resolution: radius
``round(4 * width / 48)`` pixels, at least 1 (the paper's P = 4 at 48 x 24).

Per cell (resolution, darkness, sensor, method) the errors of every query frame from the
``seq_len``-th on (earlier frames have no full sequence and the filter has seen little), over
every draw, give the median, p95, share of frames over 1 m, the longest run of consecutive
frames over 1 m (:func:`~nightloc.localization.tail.tail_metrics`), and the spread of the per-draw
medians (their standard deviation).
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Union

import numpy as np

from ..io.atomic import atomic_file
from ..localization.evaluation import EvaluationSettings, QueryMatches, evaluate
from ..localization.localizer import LocalizationParams
from ..localization.tail import tail_metrics
from ..mapping.reference_map import ReferenceMap
from ..matching.sad import MatchResult, difference_matrix, rotational_sad, shifts_to_headings
from ..motion.odometry import noise_model
from ..preparation.params import PreparationParams
from ..preparation.preparer import Preparer
from ..progress import progress
from ..synth.dataset import SynthScene
from ..synth.paths import TraversePlan, plan_traverses
from ..synth.render import render_radiance
from ..synth.sensor import FULL_WELL, MAX_DARKNESS, READ_NOISE, capture
from ..synth.world import ALL_WORLDS

__all__ = [
    "CSV_HEADER",
    "DEFAULT_DARKNESS_LEVELS",
    "DEFAULT_SENSORS",
    "DEFAULT_SIZES",
    "REFERENCE_PITCH_UM",
    "CameraStudy",
    "Sensor",
    "StudyRow",
    "StudySettings",
    "run_camera_study",
]

PathLike = Union[str, "os.PathLike[str]"]

#: Pixel pitch (micrometres) of the synthetic worlds' default sensor (:data:`~nightloc.synth.sensor.FULL_WELL`
#: electrons): a typical small CMOS pixel. Other wells give ``pitch = 2 um * sqrt(well / FULL_WELL)``.
REFERENCE_PITCH_UM = 2.0


@dataclass(frozen=True)
class Sensor:
    """One camera pixel.

    Attributes:
        full_well: electrons a pixel holds (the brightest output level).
        read_noise: rms read noise, electrons.
    """

    full_well: float = FULL_WELL
    read_noise: float = READ_NOISE

    def __post_init__(self) -> None:
        if not (math.isfinite(self.full_well) and 10.0 <= self.full_well <= 1e7):
            raise ValueError(f"a sensor's full well must be 10..1e7 electrons, got {self.full_well!r}")
        if not (math.isfinite(self.read_noise) and 0.0 <= self.read_noise <= 1000.0):
            raise ValueError(f"a sensor's read noise must be 0..1000 electrons rms, got {self.read_noise!r}")

    @property
    def pitch_um(self) -> float:
        """Pixel pitch in micrometres at the reference sensor's well density."""
        return REFERENCE_PITCH_UM * math.sqrt(self.full_well / FULL_WELL)

    @property
    def label(self) -> str:
        """e.g. ``"4.0 um, 16000 e-, 3 e- read"``."""
        return f"{self.pitch_um:.1f} um, {self.full_well:.0f} e-, {self.read_noise:g} e- read"


#: Matching resolutions (width, height): 72 to 4 608 pixels; the paper's 48 x 24 among them.
DEFAULT_SIZES: tuple[tuple[int, int], ...] = ((12, 6), (16, 8), (24, 12), (32, 16), (48, 24), (64, 32), (96, 48))
#: Night darkness levels (0 = night lighting exposed like day; each step of 1: 100x fewer photons).
DEFAULT_DARKNESS_LEVELS: tuple[float, ...] = (0.0, 1.0, 1.5, 2.0, 2.5, MAX_DARKNESS)
#: Pixels from a small phone pixel to a large full-frame one (1, 2, 4 and 8 um), with typical read
#: noise at high gain (a large low-light sensor reads out with fewer electrons of noise).
DEFAULT_SENSORS: tuple[Sensor, ...] = (
    Sensor(1000.0, 1.5),
    Sensor(4000.0, 2.5),
    Sensor(16000.0, 2.5),
    Sensor(64000.0, 2.0),
)


@dataclass(frozen=True)
class StudySettings:
    """The study's grid and how each cell is localized.

    Attributes:
        sizes: matching resolutions ``(width, height)`` in pixels.
        darkness: night darkness levels in [0, :data:`~nightloc.synth.sensor.MAX_DARKNESS`].
        sensors: the pixels compared.
        draws: independent draws of sensor noise and odometry noise per cell.
        seed: the world's seed (textures, sun, paths) and of every noise draw.
        seq_len: the paper's sequence length n; the first ``seq_len - 1`` frames of a query are
            left out of the statistics.
        noise_model: the Table III odometry noise model both methods are given.
        methods: ``"paper"`` and/or ``"filter"``.
    """

    sizes: tuple[tuple[int, int], ...] = DEFAULT_SIZES
    darkness: tuple[float, ...] = DEFAULT_DARKNESS_LEVELS
    sensors: tuple[Sensor, ...] = DEFAULT_SENSORS
    draws: int = 5
    seed: int = 0
    seq_len: int = 7
    noise_model: int = 1
    methods: tuple[str, ...] = ("paper", "filter")

    def __post_init__(self) -> None:
        sizes = tuple((int(w), int(h)) for w, h in self.sizes)
        if not sizes or len(set(sizes)) != len(sizes):
            raise ValueError(f"sizes must be distinct (width, height) pairs, at least one, got {self.sizes!r}")
        for w, h in sizes:
            if not (4 <= w <= 192 and 2 <= h <= 96):
                raise ValueError(
                    f"matching size {w}x{h} is out of range: width 4..192 and height 2..96 pixels (the rendered "
                    f"panorama is 192x96)"
                )
        object.__setattr__(self, "sizes", tuple(sorted(sizes, key=lambda s: (s[0] * s[1], s))))
        levels = tuple(sorted({float(d) for d in self.darkness}))
        if not levels or any(not (math.isfinite(d) and 0.0 <= d <= MAX_DARKNESS) for d in levels):
            raise ValueError(
                f"darkness levels must be numbers in [0, {MAX_DARKNESS:g}], at least one, got {self.darkness!r}"
            )
        object.__setattr__(self, "darkness", levels)
        if not self.sensors or not all(isinstance(s, Sensor) for s in self.sensors):
            raise ValueError("sensors must be at least one Sensor")
        if len(set(self.sensors)) != len(self.sensors):
            raise ValueError("sensors must not repeat")
        for name, value, low, high in (("draws", self.draws, 1, 100), ("seq_len", self.seq_len, 1, 10)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
                raise ValueError(f"{name} must be an int in {low}..{high}, got {value!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f"seed must be an int >= 0, got {self.seed!r}")
        noise_model(self.noise_model)
        methods = tuple(dict.fromkeys(self.methods))
        if not methods or any(m not in ("paper", "filter") for m in methods):
            raise ValueError(f"methods must be among 'paper', 'filter', got {self.methods!r}")
        object.__setattr__(self, "methods", methods)

    @property
    def cells(self) -> int:
        """Rows of the study's table."""
        return len(self.sizes) * len(self.darkness) * len(self.sensors) * len(self.methods)


#: A method is lost at a light level and sensor when even its best resolution errs over 1 m on
#: more than this share of the frames (or has a median over 1 m): a robot that loses its track
#: that often cannot drive on the estimate, however good its typical frame.
LOST_SHARE_OVER_1M = 0.4

#: Columns of ``camera_study.csv``.
CSV_HEADER: tuple[str, ...] = (
    "width",
    "height",
    "pixels",
    "darkness",
    "full_well_e",
    "read_noise_e",
    "pixel_pitch_um",
    "method",
    "median_m",
    "p95_m",
    "share_over_1m",
    "longest_over_1m",
    "median_spread_m",
    "frames",
    "draws",
)


@dataclass(frozen=True)
class StudyRow:
    """One cell of the study: the error statistics of one (resolution, darkness, sensor, method).

    ``median_m``, ``p95_m``: metres over all frames and draws; ``share_over_1m``: fraction of
    frames more than 1 m off; ``longest_over_1m``: the longest run of consecutive frames over
    1 m in any query and draw; ``median_spread_m``: standard deviation of the per-draw medians;
    ``frames``: errors pooled (frames x draws).
    """

    width: int
    height: int
    darkness: float
    sensor: Sensor
    method: str
    median_m: float
    p95_m: float
    share_over_1m: float
    longest_over_1m: int
    median_spread_m: float
    frames: int
    draws: int

    @property
    def pixels(self) -> int:
        return self.width * self.height

    def csv_row(self) -> list[str]:
        return [
            str(self.width),
            str(self.height),
            str(self.pixels),
            f"{self.darkness:g}",
            f"{self.sensor.full_well:g}",
            f"{self.sensor.read_noise:g}",
            f"{self.sensor.pitch_um:.2f}",
            self.method,
            f"{self.median_m:.4f}",
            f"{self.p95_m:.4f}",
            f"{self.share_over_1m:.4f}",
            str(self.longest_over_1m),
            f"{self.median_spread_m:.4f}",
            str(self.frames),
            str(self.draws),
        ]


@dataclass
class CameraStudy:
    """The study's result: its settings, world and one :class:`StudyRow` per cell."""

    world: str
    settings: StudySettings
    rows: list[StudyRow] = field(default_factory=list)

    def row(self, width: int, height: int, darkness: float, sensor: Sensor, method: str) -> StudyRow:
        """The cell's row (KeyError when the study has no such cell)."""
        for r in self.rows:
            if (r.width, r.height, r.darkness, r.sensor, r.method) == (width, height, darkness, sensor, method):
                return r
        raise KeyError(f"no cell {width}x{height}, darkness {darkness}, {sensor.label}, {method}")

    def smallest_within(self, darkness: float, sensor: Sensor, method: str, tolerance: float = 0.10) -> StudyRow:
        """The fewest-pixel resolution whose median is within ``tolerance`` (a fraction) of the best
        resolution's median at this darkness, sensor and method."""
        cells = self.cells(darkness, sensor, method)
        if not cells:
            raise KeyError(f"no cells at darkness {darkness}, {sensor.label}, {method}")
        best = min(r.median_m for r in cells)
        good = [r for r in cells if r.median_m <= best * (1.0 + tolerance)]
        return min(good, key=lambda r: (r.pixels, r.median_m))

    def write_csv(self, path: PathLike) -> Path:
        """Writes ``camera_study.csv`` (header :data:`CSV_HEADER`) atomically."""
        with atomic_file(path, "w", newline="") as stream:
            writer = csv.writer(stream, lineterminator="\n")
            writer.writerow(CSV_HEADER)
            for r in self.rows:
                writer.writerow(r.csv_row())
        return Path(path)

    def cells(self, darkness: float, sensor: Sensor, method: str) -> list[StudyRow]:
        """Every resolution's row at this darkness, sensor and method."""
        return [r for r in self.rows if (r.darkness, r.sensor, r.method) == (darkness, sensor, method)]

    def lost(self, darkness: float, sensor: Sensor, method: str) -> bool:
        """True when ``method`` is lost at this darkness and sensor at every resolution: a median
        over 1 m, or more than :data:`LOST_SHARE_OVER_1M` of the frames over 1 m."""
        return all(
            r.median_m > 1.0 or r.share_over_1m > LOST_SHARE_OVER_1M for r in self.cells(darkness, sensor, method)
        )

    def summary_lines(self, tolerance: float = 0.10) -> list[str]:
        """Per darkness level and sensor: the smallest resolution within ``tolerance`` of the best,
        per method (the paper's "about 1000 pixels" as a number on this world), and the methods
        lost at every resolution (:meth:`lost`)."""
        lines = []
        for darkness in self.settings.darkness:
            for sensor in self.settings.sensors:
                parts = []
                for method in self.settings.methods:
                    cells = self.cells(darkness, sensor, method)
                    small = self.smallest_within(darkness, sensor, method, tolerance)
                    best = min(cells, key=lambda r: r.median_m)
                    lost = ""
                    if self.lost(darkness, sensor, method):
                        fewest = min(r.share_over_1m for r in cells)
                        lost = f"; LOST: {fewest:.0%} or more of the frames over 1 m at every resolution"
                    parts.append(
                        f"{method} {small.width}x{small.height} ({small.pixels} px, {small.median_m:.2f} m; best "
                        f"{best.median_m:.2f} m at {best.width}x{best.height}{lost})"
                    )
                lines.append(f"darkness {darkness:g}, {sensor.label}: " + "; ".join(parts))
        return lines


def patch_radius(width: int) -> int:
    """Patch-normalization radius at ``width`` columns: the paper's 4 at 48, same angle elsewhere."""
    return max(1, round(4 * width / 48))


def _matches(
    ref_map: ReferenceMap,
    prepared: np.ndarray,
    positions: np.ndarray,
    headings: np.ndarray,
    name: str,
    threads: int | None,
    tables: bool,
) -> QueryMatches:
    """A prepared night drive matched against ``ref_map`` (a 360-degree panorama map)."""
    width = ref_map.params.width
    scores, shifts = difference_matrix(prepared, ref_map.images, threads=threads)
    results = tuple(
        MatchResult(int(np.argmin(scores[i])), scores[i], shifts[i], shifts_to_headings(shifts[i], width), width)
        for i in range(len(prepared))
    )
    table_array = np.stack([rotational_sad(q, ref_map.images, threads=threads) for q in prepared]) if tables else None
    return QueryMatches(
        name=name,
        images=tuple(f"{i:06d}" for i in range(len(prepared))),
        positions=positions,
        headings=headings,
        results=results,
        tables=table_array,
    )


def _day_maps(
    scene: SynthScene, day: TraversePlan, day_frames: np.ndarray, settings: StudySettings
) -> tuple[dict[tuple[int, int], Preparer], dict[tuple[int, int], ReferenceMap]]:
    """Per image size ``(width, height)`` its preparer and the day map prepared with it."""
    preparers = {
        size: Preparer(PreparationParams(width=size[0], height=size[1], radius=patch_radius(size[0])))
        for size in settings.sizes
    }
    maps = {
        size: ReferenceMap(
            preparer.prepare(day_frames),
            day.positions,
            day.headings,
            params=preparer.params,
            frame_size=(scene.camera.width, scene.camera.height),
        )
        for size, preparer in preparers.items()
    }
    return preparers, maps


def _study(world: str, settings: StudySettings, errors: dict[tuple, list[list[np.ndarray]]]) -> CameraStudy:
    """The study's rows: per size, darkness, sensor and method the tail of the errors over every
    draw (``errors[(size, darkness index, sensor index, method)]``: per draw, one array per night)."""
    study = CameraStudy(world, settings)
    for size in settings.sizes:
        for d_index, darkness in enumerate(settings.darkness):
            for s_index, sensor in enumerate(settings.sensors):
                for method in settings.methods:
                    per_draw = errors[(size, d_index, s_index, method)]
                    tail = tail_metrics([e for draw in per_draw for e in draw], first_frame=settings.seq_len)
                    medians = [tail_metrics(draw, first_frame=settings.seq_len).median_m for draw in per_draw]
                    study.rows.append(
                        StudyRow(
                            width=size[0],
                            height=size[1],
                            darkness=darkness,
                            sensor=sensor,
                            method=method,
                            median_m=tail.median_m,
                            p95_m=tail.p95_m,
                            share_over_1m=tail.share_over_1m,
                            longest_over_1m=tail.longest_run_over_1m,
                            median_spread_m=float(np.std(medians)),
                            frames=tail.n,
                            draws=settings.draws,
                        )
                    )
    return study


def run_camera_study(
    world: str,
    settings: StudySettings | None = None,
    threads: int | None = None,
    progress_desc: str | None = None,
) -> CameraStudy:
    """Runs the study on ``world`` (``"garden"``, ``"living_room"`` or ``"large_garden"``).

    Every night traverse of the world is a query; each (darkness, sensor, draw) exposes their
    radiance once, and every resolution is prepared from those frames.
    """
    if world not in ALL_WORLDS:
        raise ValueError(f"unknown world {world!r}; choose one of {', '.join(ALL_WORLDS)}")
    settings = settings or StudySettings()
    scene = SynthScene(world, settings.seed)
    plans = plan_traverses(world, settings.seed)
    day = next(p for p in plans if p.name == "day_reference")
    nights = [p for p in plans if p.condition == "night"]
    day_frames = np.stack(list(scene.render_plan(day, threads)))
    night_light = scene.lighting["night"]
    radiance = {
        p.name: [
            render_radiance(scene.world, night_light, float(x), float(y), float(h), scene.camera)
            for (x, y), h in zip(p.positions, p.headings)
        ]
        for p in nights
    }
    preparers, maps = _day_maps(scene, day, day_frames, settings)
    params = LocalizationParams(seq_len=settings.seq_len)
    errors: dict[tuple, list[list[np.ndarray]]] = {}
    jobs = [
        (d_index, s_index, draw)
        for d_index in range(len(settings.darkness))
        for s_index in range(len(settings.sensors))
        for draw in range(settings.draws)
    ]
    desc = progress_desc or f"camera study {world}"
    for d_index, s_index, draw in progress(jobs, total=len(jobs), desc=desc, unit="night"):
        darkness, sensor = settings.darkness[d_index], settings.sensors[s_index]
        exposure = scene.night_exposure(darkness, sensor.full_well, sensor.read_noise)
        odometry_settings = EvaluationSettings(
            seq_lengths=(settings.seq_len,),
            noise_models=(settings.noise_model,),
            interpolation=(True,),
            repeats=1,
            seed=settings.seed * 1000 + draw,
            methods=settings.methods,
        )
        for plan in nights:
            frames = np.stack(
                [
                    capture(
                        rad,
                        exposure,
                        np.random.default_rng([settings.seed, 11, d_index, s_index, draw, nights.index(plan), i]),
                    )
                    for i, rad in enumerate(radiance[plan.name])
                ]
            )
            for size, preparer in preparers.items():
                matches = _matches(
                    maps[size],
                    preparer.prepare(frames),
                    np.asarray(plan.positions, dtype=np.float64),
                    np.asarray(plan.headings, dtype=np.float64),
                    plan.name,
                    threads,
                    "filter" in settings.methods,
                )
                evaluation = evaluate(maps[size], matches, odometry_settings, params)
                for method in settings.methods:
                    (e,) = evaluation.runs(evaluation.select(method=method))
                    per_draw = errors.setdefault((size, d_index, s_index, method), [[] for _ in range(settings.draws)])
                    per_draw[draw].append(e)
    return _study(world, settings, errors)


def sizes_from_text(text: str) -> tuple[tuple[int, int], ...]:
    """``"12x6,48x24"`` -> ``((12, 6), (48, 24))``; a clear ValueError otherwise."""
    sizes = []
    for part in text.split(","):
        pieces = part.strip().lower().split("x")
        if len(pieces) != 2 or not all(p.strip().isdigit() for p in pieces):
            raise ValueError(f"sizes must be WIDTHxHEIGHT pairs separated by commas, e.g. 12x6,48x24, got {text!r}")
        sizes.append((int(pieces[0]), int(pieces[1])))
    return tuple(sizes)


def sensors_from_text(text: str) -> tuple[Sensor, ...]:
    """``"4000:2.5,64000:5"`` (full well electrons : read noise electrons) -> Sensors."""
    sensors = []
    for part in text.split(","):
        pieces = part.strip().split(":")
        try:
            if len(pieces) != 2:
                raise ValueError
            sensors.append(Sensor(float(pieces[0]), float(pieces[1])))
        except ValueError as error:
            detail = f" ({error})" if str(error) else ""
            raise ValueError(
                f"sensors must be FULL_WELL:READ_NOISE pairs in electrons separated by commas, e.g. 4000:2.5,64000:5, "
                f"got {text!r}{detail}"
            ) from None
    return tuple(sensors)


def numbers_from_text(text: str, name: str) -> tuple[float, ...]:
    """``"0,1,2.5"`` -> ``(0.0, 1.0, 2.5)``; a ValueError naming ``name`` otherwise."""
    try:
        return tuple(float(p) for p in text.split(","))
    except ValueError:
        raise ValueError(f"{name} must be numbers separated by commas, e.g. 0,1,2, got {text!r}") from None
