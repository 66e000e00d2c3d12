"""The live node: a ROS 2 participant over DDS (cyclonedds, no ROS install) around a
:class:`~nightloc.node.runner.FrameLocalizer`.

Two threads. The **receiver** (the caller's, :meth:`Node.spin`) waits on the readers and takes
what arrives: odometry and TF samples into the :class:`~nightloc.node.sync.OdometrySync`,
``initialpose`` and relocalize requests into a short queue, and camera frames into a slot of
one: a frame that arrives while another waits replaces it (**latest wins**; the replaced one is
counted as dropped), so a slow CPU drops frames and never queues them. The **worker** takes the
slot's frame once the odometry has reached its stamp (or ``odometry_wait`` seconds have passed),
localizes it and publishes the pose, ``map -> odom`` while converged, the belief at its rate and
the status.

Bad input (an undecodable or wrongly sized frame, a stamp going back, a frame without odometry
within the tolerance, an ``initialpose`` in another frame) is one log line (repeats of the same
complaint at most every few seconds, counted) and the node goes on.
"""

from __future__ import annotations

import math
import re
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import DatasetError
from ..io.bag import decode_image, quaternion_yaw, stamp_seconds
from . import build
from .conventions import DEFAULT_FRAMES, TOPICS, BeliefRaster, map_to_odom
from .record import FrameRecord, NightRecorder
from .runner import FrameLocalizer
from .sync import OdometrySync

__all__ = ["Node", "NodeSettings", "NodeStats"]

#: Seconds between two log lines of the same complaint.
COMPLAINT_INTERVAL_S = 5.0
#: Latencies kept for the status' percentiles.
LATENCY_WINDOW = 1000
#: Seconds the node waits at shutdown for its subscribers to acknowledge the last messages.
FLUSH_TIMEOUT_S = 2.0


@dataclass
class NodeSettings:
    """How the node is wired (``nightloc node``'s options).

    Attributes:
        topics: role -> topic name (:data:`~nightloc.node.conventions.TOPICS`' roles; missing roles
            take their default).
        compressed: the camera topic carries ``CompressedImage`` (else ``Image``).
        odometry: ``"topic"`` (``nav_msgs/Odometry``), ``"tf"`` (``odom -> base`` on the TF topic) or
            ``"none"`` (every motion unknown).
        frames: the map, odom and base frame names.
        noise: the odometry noise: None (the localizer's), or ``"covariance"`` (each step's from
            the message's twist covariance; all zeros: the localizer's).
        sync_tolerance: seconds between a frame and the nearest odometry sample at most.
        odometry_wait: seconds a frame waits for the odometry to reach its stamp.
        transform_tolerance: seconds ``map -> odom`` is post-dated by.
        belief_rate: belief messages per second (0: none).
        domain_id: the DDS domain (ROS_DOMAIN_ID).
    """

    topics: dict[str, str] = field(default_factory=dict)
    compressed: bool = False
    odometry: str = "topic"
    frames: tuple[str, str, str] = DEFAULT_FRAMES
    noise: str | None = None
    sync_tolerance: float = 0.25
    odometry_wait: float = 0.2
    transform_tolerance: float = 1.0
    belief_rate: float = 1.0
    domain_id: int = 0

    def topic(self, role: str) -> str:
        return self.topics.get(role) or next(spec.default for spec in TOPICS if spec.role == role)


@dataclass
class NodeStats:
    """Counts since the start: frames received, localized, dropped (replaced while waiting) and
    skipped (bad input); latencies (s) from a frame's arrival to its pose, the last
    :data:`LATENCY_WINDOW`."""

    received: int = 0
    processed: int = 0
    dropped: int = 0
    skipped: int = 0
    latencies: deque = field(default_factory=lambda: deque(maxlen=LATENCY_WINDOW))

    def latency(self, q: float) -> float:
        """The ``q``-quantile (0..1) of the kept latencies, seconds (NaN before the first)."""
        return float(np.quantile(np.fromiter(self.latencies, float), q)) if self.latencies else math.nan


class _Complaints:
    """One log line per kind of complaint every :data:`COMPLAINT_INTERVAL_S` seconds, counting the rest."""

    def __init__(self, log: Callable[[str], None]):
        self.log = log
        self._last: dict[str, float] = {}
        self._quiet: dict[str, int] = {}

    def __call__(self, kind: str, line: str) -> None:
        kind = f"{kind}: {re.sub(r'[0-9.]+', '#', line)}"  # the same complaint about another frame or time
        now = time.monotonic()
        if now - self._last.get(kind, -math.inf) < COMPLAINT_INTERVAL_S:
            self._quiet[kind] = self._quiet.get(kind, 0) + 1
            return
        quiet = self._quiet.pop(kind, 0)
        self._last[kind] = now
        self.log(line + (f" ({quiet} more like it since the last line)" if quiet else ""))


@dataclass
class _Frame:
    message: Any
    msgtype: str
    arrival: float
    index: int


class Node:
    """The participant: readers and writers for :data:`~nightloc.node.conventions.TOPICS`, the
    worker thread, the counts. :meth:`spin` runs until :meth:`stop`.

    Args:
        runner: the localizer, frame by frame.
        settings: the wiring.
        log: where log lines go (one line each).
        recorder: a bag the localized frames are also written to, or None.
    """

    def __init__(
        self,
        runner: FrameLocalizer,
        settings: NodeSettings,
        log: Callable[[str], None],
        recorder: NightRecorder | None = None,
    ):
        self.runner = runner
        self.settings = settings
        self.log = log
        self.complain = _Complaints(log)
        self.recorder = recorder
        self.stats = NodeStats()
        self.sync = OdometrySync(settings.sync_tolerance)
        self.raster = BeliefRaster(runner.localizer.grid)
        self._lock = threading.Condition()
        self._slot: _Frame | None = None
        self._commands: deque[tuple[str, Any]] = deque(maxlen=16)
        self._stop = threading.Event()
        self._last_stamp: float | None = None
        self._last_belief = -math.inf
        #: The odometry noise when a message's covariance is all zeros (``noise="covariance"``).
        self.base_noise = runner.localizer.noise
        self._dds()
        self._worker = threading.Thread(target=self._work, name="nightloc-node-worker", daemon=True)
        self._worker_error: BaseException | None = None

    # ---------------------------------------------------------------------------------- DDS
    def _dds(self) -> None:
        from cyclonedds.core import InstanceState, Policy, Qos, ReadCondition, SampleState, ViewState, WaitSet
        from cyclonedds.domain import DomainParticipant
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic
        from cyclonedds.util import duration

        from .messages import TYPES, dds_topic

        s = self.settings
        self.types = TYPES
        self.participant = DomainParticipant(s.domain_id)
        topics: dict[tuple[str, str], Any] = {}

        def qos(spec):
            return Qos(
                Policy.Reliability.Reliable(duration(seconds=1)) if spec.reliable else Policy.Reliability.BestEffort,
                Policy.Durability.TransientLocal if spec.transient_local else Policy.Durability.Volatile,
                Policy.History.KeepLast(spec.depth),
            )

        def topic(name: str, msgtype: str):
            key = (name, msgtype)
            if key not in topics:
                topics[key] = Topic(self.participant, dds_topic(name), TYPES[msgtype])
            return topics[key]

        specs = {spec.role: spec for spec in TOPICS}
        self.readers: dict[str, Any] = {}
        image_type = specs["image"].types[1 if s.compressed else 0]
        self.image_type = image_type
        wanted = {
            "image": image_type,
            "initialpose": specs["initialpose"].types[0],
            "relocalize": specs["relocalize"].types[0],
        }
        if s.odometry == "topic":
            wanted["odometry"] = specs["odometry"].types[0]
        elif s.odometry == "tf":
            wanted["tf"] = specs["tf"].types[0]
        for role, msgtype in wanted.items():
            self.readers[role] = DataReader(self.participant, topic(s.topic(role), msgtype), qos=qos(specs[role]))
        self.writers: dict[str, Any] = {}
        for role in ("pose", "tf", "belief", "status"):
            spec = specs[role]
            self.writers[role] = DataWriter(self.participant, topic(s.topic(role), spec.types[0]), qos=qos(spec))
        self.waitset = WaitSet(self.participant)
        self._conditions = []
        for role, reader in self.readers.items():
            condition = ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any)
            self.waitset.attach(condition)
            self._conditions.append((role, reader, condition))

    # ------------------------------------------------------------------------------ receiving
    def spin(self) -> None:
        """Receives until :meth:`stop` (the worker runs beside it), then lets the worker finish
        the frame it holds and waits (at most :data:`FLUSH_TIMEOUT_S`) until the subscribers
        have the last pose and status. Raises what the worker raised, if it failed."""
        self._worker.start()
        try:
            while not self._stop.is_set():
                self.waitset.wait(100_000_000)  # ns: wakes to see stop() at least every 0.1 s
                self.receive()
        finally:
            self._stop.set()
            with self._lock:
                self._lock.notify_all()
            self._worker.join()
            self.flush()
        if self._worker_error is not None:
            raise self._worker_error

    def flush(self, timeout: float = FLUSH_TIMEOUT_S) -> bool:
        """Waits until every matched reliable subscriber has acknowledged what the node wrote, at
        most ``timeout`` seconds in all; False if some had not by then, or DDS could not tell
        (shutdown goes on either way, and an error of the worker is not hidden by it)."""
        from cyclonedds.core import DDSException

        end = time.monotonic() + timeout
        for role, writer in self.writers.items():
            left = end - time.monotonic()
            try:
                acknowledged = left > 0 and writer.wait_for_acks(int(left * 1e9))
            except DDSException as error:
                self.log(f"shutdown: cannot wait for the subscribers of {self.settings.topic(role)} ({error})")
                return False
            if not acknowledged:
                return False
        return True

    def stop(self) -> None:
        """Asks :meth:`spin` to return (signal-safe)."""
        self._stop.set()

    def receive(self) -> None:
        """Takes everything the readers hold."""
        for role, reader, _ in self._conditions:
            while True:
                try:
                    samples = reader.take(N=64)
                except Exception as error:  # a message that does not deserialize: it is gone
                    self.complain(
                        f"broken-{role}", f"a message on {self.settings.topic(role)} cannot be read ({error})"
                    )
                    break
                if not samples:
                    break
                samples = [m for m in samples if getattr(getattr(m, "sample_info", None), "valid_data", False)]
                if samples:
                    self._take(role, samples)

    def _take(self, role: str, samples: list) -> None:
        arrival = time.perf_counter()
        if role == "image":
            with self._lock:
                for message in samples:
                    self.stats.received += 1
                    if self._slot is not None:
                        self.stats.dropped += 1
                    self._slot = _Frame(message, self.image_type, arrival, self.stats.received - 1)
                self._lock.notify_all()
            return
        if role in ("initialpose", "relocalize"):
            with self._lock:
                self._commands.extend((role, m) for m in samples)
                self._lock.notify_all()
            return
        problems = []
        with self._lock:
            for message in samples:
                problems.extend(self._odometry_samples(role, message))
            self._lock.notify_all()
        for problem in problems:
            if problem:
                self.complain("odometry", problem)

    def _odometry_samples(self, role: str, message: Any) -> list[str]:
        _, odom, base = self.settings.frames
        if role == "odometry":
            held = message.pose.pose
            twist = message.twist.covariance
            variances = (float(twist[0]), float(twist[7]), float(twist[35]))
            pose = (held.position.x, held.position.y, quaternion_yaw(held.orientation))
            return [self.sync.add(stamp_seconds(message.header.stamp), pose, variances)]
        problems = []
        for transform in message.transforms:
            if transform.header.frame_id.lstrip("/") == odom and transform.child_frame_id.lstrip("/") == base:
                t, r = transform.transform.translation, transform.transform.rotation
                problems.append(self.sync.add(stamp_seconds(transform.header.stamp), (t.x, t.y, quaternion_yaw(r))))
        return problems

    # -------------------------------------------------------------------------------- working
    def _ready(self, frame: _Frame, now: float) -> bool:
        if self.settings.odometry == "none":
            return True
        stamp = stamp_seconds(frame.message.header.stamp)
        return self.sync.covers(stamp) or now - frame.arrival >= self.settings.odometry_wait

    def _work(self) -> None:
        try:
            while True:
                command: tuple[str, Any] | None = None
                frame: _Frame | None = None
                with self._lock:
                    while True:
                        if self._commands:
                            command = self._commands.popleft()
                            break
                        now = time.perf_counter()
                        if self._slot is not None and self._ready(self._slot, now):
                            frame, self._slot = self._slot, None
                            break
                        if self._stop.is_set():
                            if self._slot is not None:  # still waiting for its odometry: never localized
                                self._slot = None
                                self.stats.dropped += 1
                            return
                        self._lock.wait(0.02 if self._slot is not None else 0.1)
                if command is not None:
                    self._command(*command)
                elif frame is not None:
                    self._process(frame)
        except BaseException as error:  # a bug: spin() raises it in the main thread
            self._worker_error = error
            self._stop.set()

    def _command(self, role: str, message: Any) -> None:
        map_frame = self.settings.frames[0]
        if role == "relocalize":
            self.runner.relocalize()
            self.log("relocalize: the belief is uniform again; map -> odom stops until it has converged")
            self._publish_status(None, self._last_stamp or 0.0)
            return
        frame_id = message.header.frame_id.lstrip("/")
        if frame_id not in (map_frame, ""):
            self.complain("initialpose", f"an initial pose in frame {frame_id!r}, not {map_frame!r}, is ignored")
            return
        held = message.pose.pose
        covariance = np.asarray(message.pose.covariance, dtype=np.float64).reshape(6, 6)
        cov3 = covariance[np.ix_([0, 1, 5], [0, 1, 5])]
        heading = quaternion_yaw(held.orientation)
        try:
            self.runner.set_pose(held.position.x, held.position.y, heading, cov3)
        except ValueError as error:
            self.complain("initialpose", f"the initial pose is ignored: {error}")
            return
        self.log(
            f"initial pose ({held.position.x:.2f}, {held.position.y:.2f}) m, heading {heading:.2f} rad: the belief is "
            f"that Gaussian"
        )

    def _skip(self, kind: str, line: str) -> None:
        with self._lock:
            self.stats.skipped += 1
        self.complain(kind, line)

    def _process(self, frame: _Frame) -> None:
        message, s = frame.message, self.settings
        stamp = stamp_seconds(message.header.stamp)
        where = f"{s.topic('image')} frame {frame.index} at {stamp:.3f} s"
        if self._last_stamp is not None and stamp <= self._last_stamp:
            self._skip(
                "stamp",
                f"{where}: its stamp is not after the last frame's ({self._last_stamp:.3f} s): skipped; the next "
                f"frame's motion is unknown",
            )
            with self._lock:
                self.sync.forget_last()
            self._last_stamp = stamp
            return
        try:
            image = decode_image(message, frame.msgtype, where)
            self.runner.ref_map.check_frames(image.shape, where, None)
        except (DatasetError, ValueError) as error:
            self._skip("image", f"{error}: skipped")
            return
        odometry_pose = None
        motion = None
        if s.odometry != "none":
            with self._lock:
                try:
                    odometry_pose = self.sync.pose_at(stamp)
                except DatasetError as error:
                    odometry_pose = None
                    problem = str(error)
                else:
                    previous = self._last_stamp
                    motion = self.sync.motion(stamp, odometry_pose)
                    noise = None
                    if s.noise == "covariance" and previous is not None:
                        noise = self.sync.step_noise(stamp, stamp - previous)
            if odometry_pose is None:
                self._skip(
                    "odometry",
                    f"{where}: {problem} within {s.sync_tolerance:g} s (--sync-tolerance): skipped (or run with "
                    f"--odometry-topic none)",
                )
                return
            if s.noise == "covariance":
                self.runner.localizer.noise = noise if noise is not None else self.base_noise
        self._last_stamp = stamp
        prepared = self.runner.prepare(image)
        estimate = self.runner.step(prepared, motion, f"frame_{frame.index:06d}", stamp)
        header_stamp = (int(message.header.stamp.sec), int(message.header.stamp.nanosec))
        map_frame, odom_frame, _ = s.frames
        self.writers["pose"].write(build.pose_with_covariance_stamped(self.types, header_stamp, map_frame, estimate))
        converged = self.runner.converged and odometry_pose is not None
        if converged:
            assert odometry_pose is not None
            heading = estimate.heading if math.isfinite(estimate.heading) else 0.0
            later = divmod(
                int(header_stamp[0]) * 1_000_000_000 + header_stamp[1] + round(s.transform_tolerance * 1e9),
                1_000_000_000,
            )
            correction = map_to_odom((estimate.x, estimate.y, heading), odometry_pose)
            transform = build.transform_stamped(self.types, later, map_frame, odom_frame, correction)
            self.writers["tf"].write(build.tf_message(self.types, [transform]))
        done = time.perf_counter()
        with self._lock:
            self.stats.processed += 1
            self.stats.latencies.append(done - frame.arrival)
        belief = None
        wall = time.monotonic()
        if s.belief_rate > 0 and wall - self._last_belief >= 1.0 / s.belief_rate:
            self._last_belief = wall
            belief = self.runner.localizer.belief
            values = self.raster.values(belief)
            self.writers["belief"].write(build.occupancy_grid(self.types, header_stamp, map_frame, self.raster, values))
        self._publish_status(estimate, stamp)
        if self.recorder is not None:
            if belief is None:
                belief = self.runner.localizer.belief
            self.recorder.write(FrameRecord(header_stamp, estimate, odometry_pose, prepared, belief, None, converged))

    def _publish_status(self, estimate: Any, stamp: float) -> None:
        with self._lock:
            stats = self.stats
            values = {
                "converged": self.runner.converged,
                "confidence": f"{estimate.confidence:.4f}" if estimate is not None else "nan",
                "credible_radius_m": f"{estimate.credible_radius:.3f}" if estimate is not None else "nan",
                "frames_received": stats.received,
                "frames_processed": stats.processed,
                "frames_dropped": stats.dropped,
                "frames_skipped": stats.skipped,
                "latency_last_ms": f"{1e3 * stats.latencies[-1]:.2f}" if stats.latencies else "nan",
                "latency_p50_ms": f"{1e3 * stats.latency(0.5):.2f}",
                "latency_p99_ms": f"{1e3 * stats.latency(0.99):.2f}",
            }
        level = build.OK if self.runner.converged else build.WARN
        words = "converged" if self.runner.converged else "not converged: map -> odom is not published"
        sec, nanosec = divmod(round(stamp * 1e9), 1_000_000_000)
        self.writers["status"].write(
            build.diagnostic_array(self.types, (sec, nanosec), "nightloc", level, words, values)
        )
