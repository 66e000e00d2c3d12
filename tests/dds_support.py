"""DDS on loopback for the node's tests: a CYCLONEDDS_URI configuration that keeps discovery on
``lo`` (unicast to 127.0.0.1, no multicast: CI needs no network), a domain ID and topic prefix of
the test's own (parallel runs never meet), the node as a child process that is always ended, and
the test's own participant as the "robot" (publishing a night) and the listener (collecting what
the node publishes), with bounded waits that fail with a message saying what never came."""

from __future__ import annotations

import gc
import os
import random
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections import defaultdict
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

CONFIG = """<?xml version="1.0" encoding="UTF-8" ?>
<CycloneDDS xmlns="https://cdds.io/config">
  <Domain Id="any">
    <General>
      <Interfaces><NetworkInterface name="lo" multicast="false"/></Interfaces>
      <AllowMulticast>false</AllowMulticast>
    </General>
    <Discovery>
      <ParticipantIndex>auto</ParticipantIndex>
      <MaxAutoParticipantIndex>30</MaxAutoParticipantIndex>
      <Peers><Peer address="127.0.0.1"/></Peers>
    </Discovery>
  </Domain>
</CycloneDDS>
"""

REPOSITORY = Path(__file__).resolve().parents[2]


def loopback_environment(folder: Path) -> dict[str, str]:
    """Writes the configuration into ``folder`` and sets (in this process too) CYCLONEDDS_URI and a
    random ROS_DOMAIN_ID; returns the child processes' environment."""
    config = folder / "cyclonedds.xml"
    config.write_text(CONFIG, encoding="utf-8")
    os.environ["CYCLONEDDS_URI"] = f"file://{config}"
    domain = random.SystemRandom().randint(1, 232)
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    return dict(os.environ)


def unique_prefix() -> str:
    """A topic namespace of this test's own, e.g. ``/t3f2a9c1``."""
    return f"/t{uuid.uuid4().hex[:8]}"


def topic_options(prefix: str) -> list[str]:
    """``nightloc node`` options that put every topic of the graph under ``prefix``."""
    from nightloc.node.conventions import TOPICS

    return [option for spec in TOPICS for option in (f"--{spec.role}-topic", prefix + spec.default)]


@contextmanager
def node_process(args: Sequence[str], env: dict[str, str], log: Path) -> Iterator[subprocess.Popen]:
    """``python -m nightloc node ARGS`` with its stderr in ``log``; waits for its "ready" line
    (20 s at most) and always ends it (SIGTERM, then SIGKILL after 10 s)."""
    handle = log.open("w", encoding="utf-8")
    process = subprocess.Popen(
        [sys.executable, "-m", "nightloc", "node", *args], env=env, stdout=subprocess.DEVNULL, stderr=handle
    )
    try:
        wait_for(lambda: "ready:" in log.read_text() or process.poll() is not None, 20, "the node's ready line", log)
        if process.poll() is not None:
            raise AssertionError(f"the node exited with {process.returncode}: {log.read_text()}")
        yield process
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGTERM)
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        handle.close()


def stop_node(process: subprocess.Popen, log: Path, sig: int = signal.SIGTERM, timeout: float = 20) -> str:
    """Sends ``sig`` and waits for a clean exit (status 0); the node's log."""
    process.send_signal(sig)
    try:
        status = process.wait(timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        raise AssertionError(f"the node did not stop within {timeout} s of signal {sig}: {log.read_text()}") from None
    text = log.read_text()
    assert status == 0, f"the node exited with {status}: {text}"
    assert "Traceback" not in text, text
    return text


def wait_for(condition, timeout: float, what: str, log: Path | None = None) -> None:
    """Polls ``condition()`` every 10 ms for ``timeout`` seconds; AssertionError naming ``what``."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return
        time.sleep(0.01)
    tail = f"; the node's log: {log.read_text()[-3000:]}" if log is not None and log.exists() else ""
    raise AssertionError(f"waited {timeout} s for {what}{tail}")


class Graph:
    """The test's participant: writers for the robot's topics, readers for the node's, each
    reader's messages collected by a thread (``messages[role]``, in arrival order)."""

    def __init__(self, prefix: str, domain: int | None = None):
        from cyclonedds.core import Policy, Qos
        from cyclonedds.domain import DomainParticipant
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic
        from cyclonedds.util import duration

        from nightloc.node.conventions import TOPICS
        from nightloc.node.messages import TYPES, dds_topic

        self.types = TYPES
        gc.collect()  # entities an earlier graph left are deleted now, not while these are created
        self.participant = DomainParticipant(int(os.environ["ROS_DOMAIN_ID"]) if domain is None else domain)
        self.names = {spec.role: prefix + spec.default for spec in TOPICS}
        self.writers, self.readers = {}, {}
        self.topics: list = []  # held as long as their readers and writers
        self.messages: dict[str, list] = defaultdict(list)
        self.arrivals: dict[str, list] = defaultdict(list)
        for spec in TOPICS:
            reliability = Policy.Reliability.Reliable(duration(seconds=1)) if spec.reliable else None
            # the robot's side: what a ROS 2 robot offers (camera: best effort, the rest reliable)
            for msgtype in spec.types:
                topic = Topic(self.participant, dds_topic(self.names[spec.role]), TYPES[msgtype])
                self.topics.append(topic)
                qos = Qos(
                    reliability or Policy.Reliability.BestEffort,
                    Policy.Durability.TransientLocal if spec.transient_local else Policy.Durability.Volatile,
                    Policy.History.KeepLast(max(spec.depth, 100) if spec.incoming else 1000),
                )
                if spec.incoming or spec.role == "tf":
                    self.writers[(spec.role, msgtype)] = DataWriter(self.participant, topic, qos=qos)
                if not spec.incoming:
                    self.readers[spec.role] = DataReader(self.participant, topic, qos=qos)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._collect, daemon=True)
        self._thread.start()

    def _collect(self) -> None:
        while not self._stop.is_set():
            self._take()
            time.sleep(0.002)
        self._take()  # what arrived since the last pass (the node's last messages before it exited)

    def _take(self) -> None:
        for role, reader in self.readers.items():
            while messages := reader.take(N=256):
                for message in messages:
                    if getattr(message.sample_info, "valid_data", False):
                        self.messages[role].append(message)
                        self.arrivals[role].append(time.perf_counter())

    @staticmethod
    def types_for_test():
        """The node's DDS types (to build messages before a Graph exists)."""
        from nightloc.node.messages import TYPES

        return TYPES

    def write(self, role: str, message, msgtype: str | None = None) -> None:
        from nightloc.node.conventions import TOPICS

        spec = next(s for s in TOPICS if s.role == role)
        self.writers[(role, msgtype or spec.types[0])].write(message)

    def matched(self, role: str, msgtype: str | None = None) -> int:
        """How many readers the robot's writer of ``role`` has met."""
        from nightloc.node.conventions import TOPICS

        spec = next(s for s in TOPICS if s.role == role)
        return len(self.writers[(role, msgtype or spec.types[0])].get_matched_subscriptions())

    def close(self) -> None:
        """Stops collecting and deletes the graph's DDS entities (readers, writers, topics, the
        participant) now: left to the garbage collector, their deletion could fall inside the
        creation of another graph's entities."""
        self._stop.set()
        self._thread.join(5)
        self.readers.clear()
        self.writers.clear()
        self.topics.clear()
        self.participant = None
        gc.collect()


def night_messages(night, odometry_poses: np.ndarray, stamps: Sequence[float], types, tf: bool = False):
    """Per frame: the odometry message (Odometry, or a TFMessage odom -> base_link) and the image
    message (bgr8), at the frame's stamp."""
    from nightloc.node import build
    from nightloc.node.conventions import stamp_of

    for (_, frame), pose, seconds in zip(night.frames(), odometry_poses, stamps):
        stamp = stamp_of(float(seconds))
        if tf:
            odometry = build.tf_message(types, [build.transform_stamped(types, stamp, "odom", "base_link", pose)])
        else:
            odometry = build.odometry(types, stamp, ("odom", "base_link"), pose)
        yield odometry, build.image(types, stamp, "camera", frame)
