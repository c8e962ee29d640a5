import re
import struct
import zlib

import numpy as np
import pytest

from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import (
    open_tour,
    read_image,
    read_image_folder,
    read_mot_gt,
    read_mot_results,
    read_tour,
    read_video,
    write_tour,
)

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
