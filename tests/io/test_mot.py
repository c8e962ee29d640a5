
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
