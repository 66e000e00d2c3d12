"""``nightloc node`` end to end over real DDS on loopback: the node in a child process, this test's
participant as the robot (publishing the synthetic garden's night: images and odometry) and the
listener. Discovery is pinned to ``lo`` by a CYCLONEDDS_URI file; each test has its own domain
and topic namespace (tests/dds_support.py)."""

from __future__ import annotations

import csv
import glob
import math
import re
import signal
import sys
from pathlib import Path

import cv2
import mcap.reader as mcap_reader  # the test extra brings it (and cyclonedds): these tests never skip
import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.mapping.dead_reckoning import compose_steps
from nightloc.motion.odometry import traverse_odometry
from nightloc.node import build
from nightloc.node.conventions import compose, stamp_of
from nightloc.synth import default_dataset

from bag_support import stamp_ns, write_bag
from dds_support import (
    Graph,
    loopback_environment,
    night_messages,
    node_process,
    stop_node,
    topic_options,
    unique_prefix,
    wait_for,
)

TOLERANCE_S = 1.0  # the node's default --transform-tolerance
CONVERGED = 0.8  # its default --converged-confidence


@pytest.fixture(scope="module")
def garden(tmp_path_factory):
    """The garden's map file, its night (frames, times, odometry poses) and ``nightloc localize
    --learn --format csv,mcap`` of the same night recorded as a ROS 2 bag."""
    folder = tmp_path_factory.mktemp("node")
    data = default_dataset()["garden"]
    ref_map = nightloc.ReferenceMap.build(nightloc.load_traverse(data["day_reference"]))
    map_path = folder / "garden.map"
    ref_map.save(map_path)
    night = nightloc.load_traverse(data["night_query"])
    motions = traverse_odometry(night)
    poses = compose_steps([(m.forward, m.left, m.turn) for m in motions[1:]])
    frames = [frame for _, frame in night.frames()]
    stamps = [stamp_ns(t) for t in night.timestamps]
    truth = np.column_stack([night.positions, night.headings])
    bag = write_bag(folder / "night_bag", frames, stamps, odometry=poses, poses=truth)
    out, learned = folder / "localize", folder / "localize.map"
    args = ["localize", str(map_path), str(bag), "--out", str(out), "--format", "csv,mcap", "--no-figures"]
    assert main([*args, "--learn", str(learned)]) == 0
    with (out / "trajectory.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    return {
        "folder": folder,
        "map": map_path,
        "night": night,
        "poses": poses,
        "trajectory": rows,
        "learned": learned,
        "bag": out / "trajectory_bag",
    }


def _heading(message) -> float:
    q = message.pose.pose.orientation
    return 2 * math.atan2(q.z, q.w)


def _seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def _status(message) -> dict[str, str]:
    return {kv.key: kv.value for kv in message.status[0].values}


def _bag_counts(folder: Path) -> dict[str, tuple[str, int]]:
    """Topic -> (schema name, messages) of the bag's MCAP file, read with the mcap package."""
    [file] = glob.glob(str(folder / "*.mcap"))
    with open(file, "rb") as handle:
        summary = mcap_reader.make_reader(handle).get_summary()
    counts = summary.statistics.channel_message_counts
    return {c.topic: (summary.schemas[c.schema_id].name, counts.get(c.id, 0)) for c in summary.channels.values()}


def _bag_poses(folder: Path) -> list:
    """The pose messages of a recording, read with rosbags."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([folder], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        connections = [c for c in reader.connections if c.topic.endswith("/nightloc/pose")]
        return [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=connections)]


def _matched(graph: Graph, log: Path) -> None:
    wait_for(
        lambda: graph.matched("image") and graph.matched("odometry") and graph.matched("relocalize")
        and graph.matched("initialpose")
        and all(len(graph.readers[r].get_matched_publications()) for r in ("pose", "tf", "status")),
        15,
        "discovery between the robot and the node",
        log,
    )  # fmt: skip


def _play(graph: Graph, messages, log: Path, lockstep: bool = True) -> None:
    """Publishes (odometry, image) pairs; with ``lockstep`` waits for each frame's pose first."""
    for odometry, image in messages:
        before = len(graph.messages["pose"])
        graph.write("odometry", odometry)
        graph.write("image", image)
        if lockstep:
            wait_for(lambda b=before: len(graph.messages["pose"]) > b, 10, "the pose of a frame", log)


def test_node_equals_localize_learns_the_same_map_and_records(garden, tmp_path):
    env = loopback_environment(tmp_path)
    prefix, log = unique_prefix(), tmp_path / "node.log"
    learned, recorded = tmp_path / "node.map", tmp_path / "node_bag"
    args = [str(garden["map"]), *topic_options(prefix), "--learn", str(learned), "--record", str(recorded)]
    night = garden["night"]
    with node_process(args, env, log) as process:
        graph = Graph(prefix)
        try:
            _matched(graph, log)
            _play(graph, night_messages(night, garden["poses"], night.timestamps, graph.types), log)
            wait_for(lambda: len(graph.messages["status"]) >= len(night), 10, "the status of every frame", log)
            text = stop_node(process, log, signal.SIGINT)
        finally:
            graph.close()
    poses, expected = graph.messages["pose"], garden["trajectory"]
    exact = _bag_poses(garden["bag"])  # localize's poses in full precision (trajectory.csv rounds)
    assert len(poses) == len(expected) == len(exact) == len(night)
    for message, theirs, row in zip(poses, exact, expected):
        assert message.header.frame_id == "map"
        assert abs(message.pose.pose.position.x - theirs.pose.pose.position.x) <= 1e-6
        assert abs(message.pose.pose.position.y - theirs.pose.pose.position.y) <= 1e-6
        assert abs(math.remainder(_heading(message) - _heading(theirs), 2 * math.pi)) <= 1e-6
        assert abs(message.pose.pose.position.x - float(row["x"])) <= 1e-4  # the CSV's 4 decimals
        assert _seconds(message.header.stamp) == pytest.approx(float(row["timestamp"]), abs=1e-9)
        assert message.header.stamp.sec == theirs.header.stamp.sec
    # map -> odom exactly for the frames whose confidence reached the threshold, post-dated
    confident = [float(r["timestamp"]) for r in expected if float(r["confidence"]) >= CONVERGED]
    assert 0 < len(confident) < len(expected)  # the night starts lost: no transform before convergence
    sent = [_seconds(m.transforms[0].header.stamp) - TOLERANCE_S for m in graph.messages["tf"]]
    assert sent == pytest.approx(confident, abs=1e-6)
    assert {(m.transforms[0].header.frame_id, m.transforms[0].child_frame_id) for m in graph.messages["tf"]} == {
        ("map", "odom")
    }
    last = _status(graph.messages["status"][-1])
    assert (last["frames_received"], last["frames_processed"], last["frames_dropped"]) == ("41", "41", "0")
    assert "41 frames received, 41 localized, 0 dropped" in text
    assert graph.messages["belief"], "no belief grid"
    # the learned map on shutdown: localize --learn's (the same places, looks, poses and counts)
    ours, theirs = nightloc.ReferenceMap.load(learned), nightloc.ReferenceMap.load(garden["learned"])
    assert len(ours) > len(nightloc.ReferenceMap.load(garden["map"]))  # it learned something
    np.testing.assert_array_equal(ours.images, theirs.images)
    np.testing.assert_array_equal(ours.positions, theirs.positions)
    np.testing.assert_array_equal(ours.headings, theirs.headings)
    assert ours.names == theirs.names
    for field in ("night", "confidence", "time", "matches"):
        np.testing.assert_array_equal(getattr(ours.appearances, field), getattr(theirs.appearances, field))
    # both recordings, read by the independent mcap reader
    n = len(night)
    node_bag, localize_bag = _bag_counts(recorded), _bag_counts(garden["bag"])
    common = {
        "/nightloc/pose": ("geometry_msgs/msg/PoseWithCovarianceStamped", n),
        "/tf": ("tf2_msgs/msg/TFMessage", n),
        "/nightloc/belief": ("nav_msgs/msg/OccupancyGrid", n),
        "/nightloc/prepared": ("sensor_msgs/msg/Image", n),
    }
    assert localize_bag == common | {"/nightloc/truth": ("geometry_msgs/msg/PoseStamped", n)}
    assert {topic: value for topic, value in node_bag.items() if value[1]} == {
        prefix + topic if topic != "/nightloc/prepared" else topic: value for topic, value in common.items()
    }


def test_tf_odometry_and_compressed_frames_give_the_same_poses(garden, tmp_path):
    env = loopback_environment(tmp_path)
    prefix, log = unique_prefix(), tmp_path / "node.log"
    night, n = garden["night"], 12
    # TF carries no covariance: --odometry-noise covariance falls back to the wheel model, as localize's
    args = [str(garden["map"]), *topic_options(prefix), "--odometry-topic", "/tf", "--compressed"]
    args += ["--odometry-noise", "covariance"]
    with node_process(args, env, log) as process:
        graph = Graph(prefix)
        try:
            _matched_tf(graph, log)
            t = graph.types
            for (_, frame), pose, seconds in list(zip(night.frames(), garden["poses"], night.timestamps))[:n]:
                stamp = stamp_of(float(seconds))
                ok, png = cv2.imencode(".png", frame)
                assert ok
                image = t["sensor_msgs/msg/CompressedImage"](
                    header=build.header(t, stamp, "camera"), format="png", data=png.reshape(-1)
                )
                before = len(graph.messages["pose"])
                graph.write("tf", build.tf_message(t, [build.transform_stamped(t, stamp, "odom", "base_link", pose)]))
                graph.write("image", image, "sensor_msgs/msg/CompressedImage")
                wait_for(lambda b=before: len(graph.messages["pose"]) > b, 10, "the pose of a frame", log)
            stop_node(process, log)
        finally:
            graph.close()
    exact = _bag_poses(garden["bag"])[:n]
    for message, theirs in zip(graph.messages["pose"], exact, strict=True):
        assert abs(message.pose.pose.position.x - theirs.pose.pose.position.x) <= 1e-6
        assert abs(message.pose.pose.position.y - theirs.pose.pose.position.y) <= 1e-6
        assert abs(math.remainder(_heading(message) - _heading(theirs), 2 * math.pi)) <= 1e-6


def _matched_tf(graph: Graph, log: Path) -> None:
    wait_for(
        lambda: graph.matched("image", "sensor_msgs/msg/CompressedImage") and graph.matched("tf")
        and len(graph.readers["pose"].get_matched_publications()),
        15,
        "discovery between the robot and the node",
        log,
    )  # fmt: skip


def test_transform_waits_for_convergence_stops_at_a_kidnap_and_resumes(garden, tmp_path):
    env = loopback_environment(tmp_path)
    prefix, log = unique_prefix(), tmp_path / "node.log"
    night, poses = garden["night"], garden["poses"]
    times = np.asarray(night.timestamps)
    with node_process([str(garden["map"]), *topic_options(prefix)], env, log) as process:
        graph = Graph(prefix)
        try:
            _matched(graph, log)
            first = list(night_messages(night, poses, times, graph.types))
            _play(graph, first[:25], log)
            assert graph.messages["tf"], "no transform after 25 frames"
            graph.write("relocalize", build.empty(graph.types))
            wait_for(lambda: "relocalize" in log.read_text(), 10, "the relocalize to arrive", log)
            # carried elsewhere: frames 3.. again, later in time, the odometry continuing (no motion across)
            start = 3
            later = times[start:] - times[start] + times[24] + 1.0
            moved = [compose(tuple(poses[24]), compose(_inverse(poses[start]), tuple(p))) for p in poses[start:]]
            second = list(night_messages(_Frames(night, start), np.array(moved), later, graph.types))
            tf_before = len(graph.messages["tf"])
            _play(graph, second, log)
            stop_node(process, log)
        finally:
            graph.close()
    after = [_seconds(m.transforms[0].header.stamp) - TOLERANCE_S for m in graph.messages["tf"][tf_before:]]
    kidnapped = [round(t, 6) for t in later]
    sent = {round(t, 6) for t in after}
    assert sent <= set(kidnapped)
    # stops within 2 frames of the relocalize, resumes once converged again
    assert not sent & set(kidnapped[2:10]), f"transforms right after the kidnap: {sorted(sent)[:5]}"
    assert sent, "the transform never resumed after the kidnap"
    resumed = kidnapped.index(min(sent))
    assert 2 <= resumed < len(kidnapped) - 1


def _inverse(pose):
    from nightloc.node.conventions import invert

    return invert(tuple(pose))


class _Frames:
    """The night's frames from ``start`` on (what night_messages reads)."""

    def __init__(self, night, start: int):
        self.night, self.start = night, start

    def frames(self):
        return ((k, frame) for k, frame in self.night.frames() if k >= self.start)


def test_initial_pose_sets_the_belief(garden, tmp_path):
    env = loopback_environment(tmp_path)
    prefix, log = unique_prefix(), tmp_path / "node.log"
    night = garden["night"]
    x, y = night.positions[0]
    pose = build.pose_with_covariance_stamped(
        Graph.types_for_test(), (0, 0), "map", _estimate(x, y, float(night.headings[0]))
    )
    with node_process([str(garden["map"]), *topic_options(prefix)], env, log) as process:
        graph = Graph(prefix)
        try:
            _matched(graph, log)
            graph.write("initialpose", pose)
            wait_for(lambda: "initial pose" in log.read_text(), 10, "the initial pose to arrive", log)
            _play(graph, list(night_messages(night, garden["poses"], night.timestamps, graph.types))[:3], log)
            stop_node(process, log)
        finally:
            graph.close()
    # from the first frame on: converged at the true pose (from a uniform belief it takes 11 frames)
    assert len(graph.messages["tf"]) == 3
    first = graph.messages["pose"][0].pose.pose.position
    assert math.hypot(first.x - x, first.y - y) < 0.5


def _estimate(x, y, heading):
    from nightloc.localization.localizer import Estimate

    return Estimate(
        x=x, y=y, heading=heading, ref_index=0, confidence=1.0, frames=0, best_ref=0, score=0.0,
        covariance=((0.05, 0.0), (0.0, 0.05)), method="filter", heading_variance=0.02,
    )  # fmt: skip


def _rss_kb(pid: int) -> int:
    return int(re.search(r"VmRSS:\s+(\d+)", Path(f"/proc/{pid}/status").read_text()).group(1))


def test_faster_than_the_node_drops_frames_bounded_and_says_so(garden, tmp_path):
    env = loopback_environment(tmp_path)
    prefix, log = unique_prefix(), tmp_path / "node.log"
    night = garden["night"]
    frame = next(iter(night.frames()))[1]
    with node_process([str(garden["map"]), *topic_options(prefix), "--belief-rate", "0"], env, log) as process:
        graph = Graph(prefix)
        try:
            _matched(graph, log)
            sent = 0
            rss = []
            for _burst in range(3):
                for _ in range(400):
                    stamp = stamp_of(1.0 + 0.01 * sent)
                    graph.write(
                        "odometry", build.odometry(graph.types, stamp, ("odom", "base_link"), (0.001 * sent, 0, 0))
                    )
                    graph.write("image", build.image(graph.types, stamp, "camera", frame))
                    sent += 1
                wait_for(
                    lambda s=sent: (
                        graph.messages["status"]
                        and int(_status(graph.messages["status"][-1])["frames_received"])
                        == int(_status(graph.messages["status"][-1])["frames_processed"])
                        + int(_status(graph.messages["status"][-1])["frames_dropped"])
                    ),
                    20,
                    "the node to catch up",
                    log,
                )
                rss.append(_rss_kb(process.pid))
            text = stop_node(process, log)
        finally:
            graph.close()
    # the counts at shutdown are final (frames still in flight after the last status are in them)
    final = re.search(r"(\d+) frames received, (\d+) localized, (\d+) dropped", text)
    assert final, text[-2000:]
    received, processed, dropped = (int(v) for v in final.groups())
    assert dropped > 0 and processed > 0, final.group(0)
    assert received == processed + dropped <= sent
    # the pose topic keeps AMCL's QoS (reliable, keep last 1): a subscriber that falls behind may
    # miss a pose the next one replaced, never get one twice or out of order, and gets the last
    stamps = [_seconds(m.header.stamp) for m in graph.messages["pose"]]
    assert np.all(np.diff(stamps) > 0), "poses came twice or out of order"
    assert 0.95 * processed <= len(stamps) <= processed, (len(stamps), processed)
    last = graph.messages["status"][-1]  # the node waited at shutdown until its last status and pose were taken
    status = _status(last)
    assert int(status["frames_processed"]) == processed and 0 < int(status["frames_dropped"]) <= dropped, status
    assert _seconds(last.header.stamp) == pytest.approx(stamps[-1], abs=1e-6), "the last frame's pose is missing"
    assert rss[-1] - rss[0] < 8 * 1024, f"resident memory grew from {rss[0]} to {rss[-1]} KiB"


def test_bad_input_is_one_line_each_and_the_node_goes_on(garden, tmp_path):
    env = loopback_environment(tmp_path)
    prefix, log = unique_prefix(), tmp_path / "node.log"
    night = garden["night"]
    frame = next(iter(night.frames()))[1]
    with node_process([str(garden["map"]), *topic_options(prefix)], env, log) as process:
        graph = Graph(prefix)
        try:
            _matched(graph, log)
            t = graph.types

            def send(seconds, image):
                stamp = stamp_of(seconds)
                graph.write("odometry", build.odometry(t, stamp, ("odom", "base_link"), (0.0, 0.0, 0.0)))
                graph.write("image", image)

            send(1.0, build.image(t, stamp_of(1.0), "camera", frame))  # a good frame
            wait_for(lambda: len(graph.messages["pose"]) == 1, 10, "the first pose", log)
            broken = build.image(t, stamp_of(3.0), "camera", frame)
            broken.data = broken.data[:100]  # fewer bytes than height x step
            odd = build.image(t, stamp_of(4.0), "camera", frame)
            odd.encoding = "yuv422"
            bad = [
                (2.0, build.image(t, stamp_of(2.0), "camera", np.zeros((30, 50, 3), np.uint8)), "50x30 frames"),
                (3.0, broken, "needs"),
                (4.0, odd, "yuv422"),
                (0.5, build.image(t, stamp_of(0.5), "camera", frame), "not after the last frame"),
            ]
            for seconds, image, words in bad:  # one at a time (a newer frame would replace a waiting one)
                send(seconds, image)
                wait_for(lambda w=words: w in log.read_text(), 10, f"the line saying {words!r}", log)
            graph.write("initialpose", build.pose_with_covariance_stamped(t, (0, 0), "odom", _estimate(0, 0, 0)))
            wait_for(lambda: "in frame 'odom'" in log.read_text(), 10, "the initial pose's line", log)
            send(5.0, build.image(t, stamp_of(5.0), "camera", frame))  # and on it goes
            wait_for(lambda: len(graph.messages["pose"]) == 2, 10, "the next good frame's pose", log)
            text = stop_node(process, log, signal.SIGINT)
        finally:
            graph.close()
    lines = text.splitlines()
    assert all(line.startswith("nightloc node: ") for line in lines), text
    for words in ("50x30 frames", "needs", "yuv422", "not after the last frame", "went back in time", "'odom'"):
        assert sum(words in line for line in lines) == 1, (words, text)
    assert "4 skipped (bad input)" in text


def test_a_map_that_does_not_load_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.map"
    bad.write_bytes(b"not a map")
    assert main(["node", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("nightloc node: error:") and "bad.map" in err[0]


@pytest.mark.parametrize(
    ("options", "words"),
    [
        (["--domain-id", "300"], "--domain-id (or ROS_DOMAIN_ID) must be 0-232"),
        (["--converged-confidence", "1.5"], "--converged-confidence must be in [0, 1]"),
        (["--odometry-noise", "7"], "noise model must be one of [0, 1, 2, 3]"),
        (["--belief-rate", "-1"], "--belief-rate must be a finite number >= 0"),
        (["--overwrite"], "--overwrite replaces the --learn NEW_MAP"),
    ],
)
def test_bad_options_are_one_line(garden, capsys, options, words):
    assert main(["node", str(garden["map"]), *options, "--duration", "5"]) == 2  # (a node that started: 5 s)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err


def test_an_existing_record_bag_is_refused_before_any_work(garden, tmp_path, capsys):
    (tmp_path / "bag").mkdir()
    assert main(["node", str(garden["map"]), "--record", str(tmp_path / "bag"), "--duration", "5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists: a recording goes into a new folder" in err[0], err


def test_without_cyclonedds_one_line_names_the_extra(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "cyclonedds.domain", None)  # import fails as when it is not installed
    assert main(["node", str(tmp_path / "any.map")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'pip install "nightloc[ros2]"' in err[0]


def test_shutdown_waits_for_acknowledgements_and_a_dds_error_does_not_stop_it():
    from cyclonedds.core import DDSException

    from nightloc.node.participant import Node, NodeSettings

    class Writer:
        def __init__(self, answer):
            self.answer, self.timeouts = answer, []

        def wait_for_acks(self, timeout: int) -> bool:
            self.timeouts.append(timeout)
            if isinstance(self.answer, Exception):
                raise self.answer
            return self.answer

    lines: list[str] = []
    node = object.__new__(Node)  # the shutdown step alone, over stand-in writers
    node.settings, node.log = NodeSettings(), lines.append
    node.writers = {"pose": Writer(True), "status": Writer(True)}
    assert node.flush(1.0) and all(0 < w.timeouts[0] <= 1e9 for w in node.writers.values())
    node.writers = {"pose": Writer(False), "status": Writer(True)}
    assert not node.flush(1.0) and node.writers["status"].timeouts == []  # a wait times out only when the time is up
    node.writers = {"pose": Writer(DDSException(DDSException.DDS_RETCODE_ERROR, "gone"))}
    assert not node.flush(1.0)
    topic = node.settings.topic("pose")
    assert len(lines) == 1 and lines[0].startswith(f"shutdown: cannot wait for the subscribers of {topic}")
    assert "gone" in lines[0]
