import re
import struct
import zlib

import numpy as np
import pandas as pd
import pytest

from tunnelsense import Tour
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import (
    open_tour,
    read_image,
    read_image_folder,
    read_mot_gt,
    read_mot_results,
    read_tour,
    read_video,
    write_mot_results,
    write_tour,
)


def _gt():
    return pd.DataFrame(
        {
            "frame": [1, 2, 2, 3],
            "id": [1, 1, 2, 5],
            "bb_left": [1.5, 2.25, 3.0, 0.1],
            "bb_top": [1.0, 2.0, 3.1, 0.2],
            "bb_width": [4.0, 5.0, 6.0, 1 / 3],
            "bb_height": [7.0, 8.0, 9.0, 2.0],
            "conf": 1.0,
            "class": [1, 1, 2, 4],
            "visibility": [1.0, 0.5, 1 / 3, 0.9],
        }
    )


@pytest.fixture(params=[np.uint8, np.uint16], ids=["8bit", "16bit"])
def tour(request, global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    info = np.iinfo(request.param)
    images = rng.integers(0, info.max, (4, 24, 32), dtype=request.param, endpoint=True)
    return Tour.from_array(
        "seq-a",
        images,
        _gt(),
        frame_rate=25.0,
        info={"scenario": "light", "focal_px": 512.5},
    )


def test_round_trip_is_identical(tour, tmp_path):
    write_tour(tour, tmp_path / "seq-a")
    back = read_tour(tmp_path / "seq-a")
    assert back.name == "seq-a" and back.frame_rate == 25.0 and len(back) == 4
    for a, b in zip(tour.frames, back.frames, strict=True):
        assert a.key == b.key
        assert b.image.dtype == a.image.dtype
        assert np.array_equal(a.image, b.image)
    pd.testing.assert_frame_equal(back.gt, tour.gt)
    assert back.info == {"scenario": "light", "focal_px": "512.5"}
    # and a second write gives the same files
    write_tour(back, tmp_path / "again")
    for name in ("gt/gt.txt", "seqinfo.ini", "img1/000003.png"):
        assert (tmp_path / "again" / name).read_bytes() == (
            tmp_path / "seq-a" / name
        ).read_bytes()


def test_folder_from_another_program_loads(tmp_path):
    """MOTChallenge conventions as other tools write them: ints, spaces, no gt."""
    import cv2

    seq = tmp_path / "MOT-ext"
    (seq / "frames").mkdir(parents=True)
    for i in range(1, 4):
        cv2.imwrite(
            str(seq / "frames" / f"{i:06d}.png"), np.full((10, 12), i, np.uint8)
        )
    (seq / "seqinfo.ini").write_text(
        "[Sequence]\nname=MOT-ext\nimDir=frames\nframeRate=30\nseqLength=3\n"
        "imWidth=12\nimHeight=10\nimExt=.png\n"
    )
    (seq / "gt").mkdir()
    (seq / "gt" / "gt.txt").write_text(
        "1, 3, 10, 20, 5, 8, 1, 1, 1\n\n2,3,11,21,5,8,1,1,0.5\n"
    )
    tour = read_tour(seq)
    assert len(tour) == 3 and tour.frames[2].image[0, 0] == 3
    assert tour.gt["id"].tolist() == [3, 3] and tour.gt["bb_left"].tolist() == [
        10.0,
        11.0,
    ]
    assert tour.boxes()[0].tolist() == [[10.0, 20.0, 5.0, 8.0]]
    assert len(open_tour(seq)) == 3


def test_missing_folder_and_seqinfo(tmp_path):
    with pytest.raises(FileNotFoundError, match="tour folder not found"):
        read_tour(tmp_path / "nope")
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="seqinfo.ini not found"):
        read_tour(tmp_path / "empty")


def test_seqinfo_missing_keys(tour, tmp_path):
    write_tour(tour, tmp_path / "s")
    ini = tmp_path / "s" / "seqinfo.ini"
    ini.write_text(
        "\n".join(
            line
            for line in ini.read_text().splitlines()
            if not line.startswith(("imWidth", "frameRate"))
        )
    )
    with pytest.raises(
        ValueError,
        match=r"seqinfo.ini: \[Sequence\] lacks required "
        r"key\(s\) frameRate, imWidth",
    ):
        read_tour(tmp_path / "s")


def test_missing_frame_file(tour, tmp_path):
    write_tour(tour, tmp_path / "s")
    (tmp_path / "s" / "img1" / "000002.png").unlink()
    with pytest.raises(FileNotFoundError, match=r"000002.png: frame file not found"):
        read_tour(tmp_path / "s")
    # a recorder's lost frame: the frames kept keep their numbers
    back = read_tour(tmp_path / "s", missing_frames="gap")
    assert [r.frame for r in back.frames] == [1, 3, 4]
    assert np.array_equal(back.frames[1].image, tour.frames[2].image)
    with pytest.raises(ValueError, match="missing_frames must be"):
        read_tour(tmp_path / "s", missing_frames="skip")


def test_frames_with_gaps_round_trip(tour, tmp_path):
    """A tour whose frame numbers have gaps (frames a recorder lost) is written as
    the files of its numbers and read back with its gaps."""
    kept = [tour.frames[i] for i in (0, 2, 3)]
    gapped = Tour("seq-a", kept, tour.gt[tour.gt.frame != 2].reset_index(drop=True),
                  25.0, {})
    write_tour(gapped, tmp_path / "g")
    assert sorted(p.name for p in (tmp_path / "g" / "img1").iterdir()) == [
        "000001.png", "000003.png", "000004.png"]
    with pytest.raises(FileNotFoundError, match="000002.png"):
        read_tour(tmp_path / "g")
    back = read_tour(tmp_path / "g", missing_frames="gap")
    assert [r.frame for r in back.frames] == [1, 3, 4]
    for a, b in zip(kept, back.frames, strict=True):
        assert np.array_equal(a.image, b.image)
    pd.testing.assert_frame_equal(back.gt, gapped.gt)
    # rewriting without the gap removes no frame of its own, and the lost one stays lost
    write_tour(back, tmp_path / "g")
    assert len(list((tmp_path / "g" / "img1").iterdir())) == 3
    # frames out of order or numbered below 1 cannot be written
    for frames in ([kept[1], kept[0]], [tour.frames[0].__class__("seq-a", 0,
                                                              tour.frames[0].image)]):
        with pytest.raises(InputFormatError, match="increasing order from 1"):
            write_tour(Tour("seq-a", frames, None, 25.0, {}), tmp_path / "bad")


@pytest.mark.parametrize(
    "line, message",
    [
        ("1,1,2,3,4,5,1,1\n", r"gt.txt, line 2: 8 columns, expected 9"),
        ("1,1,2,3,4,5,1,1,1,7\n", r"gt.txt, line 2: 10 columns, expected 9"),
        (
            "1,1,2,three,4,5,1,1,1\n",
            r"gt.txt, line 2: column 'bb_top' is 'three', expected a number",
        ),
        (
            "1.5,1,2,3,4,5,1,1,1\n",
            r"gt.txt, line 2: column 'frame' is '1.5', expected an integer",
        ),
    ],
)
def test_bad_gt_lines(tmp_path, line, message):
    gt = tmp_path / "gt.txt"
    gt.write_text("1,1,2,3,4,5,1,1,1\n" + line)
    with pytest.raises(ValueError, match=message):
        read_mot_gt(gt)


def test_gt_frame_outside_sequence(tour, tmp_path):
    write_tour(tour, tmp_path / "s")
    with open(tmp_path / "s" / "gt" / "gt.txt", "a") as f:
        f.write("9,1,2,3,4,5,1,1,1\n")
    with pytest.raises(ValueError, match=r"gt.txt, line 5: frame 9 is outside 1..4"):
        read_tour(tmp_path / "s")


def test_frames_of_different_sizes(tour, tmp_path):
    import cv2

    write_tour(tour, tmp_path / "s")
    cv2.imwrite(str(tmp_path / "s" / "img1" / "000003.png"), np.zeros((5, 5), np.uint8))
    with pytest.raises(
        ValueError, match=r"000003.png: frame is 5x5 px, expected 32x24 px"
    ):
        read_tour(tmp_path / "s")
    with pytest.raises(ValueError, match=r"000003.png: frame is 5x5 px"):
        read_image_folder(tmp_path / "s" / "img1")


def test_truncated_and_corrupt_png(tour, tmp_path):
    write_tour(tour, tmp_path / "s")
    f = tmp_path / "s" / "img1" / "000002.png"
    data = f.read_bytes()
    f.write_bytes(data[: len(data) // 2])
    back = read_tour(tmp_path / "s")  # headers are fine: frames decode lazily
    assert np.array_equal(back.frames[0].image, tour.frames[0].image)
    with pytest.raises(ValueError, match=r"000002.png: truncated PNG"):
        _ = back.frames[1].image
    f.write_bytes(data[:100] + b"\x00" * 50 + data[150:])
    with pytest.raises(ValueError, match=r"000002.png: corrupt image"):
        read_image(f)
    f.write_bytes(b"")
    with pytest.raises(ValueError, match="000002.png: empty file"):
        read_image(f)
    f.write_bytes(b"not a png at all")
    with pytest.raises(ValueError, match="000002.png: not a PNG file"):
        read_tour(tmp_path / "s")


def test_image_folder_sorted_by_name_and_colour_to_grey(tmp_path):
    import cv2

    for name, value in (("b.png", 2), ("a.png", 1), ("c.tif", 3)):
        image = np.full((4, 5, 3), value, np.uint8)
        cv2.imwrite(str(tmp_path / name), image)
    (tmp_path / "notes.txt").write_text("ignored")
    tour = read_image_folder(tmp_path)
    assert [r.image[0, 0] for r in tour.frames] == [1, 2, 3]
    assert tour.frames[0].image.shape == (4, 5)
    assert tour.gt.empty


def test_empty_image_folder(tmp_path):
    with pytest.raises(ValueError, match="no image files"):
        read_image_folder(tmp_path)


def test_video_round_trip(tmp_path):
    import cv2

    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, (32, 24))
    assert writer.isOpened()
    for i in range(5):
        writer.write(np.full((24, 32, 3), 40 * i, np.uint8))
    writer.release()
    tour = read_video(path)
    assert len(tour) == 5 and tour.frame_rate == pytest.approx(30)
    means = [float(r.image.mean()) for r in tour.frames]
    assert means == pytest.approx([0, 40, 80, 120, 160], abs=4)
    assert tour.frames[0].image.shape == (24, 32)
    (tmp_path / "bad.avi").write_bytes(b"garbage" * 10)
    with pytest.raises(ValueError, match="bad.avi"):
        read_video(tmp_path / "bad.avi")


def test_results_round_trip(tmp_path):
    res = pd.DataFrame(
        {
            "frame": [1, 2],
            "id": [4, 4],
            "bb_left": [1.0, 2.5],
            "bb_top": [3.0, 4.0],
            "bb_width": [5.0, 6.0],
            "bb_height": [7.0, 8.0],
            "conf": [0.9, 0.75],
        }
    )
    write_mot_results(res, tmp_path / "res.txt")
    assert (tmp_path / "res.txt").read_text().splitlines()[0] == (
        "1,4,1.0,3.0,5.0,7.0,0.9,-1,-1,-1"  # as detect tunnel writes
    )
    back = read_mot_results(tmp_path / "res.txt")
    pd.testing.assert_frame_equal(back[list(res.columns)], res)
    assert (back[["x", "y", "z"]] == -1).all().all()


def test_gt_errors_name_the_right_line_despite_blank_lines(tour, tmp_path):
    write_tour(tour, tmp_path / "s")
    gt = tmp_path / "s" / "gt" / "gt.txt"
    gt.write_text("1,1,2,3,4,5,1,1,1\n\n\n2,1,2,3,4,5,1,1,1\n9,1,2,3,4,5,1,1,1\n")
    with pytest.raises(ValueError, match=r"gt.txt, line 5: frame 9 is outside 1..4"):
        read_tour(tmp_path / "s")
    gt.write_text("1,1,2,3,4,5,1,1,1\n\n2,1,nan,3,4,5,1,1,1\n")
    with pytest.raises(ValueError, match=r"gt.txt, line 3: NaN or infinity"):
        read_mot_gt(gt)
    gt.write_text("1,1,2,3,-4,5,1,1,1\n")
    with pytest.raises(ValueError, match=r"gt.txt, line 1: negative box width"):
        read_mot_gt(gt)


def test_seqinfo_with_bom_and_lower_case_section(tour, tmp_path):
    write_tour(tour, tmp_path / "s")
    ini = tmp_path / "s" / "seqinfo.ini"
    ini.write_text("\ufeff" + ini.read_text().replace("[Sequence]", "[sequence]"))
    assert len(read_tour(tmp_path / "s")) == 4


def test_natural_order_and_hidden_files(tmp_path):
    import cv2

    for i in (1, 2, 10):
        cv2.imwrite(str(tmp_path / f"frame_{i}.png"), np.full((3, 3), i, np.uint8))
    (tmp_path / "._frame_3.png").write_bytes(b"macOS resource fork")
    tour = read_image_folder(tmp_path)
    assert [int(r.image[0, 0]) for r in tour.frames] == [1, 2, 10]


def test_png_with_bytes_after_iend_is_not_truncated(tour, tmp_path):
    write_tour(tour, tmp_path / "s")
    f = tmp_path / "s" / "img1" / "000001.png"
    f.write_bytes(f.read_bytes() + b"\x00" * 64)
    assert np.array_equal(read_image(f), tour.frames[0].image)


def test_rewriting_a_shorter_tour_removes_stale_frames(tour, tmp_path):
    write_tour(tour, tmp_path / "s")
    short = Tour.from_array("seq-a", np.stack([r.image for r in tour.frames][:2]))
    write_tour(short, tmp_path / "s")
    assert sorted(p.name for p in (tmp_path / "s" / "img1").iterdir()) == [
        "000001.png",
        "000002.png",
    ]
    assert len(read_tour(tmp_path / "s")) == 2


def test_a_single_non_video_file_is_not_a_tour(tmp_path):
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(ValueError, match="notes.txt: a single file of this kind is not a tour"):
        open_tour(tmp_path / "notes.txt")


# --------------------------------------------------------------------------------------
# Bad input is an InputFormatError naming the file and line, never a wrong answer
# --------------------------------------------------------------------------------------
GOOD_LINE = "1,1,2,3,4,5,1,1,1\n"


@pytest.mark.parametrize(
    "line, message",
    [
        ("0,1,2,3,4,5,1,1,1\n", r"line 2: column 'frame' is 0, expected a frame number "
                                r"of 1 or more"),
        ("-3,1,2,3,4,5,1,1,1\n", r"line 2: column 'frame' is -3, expected"),
        (f"{2**53 + 1},1,2,3,4,5,1,1,1\n",
         r"line 2: integer column out of range: 'frame'"),
        ("1,99999999999999999999999,2,3,4,5,1,1,1\n",
         r"line 2: integer column out of range: 'id'"),
        ("1_0,1,2,3,4,5,1,1,1\n", r"line 2: column 'frame' is '1_0', expected a"),
        ("1,1,\u0662,3,4,5,1,1,1\n", r"line 2: column 'bb_left' is '\u0662', expected"),
        # a form feed does not end a line (str.splitlines would say it does)
        ("1,1,2,3\x0c9,4,5,1,1,1\n", r"line 2: column 'bb_top' is '3\\x0c9', expected"),
        ("1,1,2,3,4,inf,1,1,1\n", r"line 2: NaN or infinity"),
    ],
)
def test_bad_table_fields_are_refused(tmp_path, line, message):
    for reader, extra in ((read_mot_gt, ""), (read_mot_results, ",-1")):
        path = tmp_path / "t.txt"
        path.write_text((GOOD_LINE + line).replace("\n", extra + "\n"))
        with pytest.raises(InputFormatError, match=r"t.txt, " + message):
            reader(path)


def test_non_utf8_bytes_name_the_line(tmp_path):
    path = tmp_path / "gt.txt"
    path.write_bytes(GOOD_LINE.encode() * 2 + b"1,1,\xff2,3,4,5,1,1,1\n")
    with pytest.raises(InputFormatError, match=r"gt.txt, line 3: not UTF-8 text"):
        read_mot_gt(path)


def test_seqinfo_numbers_and_encoding(tour, tmp_path):
    write_tour(tour, tmp_path / "s")
    ini = tmp_path / "s" / "seqinfo.ini"
    text = ini.read_text()
    for key, value in (("seqLength", "0_4"), ("seqLength", "\u0664"),
                       ("frameRate", "2_5")):
        ini.write_text(re.sub(rf"{key} = \S+", f"{key} = {value}", text))
        with pytest.raises(InputFormatError, match=rf"seqinfo.ini: {key} is '{value}'"):
            read_tour(tmp_path / "s")
    ini.write_bytes(text.replace("name = seq-a", "name = s\xe9q").encode("latin-1"))
    with pytest.raises(InputFormatError, match=r"seqinfo.ini, line 2: not UTF-8 text"):
        read_tour(tmp_path / "s")


def test_img1_file_names(tour, tmp_path):
    seq = write_tour(tour, tmp_path / "s")
    img1 = seq / "img1"
    (img1 / "\u00b2\u00b3.png").write_bytes(b"not a frame")  # superscripts: no number
    (img1 / "000004.png").rename(img1 / "4.png")  # not zero-padded: still frame 4
    back = read_tour(seq)
    assert [r.frame for r in back.frames] == [1, 2, 3, 4]
    assert np.array_equal(back.frames[3].image, tour.frames[3].image)
    (img1 / "0004.png").write_bytes((img1 / "4.png").read_bytes())
    with pytest.raises(InputFormatError, match=r"img1: 0004.png and 4.png both hold "
                                               r"frame 4"):
        read_tour(seq)
    (img1 / "0004.png").unlink()
    (img1 / "4.png").unlink()
    (img1 / "000004.png").mkdir()
    with pytest.raises(FileNotFoundError, match=r"000004.png: frame file not found"):
        read_tour(seq)
    (img1 / "000004.png").rmdir()
    write_tour(tour, seq)  # over a folder holding a name of superscript digits
    assert (img1 / "\u00b2\u00b3.png").exists() and len(read_tour(seq)) == 4


def test_image_folder_odd_names(tour, tmp_path):
    data = (write_tour(tour, tmp_path / "s") / "img1" / "000001.png").read_bytes()
    folder = tmp_path / "frames"
    folder.mkdir()
    for name in ("1\u00b22.png", "a.png"):  # a superscript between digits
        (folder / name).write_bytes(data)
    assert len(read_image_folder(folder)) == 2
    other = tmp_path / "huge"
    other.mkdir()
    for name in ("f_1.png", "f_99999999999999999999999.png"):
        (other / name).write_bytes(data)
    with pytest.raises(InputFormatError, match=r"f_99999999999999999999999.png: frame "
                                               r"number out of range"):
        read_image_folder(other)


def _png_header(width, height):
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
            + chunk(b"IDAT", zlib.compress(b"")) + chunk(b"IEND", b""))


def test_image_too_large_for_opencv(tmp_path):
    path = tmp_path / "big.png"
    path.write_bytes(_png_header(1_000_000, 1_000_000))
    with pytest.raises(InputFormatError, match=r"big.png: OpenCV refused the image"):
        read_image(path)


def test_a_truncated_video_is_refused_by_read_video(tmp_path):
    import cv2

    path = tmp_path / "v.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, (32, 24),
                             False)
    for i in range(40):
        writer.write(np.full((24, 32), 5 * i, np.uint8))
    writer.release()
    assert len(read_video(path)) == len(open_tour(path)) == 40
    cut = tmp_path / "cut.avi"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    message = r"cut.avi: the video ends after \d+ frames, but its header states 40"
    with pytest.raises(InputFormatError, match=message):
        read_video(cut)
    with pytest.raises(InputFormatError, match=message):
        open_tour(cut)
    assert 0 < len(read_video(cut, check_length=False)) < 40


def test_imdir_outside_the_sequence_folder_is_refused(tour, tmp_path):
    seq = write_tour(tour, tmp_path / "s")
    ini = seq / "seqinfo.ini"
    text = ini.read_text()
    for name in (str(seq / "img1"), "../s/img1"):
        ini.write_text(text.replace("imDir = img1", f"imDir = {name}"))
        with pytest.raises(InputFormatError,
                           match=r"seqinfo.ini: imDir is .*, expected a folder inside"):
            read_tour(seq)


def test_seq_length_shorter_than_img1_names_both_numbers(tour, tmp_path):
    seq = write_tour(tour, tmp_path / "s")
    ini = seq / "seqinfo.ini"
    ini.write_text(ini.read_text().replace("seqLength = 4", "seqLength = 3"))
    with pytest.raises(InputFormatError, match=r"seqinfo.ini: seqLength is 3, but .*img1 "
                                               r"holds 1 more frame\(s\), up to "
                                               r"000004.png \(4 frame files in all\)"):
        read_tour(seq)
