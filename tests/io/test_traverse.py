"""Traverses on disk: folder and video forms, round trips, and clear errors for bad data."""

from __future__ import annotations

import math
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

import nightloc
from nightloc import DatasetError, load_traverse, save_traverse

from video_support import write_video


def frames(n: int, h: int = 30, w: int = 40, colour: bool = True, seed: int = 0) -> list:
    rng = np.random.default_rng(seed)
    shape = (h, w, 3) if colour else (h, w)
    return [rng.integers(0, 256, size=shape, dtype=np.uint8) for _ in range(n)]


def write_csv(path: Path, text: str, encoding: str = "utf-8") -> None:
    path.write_bytes(text.encode(encoding))


def make_folder(root: Path, n: int = 3, names=None) -> list:
    (root / "images").mkdir(parents=True)
    images = frames(n)
    names = names or [f"{i}.png" for i in range(n)]
    for name, image in zip(names, images):
        cv2.imwrite(str(root / "images" / name), image)
    return images


# ------------------------------------------------------------------------------------------
# round trips


def test_save_and_load_round_trip_with_poses(tmp_path):
    images = frames(5) + frames(2, colour=False, seed=1)
    positions = np.random.default_rng(2).normal(size=(7, 2)) * 10
    headings = np.array([0.0, 1.0, -1.0, math.pi, 3.0, -3.0, 0.5])
    traverse = save_traverse(tmp_path / "t", images, positions, headings)
    assert isinstance(traverse, nightloc.Traverse)
    assert len(traverse) == 7 and traverse.has_poses
    assert traverse.names == tuple(f"{i:06d}.png" for i in range(7))
    np.testing.assert_array_equal(traverse.positions, positions)  # bit-exact through the CSV
    np.testing.assert_array_equal(traverse.headings, headings)
    for i, image in enumerate(images):
        np.testing.assert_array_equal(traverse.read(i), image)
    streamed = list(traverse.frames(batch_size=3))
    assert [i for i, _ in streamed] == list(range(7))
    for (_, image), expected in zip(streamed, images):
        np.testing.assert_array_equal(image, expected)
    again = load_traverse(tmp_path / "t")
    assert again.names == traverse.names
    assert (tmp_path / "t" / "poses.csv").read_text().splitlines()[0] == "image,x,y,heading"


def test_traverse_is_immutable(tmp_path):
    traverse = save_traverse(tmp_path / "t", frames(2), [[0, 0], [1, 0]])
    with pytest.raises(ValueError, match="read-only"):
        traverse.positions[0, 0] = 5.0
    with pytest.raises(AttributeError):
        traverse.names = ("x",)


def test_headings_are_wrapped(tmp_path):
    traverse = save_traverse(tmp_path / "t", frames(3), np.zeros((3, 2)), [2 * math.pi, -math.pi, 3 * math.pi / 2])
    np.testing.assert_allclose(traverse.headings, [0.0, math.pi, -math.pi / 2], atol=1e-12)
    assert np.all(traverse.headings > -math.pi) and np.all(traverse.headings <= math.pi)


def test_route_traverse_without_poses_is_natural_sorted(tmp_path):
    names = ["img10.png", "img2.png", "img1.png", "img100.png"]
    make_folder(tmp_path, 4, names)
    (tmp_path / "images" / "notes.txt").write_text("not an image")
    (tmp_path / "images" / ".hidden.png").write_bytes(b"x")
    traverse = load_traverse(tmp_path)
    assert traverse.names == ("img1.png", "img2.png", "img10.png", "img100.png")
    assert traverse.positions is None and traverse.headings is None and not traverse.has_poses
    assert load_traverse(tmp_path, frame_step=2).names == ("img1.png", "img10.png")


def test_folder_of_images_without_images_subfolder(tmp_path):
    for i, image in enumerate(frames(3)):
        cv2.imwrite(str(tmp_path / f"images-{i:05d}.png"), image)
    traverse = load_traverse(tmp_path)
    assert traverse.names == ("images-00000.png", "images-00001.png", "images-00002.png")
    assert traverse.image_dir == tmp_path


def test_poses_order_extra_columns_and_no_heading(tmp_path):
    make_folder(tmp_path, 3)
    write_csv(tmp_path / "poses.csv", "time, Image ,X,y\n5,2.png,1.5,2\n6,0.png,-1,3e1\n")
    traverse = load_traverse(tmp_path)
    assert traverse.names == ("2.png", "0.png")
    np.testing.assert_array_equal(traverse.positions, [[1.5, 2.0], [-1.0, 30.0]])
    assert traverse.headings is None and traverse.has_poses


def test_bom_and_crlf_are_accepted(tmp_path):
    make_folder(tmp_path, 2)
    write_csv(tmp_path / "poses.csv", "\ufeffimage,x,y,heading\r\n0.png,1,2,0.5\r\n\r\n1.png,3,4,-0.5\r\n", "utf-8")
    traverse = load_traverse(tmp_path)
    np.testing.assert_array_equal(traverse.positions, [[1, 2], [3, 4]])
    np.testing.assert_array_equal(traverse.headings, [0.5, -0.5])


def test_frame_step_and_subset(tmp_path):
    traverse = save_traverse(tmp_path / "t", frames(7), np.arange(14).reshape(7, 2))
    stepped = load_traverse(tmp_path / "t", frame_step=3)
    assert stepped.names == ("000000.png", "000003.png", "000006.png")
    np.testing.assert_array_equal(stepped.positions[:, 0], [0, 6, 12])
    part = traverse.subset([4, 1])
    assert part.names == ("000004.png", "000001.png")
    np.testing.assert_array_equal(part.read(0), traverse.read(4))
    assert traverse.subset(slice(2, 4)).names == ("000002.png", "000003.png")


def test_custom_names_jpeg_and_grey(tmp_path):
    grey = frames(2, colour=False)
    traverse = save_traverse(tmp_path / "t", grey, names=["a.jpg", "b.jpg"])
    assert traverse.names == ("a.jpg", "b.jpg") and not traverse.has_poses
    image = traverse.read(1)
    assert image.shape == grey[1].shape and image.dtype == np.uint8
    assert np.abs(image.astype(int) - grey[1]).mean() < 40  # lossy, but the same picture


def test_sixteen_bit_and_alpha_images_are_read(tmp_path):
    (tmp_path / "images").mkdir()
    deep = (np.arange(600, dtype=np.uint16).reshape(20, 30) * 100).astype(np.uint16)
    cv2.imwrite(str(tmp_path / "images" / "a.png"), deep)
    rgba = np.dstack(frames(1)[0:1] * 1 + [np.full((30, 40), 7, np.uint8)])
    cv2.imwrite(str(tmp_path / "images" / "b.png"), rgba)
    traverse = load_traverse(tmp_path)
    np.testing.assert_array_equal(traverse.read(0), deep)
    assert traverse.read(1).shape == (30, 40, 3)


def test_streaming_save_from_a_generator(tmp_path):
    def generate():
        yield from frames(4)

    traverse = save_traverse(tmp_path / "t", generate(), np.zeros((4, 2)))
    assert len(traverse) == 4


def test_overwrite_rules(tmp_path):
    save_traverse(tmp_path / "t", frames(2))
    with pytest.raises(FileExistsError, match="overwrite=True"):
        save_traverse(tmp_path / "t", frames(3))
    traverse = save_traverse(tmp_path / "t", frames(3), overwrite=True)
    assert len(traverse) == 3
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "thesis.tex").write_text("precious")
    with pytest.raises(FileExistsError, match="not a traverse"):
        save_traverse(tmp_path / "other", frames(1), overwrite=True)
    assert (tmp_path / "other" / "thesis.tex").read_text() == "precious"


def test_failed_save_leaves_nothing_behind(tmp_path):
    def broken():
        yield frames(1)[0]
        yield np.zeros((5, 5), np.float32)

    with pytest.raises(TypeError, match="uint8"):
        save_traverse(tmp_path / "t", broken())
    assert os.listdir(tmp_path) == []
    save_traverse(tmp_path / "t", frames(2))
    with pytest.raises(ValueError, match="3 positions"):
        save_traverse(tmp_path / "t", frames(2), np.zeros((3, 2)), overwrite=True)
    assert sorted(os.listdir(tmp_path)) == ["t"] and len(load_traverse(tmp_path / "t")) == 2


@pytest.mark.parametrize(
    ("kwargs", "error", "text"),
    [
        ({"positions": None, "headings": [0.0]}, ValueError, "headings need positions"),
        ({"positions": [[0, 0], [1, float("nan")]]}, ValueError, "finite"),
        ({"positions": np.zeros((2, 3))}, ValueError, r"\(N, 2\)"),
        ({"positions": np.zeros((2, 2)), "headings": [0.0]}, ValueError, "headings must be"),
        ({"names": ["a.png", "a.png"]}, ValueError, "repeats"),
        ({"names": ["sub/a.png", "b.png"]}, ValueError, "plain file name"),
        ({"names": ["a.txt", "b.png"]}, ValueError, "image suffix"),
        ({"image_format": "xyz"}, ValueError, "image_format"),
    ],
)
def test_save_argument_errors(tmp_path, kwargs, error, text):
    with pytest.raises(error, match=text):
        save_traverse(tmp_path / "t", frames(2), **kwargs)
    assert not (tmp_path / "t").exists()


def test_save_rejects_empty_and_bad_images(tmp_path):
    with pytest.raises(ValueError, match="empty"):
        save_traverse(tmp_path / "t", [])
    with pytest.raises(ValueError, match="shape"):
        save_traverse(tmp_path / "t", [np.zeros((4, 4, 5), np.uint8)])
    with pytest.raises(TypeError, match="ndarray"):
        save_traverse(tmp_path / "t", [[1, 2, 3]])
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------------------------------
# errors on bad data


def expect_dataset_error(path, *texts, **kwargs):
    def load_and_read_every_frame():
        traverse = load_traverse(path, **kwargs)
        for i in range(len(traverse)):
            traverse.read(i)

    with pytest.raises(DatasetError) as info:
        load_and_read_every_frame()
    message = str(info.value)
    for text in texts:
        assert text in message, message
    assert isinstance(info.value, ValueError) and isinstance(info.value, nightloc.NightlocError)
    return message


def test_missing_traverse_and_empty_folder(tmp_path):
    expect_dataset_error(tmp_path / "nope", "does not exist")
    expect_dataset_error(tmp_path, "not a traverse")
    (tmp_path / "images").mkdir()
    expect_dataset_error(tmp_path, "no image files")


@pytest.mark.parametrize(
    ("csv_text", "texts"),
    [
        ("image,x\n0.png,1\n", ["line 1", "missing column 'y'"]),
        ("name,x,y\n0.png,1,2\n", ["line 1", "missing column 'image'"]),
        ("image,x,y\n0.png,1,2\n1.png,abc,2\n", ["line 3", "'x'", "'abc'", "not a number"]),
        ("image,x,y\n0.png,1,nan\n", ["line 2", "'y'", "finite"]),
        ("image,x,y,heading\n0.png,1,2,inf\n", ["line 2", "heading"]),
        ("image,x,y\n0.png,1,\n", ["line 2", "empty"]),
        ("image,x,y\n0.png,1,2\n1.png,1,2\n0.png,3,4\n", ["line 4", "listed twice", "line 2"]),
        ("image,x,y\n0.png,1,2\n9.png,1,2\n", ["line 3", "9.png", "does not exist"]),
        ("image,x,y\n0.png,1,2,3\n", ["line 2", "4 fields"]),
        ("image,x,y\n", ["no rows"]),
        ("", ["empty"]),
        ("image,x,y\n../0.png,1,2\n", ["line 2", "inside"]),
        ("image,x,x,y\n0.png,1,2,3\n", ["appears twice"]),
    ],
)
def test_bad_poses_csv(tmp_path, csv_text, texts):
    make_folder(tmp_path, 2)
    write_csv(tmp_path / "poses.csv", csv_text)
    message = expect_dataset_error(tmp_path, *texts)
    assert "poses.csv" in message


def test_crlf_line_numbers(tmp_path):
    make_folder(tmp_path, 2)
    write_csv(tmp_path / "poses.csv", "image,x,y\r\n0.png,1,2\r\n\r\n1.png,x,2\r\n")
    expect_dataset_error(tmp_path, "line 4")


def test_non_utf8_csv(tmp_path):
    make_folder(tmp_path, 1)
    (tmp_path / "poses.csv").write_bytes(b"image,x,y\n\xff\xfe.png,1,2\n")
    expect_dataset_error(tmp_path, "UTF-8")


@pytest.mark.parametrize("suffix", [".png", ".jpg"])
@pytest.mark.parametrize("damage", ["truncate", "empty", "text"])
def test_bad_image_files_name_the_file_and_line(tmp_path, suffix, damage):
    (tmp_path / "images").mkdir()
    image = frames(1, h=120, w=160)[0]
    for i in range(2):
        cv2.imwrite(str(tmp_path / "images" / f"{i}{suffix}"), image)
    bad = tmp_path / "images" / f"1{suffix}"
    data = bad.read_bytes()
    bad.write_bytes({"truncate": data[: len(data) * 2 // 3], "empty": b"", "text": b"hello, I am not an image"}[damage])
    write_csv(tmp_path / "poses.csv", f"image,x,y\n0{suffix},0,0\n1{suffix},1,0\n")
    expect_dataset_error(tmp_path, f"1{suffix}", "line 3")
    # without poses the message still names the file
    os.remove(tmp_path / "poses.csv")
    expect_dataset_error(tmp_path, f"1{suffix}")


def test_error_in_frames_names_the_file(tmp_path):
    traverse = save_traverse(tmp_path / "t", frames(6), np.zeros((6, 2)))
    (tmp_path / "t" / "images" / "000004.png").write_bytes(b"garbage")
    seen = []
    with pytest.raises(DatasetError, match=r"000004\.png.*line 6"):
        seen.extend(index for index, _ in traverse.frames(batch_size=4))
    assert seen == [0, 1, 2, 3]


def test_read_index_checks(tmp_path):
    traverse = save_traverse(tmp_path / "t", frames(2))
    with pytest.raises(IndexError):
        traverse.read(2)
    with pytest.raises(TypeError):
        traverse.read(1.0)
    np.testing.assert_array_equal(traverse.read(-1), traverse.read(1))
    with pytest.raises(ValueError, match="batch_size"):
        next(traverse.frames(batch_size=0))
    with pytest.raises(ValueError, match="frame_step"):
        load_traverse(tmp_path / "t", frame_step=0)


def test_poses_argument_overrides_folder_csv(tmp_path):
    make_folder(tmp_path / "t", 2)
    write_csv(tmp_path / "other.csv", "image,x,y\n1.png,5,6\n")
    traverse = load_traverse(tmp_path / "t", poses=tmp_path / "other.csv")
    assert traverse.names == ("1.png",)
    with pytest.raises(DatasetError, match="does not exist"):
        load_traverse(tmp_path / "t", poses=tmp_path / "missing.csv")


# ------------------------------------------------------------------------------------------
# videos


def frame_level(image: np.ndarray) -> int:
    return int(round(float(np.median(image[image.shape[0] // 2 :]))))


@pytest.fixture
def video(tmp_path):
    if not cv2.haveImageWriter("x.jpg"):
        pytest.skip("OpenCV lacks JPEG support")
    path = tmp_path / "drive.avi"
    levels = write_video(path, 12)
    if not cv2.VideoCapture(str(path)).isOpened():
        pytest.skip("this OpenCV build cannot read MJPG AVI files")
    return path, levels


def test_video_without_poses(video):
    path, levels = video
    traverse = load_traverse(path, frame_step=5)
    assert traverse.is_video and traverse.frame_indices == (0, 5, 10)
    assert traverse.names == ("frame_000000", "frame_000005", "frame_000010")
    assert not traverse.has_poses
    got = [frame_level(image) for _, image in traverse.frames()]
    assert all(abs(g - levels[f]) <= 3 for g, f in zip(got, (0, 5, 10)))
    assert abs(frame_level(traverse.read(1)) - levels[5]) <= 3  # random access


def test_video_with_poses_csv(video, tmp_path):
    path, levels = video
    write_csv(tmp_path / "odo.csv", "frame,x,y,heading\n4,4,0,0.4\n0,0,0,0\n2,2,0,0.2\n3,3,0,0.3\n")
    traverse = load_traverse(path, poses=tmp_path / "odo.csv", frame_step=2)
    assert traverse.frame_indices == (0, 2, 4)  # sorted by frame, multiples of 2
    np.testing.assert_array_equal(traverse.positions[:, 0], [0, 2, 4])
    np.testing.assert_array_equal(traverse.headings, [0.0, 0.2, 0.4])
    got = [frame_level(image) for _, image in traverse.frames()]
    assert all(abs(g - levels[f]) <= 3 for g, f in zip(got, (0, 2, 4)))


def test_video_poses_errors(video, tmp_path):
    path, _ = video
    write_csv(tmp_path / "odo.csv", "frame,x,y\n0,0,0\n40,1,1\n")
    expect_dataset_error(path, "line 3", "past the end", poses=tmp_path / "odo.csv")
    write_csv(tmp_path / "odo.csv", "frame,x,y\n0,0,0\n1.5,1,1\n")
    expect_dataset_error(path, "line 3", "frame index", poses=tmp_path / "odo.csv")
    write_csv(tmp_path / "odo.csv", "frame,x,y\n0,0,0\n-1,1,1\n")
    expect_dataset_error(path, "line 3", "negative", poses=tmp_path / "odo.csv")


def test_unreadable_video(tmp_path):
    bad = tmp_path / "broken.mp4"
    bad.write_bytes(b"\x00" * 100)
    expect_dataset_error(bad, "broken.mp4", "cannot be opened")
    single = tmp_path / "one.png"
    cv2.imwrite(str(single), frames(1)[0])
    expect_dataset_error(single, "single file")


# ------------------------------------------------------------------------------------------
# real data


def test_nordland_folder_loads_as_route_traverse(shared_data):
    folder = shared_data / "nordland" / "summer"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    traverse = load_traverse(folder)
    assert len(traverse) == 3576 and not traverse.has_poses
    assert list(traverse.names) == sorted(os.listdir(folder))  # zero-padded: natural = plain order
    part = traverse.subset(slice(1000, 1010))
    images = [image for _, image in part.frames()]
    assert all(image.shape == (32, 64, 3) and image.dtype == np.uint8 for image in images)
    np.testing.assert_array_equal(images[0], cv2.imread(str(folder / traverse.names[1000])))


def test_save_traverse_writes_the_frames_times_into_both_csv_files(tmp_path):
    frames = [np.full((8, 16, 3), 30 * k, np.uint8) for k in range(3)]
    times = [12.5, 12.75, 13.0]
    motions = [None, nightloc.RobotMotion(0.3, 0.0, 0.1), nightloc.RobotMotion(0.3, 0.0, 0.0)]
    saved = nightloc.save_traverse(tmp_path / "t", frames, np.zeros((3, 2)), np.zeros(3), odometry=motions,
                                   timestamps=times)  # fmt: skip
    assert saved.timestamps.tolist() == times
    for name in ("poses.csv", "odometry.csv"):
        header, *rows = (saved.root / name).read_text().splitlines()
        assert header.endswith(",timestamp") and [float(r.rsplit(",", 1)[1]) for r in rows] == times
    odometry_only = nightloc.save_traverse(tmp_path / "o", frames, odometry=motions, timestamps=times)
    assert odometry_only.timestamps.tolist() == times and not (odometry_only.root / "poses.csv").exists()
    with pytest.raises(ValueError, match=r"timestamps\[2\] = 1.0 is before timestamps\[1\]"):
        nightloc.save_traverse(tmp_path / "b", frames, np.zeros((3, 2)), timestamps=[0.0, 2.0, 1.0])
    with pytest.raises(ValueError, match="pass positions or odometry"):
        nightloc.save_traverse(tmp_path / "c", frames, timestamps=times)
    with pytest.raises(ValueError, match="2 timestamps but 3 images"):
        nightloc.save_traverse(tmp_path / "d", frames, np.zeros((3, 2)), timestamps=times[:2])
    assert not [p.name for p in tmp_path.iterdir() if p.name not in ("t", "o")]
