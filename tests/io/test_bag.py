"""ROS bags as traverses (nightloc.io.bag): frames, times, odometry and poses read back as they
were written by rosbags' own writers, for ROS 1 and ROS 2 (MCAP, sqlite3) bags; topics, time
matching and their errors; memory while streaming."""

from __future__ import annotations

import itertools
import math
import subprocess
import sys
import textwrap
import warnings

import cv2
import numpy as np
import pytest

import nightloc
from nightloc.errors import DatasetError
from nightloc.io.bag import IMAGE_ENCODINGS

from bag_support import NS, stamp_ns, write_bag
from reliability_support import random_frames

T0 = 1_700_000_000.25  # seconds: stamps of the size a robot's clock gives
STORAGES = ["mcap", "sqlite3", "ros1"]


def _path(tmp_path, storage, name="drive"):
    return tmp_path / (f"{name}.bag" if storage == "ros1" else name)


def _circle(times: np.ndarray) -> np.ndarray:
    """x, y, heading of a robot driving a 3 m circle at 0.4 m/s, counter-clockwise (the truth)."""
    angle = 0.4 / 3.0 * times
    return np.column_stack([3 * np.cos(angle), 3 * np.sin(angle), np.mod(angle + np.pi / 2 + np.pi, 2 * np.pi) - np.pi])


def _in_odom_frame(poses: np.ndarray, dx=5.0, dy=-2.0, rotation=0.7) -> np.ndarray:
    """The same poses seen from another fixed frame (an odom frame wherever the robot started)."""
    c, s = math.cos(rotation), math.sin(rotation)
    x = c * poses[:, 0] - s * poses[:, 1] + dx
    y = s * poses[:, 0] + c * poses[:, 1] + dy
    return np.column_stack([x, y, poses[:, 2] + rotation])


def _lerp(sample_times: np.ndarray, samples: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Oracle: each time's pose on the straight line between the samples around it (the last
    sample's after the end); headings along the shorter turn."""
    out = []
    for t in times:
        k = max(j for j in range(len(sample_times)) if sample_times[j] <= t) if t >= sample_times[0] else 0
        if k == len(sample_times) - 1 or t < sample_times[0]:
            out.append(samples[k])
            continue
        w = (t - sample_times[k]) / (sample_times[k + 1] - sample_times[k])
        (x0, y0, h0), (x1, y1, h1) = samples[k], samples[k + 1]
        turn = math.atan2(math.sin(h1 - h0), math.cos(h1 - h0))
        out.append((x0 + w * (x1 - x0), y0 + w * (y1 - y0), h0 + w * turn))
    return np.array(out)


def _robot_steps(poses: np.ndarray) -> np.ndarray:
    """Oracle: each step as (forward, left, turn) in the robot's frame at its start."""
    out = [(0.0, 0.0, 0.0)]
    for (x0, y0, h0), (x1, y1, h1) in itertools.pairwise(poses):
        dx, dy = x1 - x0, y1 - y0
        turn = math.atan2(math.sin(h1 - h0), math.cos(h1 - h0))
        out.append((math.cos(h0) * dx + math.sin(h0) * dy, -math.sin(h0) * dx + math.cos(h0) * dy, turn))
    return np.array(out)


@pytest.fixture(scope="module")
def frames():
    return random_frames(12, seed=5, shape=(30, 60, 3))


@pytest.mark.parametrize("storage", STORAGES)
def test_frames_times_odometry_and_poses_read_back(tmp_path, frames, storage):
    times = T0 + 0.5 * np.arange(len(frames))
    frame_ns = [stamp_ns(t) + 7 for t in times]  # nanoseconds that a float cannot hold exactly
    truth = _circle(times - T0)
    odom_ns = [n - 3_000_000 for n in frame_ns]  # the odometry 3 ms before each frame
    odom = _in_odom_frame(_circle(np.array(odom_ns) / NS - T0))
    bag = write_bag(
        _path(tmp_path, storage), frames, frame_ns, storage=storage, odometry=odom, odometry_ns=odom_ns, poses=truth
    )
    traverse = nightloc.load_traverse(bag)
    assert traverse.is_bag and len(traverse) == len(frames) and traverse.names[0] == "frame_000000"
    assert traverse.bag_topics == {"image": "/camera/image_raw", "odometry": "/odom", "pose": "/ground_truth/pose"}
    expected_times = [float(f"{n // NS}.{n % NS:09d}") for n in frame_ns]
    assert traverse.timestamps.tolist() == expected_times
    np.testing.assert_allclose(traverse.positions, truth[:, :2], atol=1e-12)
    np.testing.assert_allclose(traverse.headings, truth[:, 2], atol=1e-12)
    for index, image in traverse.frames():
        np.testing.assert_array_equal(image, frames[index])
    np.testing.assert_array_equal(traverse.read(7), frames[7])
    # the odometry, in its own frame and 3 ms early, interpolated to each frame: the truth's steps
    # in the robot's frame (within the 3 ms of interpolation along the circle's chord)
    motions = nightloc.traverse_odometry(traverse)
    assert motions[0] is None
    steps = np.array([(m.forward, m.left, m.turn) for m in motions[1:]])
    at_frames = _lerp(np.array(odom_ns) / NS, odom, np.array(frame_ns) / NS)
    np.testing.assert_allclose(steps, _robot_steps(at_frames)[1:], atol=1e-6)  # times of 1.7e9 s: 0.2 us ulps
    # (the last frame comes after the last sample: it holds that sample, 3 ms stale)
    np.testing.assert_allclose(steps[:-1], _robot_steps(truth)[1:-1], atol=1e-5)


@pytest.mark.parametrize(
    ("encoding", "options"),
    [
        ("bgr8", {}),
        ("rgb8", {"padding": 8}),
        ("mono8", {"padding": 3}),
        ("mono16", {}),
        ("mono16", {"bigendian": True}),
    ],
)
def test_image_encodings(tmp_path, frames, encoding, options):
    bag = write_bag(tmp_path / "b", frames[:3], [stamp_ns(T0 + i) for i in range(3)], encoding=encoding, **options)
    traverse = nightloc.load_traverse(bag)
    image = traverse.read(1)
    grey = cv2.cvtColor(frames[1], cv2.COLOR_BGR2GRAY)
    expected = {
        "bgr8": frames[1],
        "rgb8": frames[1],
        "mono8": grey,
        "mono16": grey.astype(np.uint16) * 257,
    }[encoding]
    assert image.dtype == expected.dtype
    np.testing.assert_array_equal(image, expected)
    assert nightloc.prepare(image).shape == (24, 48)


@pytest.mark.parametrize("encoding", sorted(IMAGE_ENCODINGS))
def test_every_encoding_of_the_table_is_read_as_its_layout_says(tmp_path, frames, encoding):
    """Each encoding the reader lists, written in its channel order and bits (an alpha channel,
    16 bits as v * 257, big-endian too), reads back as the BGR or grey frame."""
    layout = IMAGE_ENCODINGS[encoding]
    grey = cv2.cvtColor(frames[1], cv2.COLOR_BGR2GRAY)
    expected = grey if layout.order == "mono" else frames[1]
    if layout.bits == 16:
        expected = expected.astype(np.uint16) * 257
    for bigendian in (False, True) if layout.bits == 16 else (False,):
        folder = tmp_path / f"b{int(bigendian)}"
        stamps = [stamp_ns(T0 + i) for i in range(3)]
        bag = write_bag(folder, frames[:3], stamps, encoding=encoding.upper(), bigendian=bigendian, padding=2)
        image = nightloc.load_traverse(bag).read(1)
        assert image.dtype == expected.dtype
        np.testing.assert_array_equal(image, expected)


def test_compressed_images(tmp_path, frames):
    bag = write_bag(
        tmp_path / "c", frames[:4], [stamp_ns(T0 + i) for i in range(4)], compressed=True, storage="sqlite3"
    )
    for index, image in nightloc.load_traverse(bag).frames():
        np.testing.assert_array_equal(image, frames[index])  # PNG: lossless


def test_tf_odometry_and_a_lone_mcap_file(tmp_path, frames):
    times = T0 + 0.5 * np.arange(len(frames))
    frame_ns = [stamp_ns(t) for t in times]
    odom = _in_odom_frame(_circle(times - T0))
    via_tf = write_bag(tmp_path / "tf", frames, frame_ns, odometry=odom, tf=True)
    traverse = nightloc.load_traverse(via_tf)
    assert traverse.bag_topics["odometry"] == "/tf:odom:base_link"
    steps = np.array([(m.forward, m.left, m.turn) for m in nightloc.traverse_odometry(traverse)[1:]])
    np.testing.assert_allclose(steps, _robot_steps(_circle(times - T0))[1:], atol=1e-9)
    lone = via_tf / "tf.mcap"  # a ROS 2 storage file on its own reads the same
    assert nightloc.load_traverse(lone).timestamps.tolist() == traverse.timestamps.tolist()
    other = write_bag(tmp_path / "tf2", frames, frame_ns, odometry=odom, tf=True, tf_frames=("odom", "chassis"))
    assert nightloc.load_traverse(other).motions is None  # no odom -> base frames: no odometry
    named = nightloc.load_traverse(other, odometry_topic="/tf:odom:chassis")
    np.testing.assert_allclose(named.motions, traverse.motions, atol=1e-12)


def test_poses_interpolated_between_samples(tmp_path, frames):
    """Poses at 20 Hz, frames at 2 Hz between them: linear interpolation of the circle, within
    its chord error (v^2 dt^2 / 8r)."""
    frame_times = T0 + 0.5 * np.arange(len(frames)) + 0.013
    pose_times = T0 + 0.05 * np.arange(140)
    bag = write_bag(
        tmp_path / "p",
        frames,
        [stamp_ns(t) for t in frame_times],
        poses=_circle(pose_times - T0),
        pose_ns=[stamp_ns(t) for t in pose_times],
    )
    traverse = nightloc.load_traverse(bag)
    truth = _circle(frame_times - T0)
    assert np.abs(traverse.positions - truth[:, :2]).max() < 0.4**2 * 0.05**2 / (8 * 3) + 1e-9
    assert np.abs(traverse.headings - truth[:, 2]).max() < 1e-6  # the heading grows linearly (0.2 us time ulps)
    assert traverse.motions is None and traverse.has_poses


def test_frame_step_composes_the_odometry(tmp_path, frames):
    times = T0 + 0.5 * np.arange(len(frames))
    truth = _circle(times - T0)
    bag = write_bag(tmp_path / "s", frames, [stamp_ns(t) for t in times], odometry=_in_odom_frame(truth))
    every_third = nightloc.load_traverse(bag, frame_step=3)
    assert every_third.names == ("frame_000000", "frame_000003", "frame_000006", "frame_000009")
    np.testing.assert_allclose(every_third.motions[1:], _robot_steps(truth[::3])[1:], atol=1e-9)
    np.testing.assert_array_equal(every_third.read(2), frames[6])
    assert [i for i, _ in every_third.frames()] == [0, 1, 2, 3]
    subset = nightloc.load_traverse(bag).subset([0, 3, 6, 9])
    np.testing.assert_allclose(subset.motions, every_third.motions, atol=1e-9)


def test_topics_chosen_by_name_when_a_kind_is_ambiguous(tmp_path, frames):
    times = [stamp_ns(T0 + i) for i in range(4)]
    odom = _circle(np.arange(4.0))
    bag = write_bag(
        tmp_path / "a", frames[:4], times, odometry=odom, extra_topics=[("/camera/image_raw/left", "image")]
    )
    with pytest.raises(
        DatasetError, match=r"2 image topics.*/camera/image_raw .*/camera/image_raw/left.*--image-topic"
    ):
        nightloc.load_traverse(bag)
    chosen = nightloc.load_traverse(bag, image_topic="/camera/image_raw")
    assert len(chosen) == 4
    with pytest.raises(DatasetError, match=r"--image-topic /nope: .*no such topic.*/odom"):
        nightloc.load_traverse(bag, image_topic="/nope")
    with pytest.raises(DatasetError, match=r"--image-topic /odom: the topic holds nav_msgs/msg/Odometry"):
        nightloc.load_traverse(bag, image_topic="/odom")
    two_odometry = write_bag(
        tmp_path / "o", frames[:4], times, odometry=odom, extra_topics=[("/wheel/odom", "odometry")]
    )
    with pytest.raises(DatasetError, match=r"2 odometry topics.*--odometry-topic"):
        nightloc.load_traverse(two_odometry)
    # an Odometry topic named as the poses leaves the other as the odometry
    both = nightloc.load_traverse(two_odometry, pose_topic="/wheel/odom", sync_tolerance=10)
    assert both.bag_topics["odometry"] == "/odom" and both.bag_topics["pose"] == "/wheel/odom"


def test_streams_that_do_not_cover_the_frames_are_named(tmp_path, frames):
    times = T0 + np.arange(6.0)
    odom = _circle(np.arange(6.0))
    far = write_bag(tmp_path / "far", frames[:6], [stamp_ns(t) for t in times], odometry=odom,
                    odometry_ns=[stamp_ns(t + 3600) for t in times])  # fmt: skip
    with pytest.raises(DatasetError, match=r"do not overlap in time: .*different clocks"):
        nightloc.load_traverse(far)
    # a gap inside the odometry stream is an error naming the frames in it
    gap = write_bag(tmp_path / "gap", frames[:6], [stamp_ns(t) for t in times], odometry=odom[[0, 1, 4, 5]],
                    odometry_ns=[stamp_ns(t) for t in times[[0, 1, 4, 5]]])  # fmt: skip
    with pytest.raises(DatasetError, match=r"2 of 6 the frames of /camera/image_raw lie more than 0.25 s from any"):
        nightloc.load_traverse(gap)
    assert len(nightloc.load_traverse(gap, sync_tolerance=1.0)) == 6
    with pytest.raises(ValueError, match="sync tolerance"):
        nightloc.load_traverse(gap, sync_tolerance=-1)


def test_frames_before_the_odometry_starts_are_skipped_with_a_warning(tmp_path, frames):
    """A camera started before the odometry: its first frames are left out, named with their
    times, and the rest of the bag is read as it would be without them."""
    times = T0 + np.arange(8.0)
    odom = _circle(times - T0)
    late = write_bag(tmp_path / "late", frames[:8], [stamp_ns(t) for t in times], odometry=odom[2:],
                     odometry_ns=[stamp_ns(t) for t in times[2:]])  # fmt: skip
    with pytest.warns(nightloc.DatasetWarning) as caught:
        traverse = nightloc.load_traverse(late)
    [warning] = caught
    message = str(warning.message)
    assert "2 of 8 frames of /camera/image_raw are skipped" in message, message
    assert f"before the odometry /odom starts at {times[2]:.3f} s ({times[0]:.3f}, {times[1]:.3f} s)" in message
    assert len(traverse) == 6 and traverse.names[0] == "frame_000002"
    np.testing.assert_allclose(traverse.timestamps, times[2:], rtol=0, atol=1e-6)
    np.testing.assert_array_equal(traverse.read(0), frames[2])
    # the motions from the first kept frame on are those of the odometry (the oracle: the drive itself)
    trimmed = write_bag(tmp_path / "trimmed", frames[2:8], [stamp_ns(t) for t in times[2:]], odometry=odom[2:])
    expected = nightloc.load_traverse(trimmed)
    np.testing.assert_allclose(
        [(m.forward, m.left, m.turn) for m in nightloc.traverse_odometry(traverse)[1:]],
        [(m.forward, m.left, m.turn) for m in nightloc.traverse_odometry(expected)[1:]],
    )
    # frames after the odometry ends too, and every third frame: counted among the kept ones
    early = write_bag(tmp_path / "early", frames[:8], [stamp_ns(t) for t in times], odometry=odom[:5],
                      odometry_ns=[stamp_ns(t) for t in times[:5]])  # fmt: skip
    with pytest.warns(nightloc.DatasetWarning, match=r"1 of 3 frames .* after the odometry /odom ends at"):
        assert nightloc.load_traverse(early, frame_step=3).names == ("frame_000000", "frame_000003")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(nightloc.load_traverse(late, sync_tolerance=2.5)) == 8  # within the tolerance: all kept


def test_unreadable_images_and_wrong_places_are_named(tmp_path, frames):
    bag = write_bag(tmp_path / "b", frames[:2], [stamp_ns(T0), stamp_ns(T0 + 1)])
    traverse = nightloc.load_traverse(bag)
    with pytest.raises(ValueError, match="image_topic applies to ROS bags"):
        nightloc.load_traverse(tmp_path, image_topic="/camera")
    with pytest.raises(ValueError, match="pose topic"):
        nightloc.load_traverse(bag, poses=tmp_path / "poses.csv")
    with pytest.raises(nightloc.MapFormatError, match=r"a traverse: build a map from it with nightloc build-map"):
        nightloc.ReferenceMap.load(bag / "b.mcap")
    from nightloc.io.bag import decode_image

    class Message:
        encoding, height, width, step, is_bigendian, data = "yuv422", 2, 2, 4, 0, np.zeros(8, np.uint8)

    with pytest.raises(DatasetError, match=r"encoding 'yuv422' is not read \(supported: .*bgr8"):
        decode_image(Message(), "sensor_msgs/msg/Image", "here")
    Message.encoding, Message.step = "bgr8", 6
    with pytest.raises(DatasetError, match="needs 6 bytes a row"):
        decode_image(Message(), "sensor_msgs/msg/Image", "here")
    assert "bag" in repr(traverse)


def test_streaming_a_long_bag_holds_a_few_frames(tmp_path):
    """Reading every frame of a 300-frame bag (69 MB of pixels) allocates at most a few frames and
    a storage chunk at a time (measured in a fresh interpreter with tracemalloc)."""
    frame = np.zeros((240, 320, 3), np.uint8)
    frames = [frame] * 300
    bag = write_bag(tmp_path / "long", frames, [stamp_ns(T0 + 0.1 * i) for i in range(300)])
    script = textwrap.dedent(
        f"""
        import tracemalloc, nightloc
        traverse = nightloc.load_traverse({str(bag)!r})
        tracemalloc.start()
        count = sum(1 for _ in traverse.frames())
        peak = tracemalloc.get_traced_memory()[1]
        print(count, peak)
        """
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    count, peak = (int(v) for v in done.stdout.split())
    assert count == 300
    assert peak < 20 * frame.nbytes, f"peak {peak / 1e6:.1f} MB while streaming {300 * frame.nbytes / 1e6:.0f} MB"


@pytest.mark.parametrize("storage", STORAGES)
def test_a_truncated_bag_is_named(tmp_path, frames, storage):
    bag = write_bag(_path(tmp_path, storage), frames, [stamp_ns(T0 + i) for i in range(len(frames))], storage=storage)
    file = bag if storage == "ros1" else next(p for p in bag.iterdir() if p.suffix in (".mcap", ".db3"))
    data = file.read_bytes()
    for size in (len(data) // 2, 0):
        file.write_bytes(data[:size])
        with pytest.raises(DatasetError, match=rf"bag {bag} cannot be read"):
            nightloc.load_traverse(bag)
