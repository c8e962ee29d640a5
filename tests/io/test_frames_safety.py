"""Frame sources: every bad input is a clear error naming the file, never a wrong answer."""

import shutil

import cv2
import numpy as np
import pytest

from tunnelsense._cli import main
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import (
    iter_video,
    open_tour,
    read_image_folder,
    read_tour,
    write_tour,
)


@pytest.fixture(scope="module")
def tour_dir(tmp_path_factory):
    tour = make_tunnel_tour(12, random_state=0, name="t")
    return write_tour(tour, tmp_path_factory.mktemp("tour") / "t")


def test_a_missing_file_in_an_image_folder_keeps_the_true_numbers(tour_dir, tmp_path):
    folder = shutil.copytree(tour_dir / "img1", tmp_path / "frames")
    (folder / "000004.png").unlink()
    tour = read_image_folder(folder)
    assert [r.frame for r in tour.frames] == [1, 2, 3, *range(5, 13)]
    assert tour.frames[3].source.path.endswith("000005.png")


def test_image_folder_numbered_from_zero_and_by_name(tour_dir, tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    for k in (0, 1, 2, 10):
        shutil.copy(tour_dir / "img1" / "000001.png", folder / f"cam_{k}.png")
    assert [r.frame for r in read_image_folder(folder).frames] == [1, 2, 3, 11]
    shutil.copy(tour_dir / "img1" / "000001.png", folder / "cam_002.png")
    with pytest.raises(InputFormatError, match="both hold frame 2"):
        read_image_folder(folder)
    # names without numbers: in order
    other = tmp_path / "named"
    other.mkdir()
    for n in ("a", "b", "c"):
        shutil.copy(tour_dir / "img1" / "000001.png", other / f"{n}.png")
    assert [r.frame for r in read_image_folder(other).frames] == [1, 2, 3]


def test_seq_length_must_match_the_frames(tour_dir, tmp_path):
    folder = shutil.copytree(tour_dir, tmp_path / "t")
    ini = folder / "seqinfo.ini"
    ini.write_text(ini.read_text().replace("seqLength = 12", "seqLength = 8"))
    with pytest.raises(InputFormatError,
                       match=r"seqLength is 8, but .*img1 holds 4 more frame\(s\), up to "
                             r"000012.png"):
        read_tour(folder)
    ini.write_text(ini.read_text().replace("seqLength = 8", "seqLength = 13"))
    with pytest.raises(FileNotFoundError, match="000013.png: frame file not found"):
        read_tour(folder)
    ini.write_text(ini.read_text().replace("seqLength = 13", "seqLength = 12")
                   .replace("frameRate = 30", "frameRate = nan"))
    with pytest.raises(InputFormatError, match="frameRate is 'nan', expected a positive"):
        read_tour(folder)


def _video(path, n):
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, (64, 48),
                             False)
    for i in range(n):
        writer.write(np.full((48, 64), 3 * i, np.uint8))
    writer.release()
    return path


def test_a_truncated_video_is_an_error_after_its_frames(tmp_path):
    whole = _video(tmp_path / "v.avi", 60)
    assert len(list(iter_video(whole))) == 60
    cut = tmp_path / "cut.avi"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    seen = []
    with pytest.raises(InputFormatError, match=r"cut.avi: the video ends after \d+ "
                                               "frames, but its header states 60"):
        for image in iter_video(cut):
            seen.append(image)
    assert 0 < len(seen) < 60


def test_gt_txt_with_huge_integers(tour_dir, tmp_path):
    folder = shutil.copytree(tour_dir, tmp_path / "t")
    gt = folder / "gt" / "gt.txt"
    gt.write_text("99999999999999999999999,1,10,10,5,9,1,1,1.0\n")
    with pytest.raises(InputFormatError, match=r"gt.txt, line 1: integer column out"):
        read_tour(folder)


@pytest.mark.slow
def test_detect_refuses_frames_of_another_depth(tour_dir, tmp_path, capsys):
    tour = make_tunnel_tour(150, random_state=1, first_indicator_m=40.0)
    train = write_tour(tour, tmp_path / "train")
    model = tmp_path / "m.skops"
    assert main(["train", "tunnel", str(train), "--model", str(model), "--quiet"]) == 0
    wide = tmp_path / "wide"
    wide.mkdir()
    for f in sorted((tour_dir / "img1").glob("*.png")):
        image = cv2.imread(str(f), cv2.IMREAD_UNCHANGED).astype(np.uint16) * 257
        cv2.imwrite(str(wide / f.name), image)
    out = tmp_path / "r.txt"
    assert main(["detect", "tunnel", "--model", str(model), str(wide), "--out",
                 str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    # refused before any output, naming the first frame's file and both types
    assert "000001.png: frame 1 is uint16, but the detector was fitted on uint8" in err
    assert not out.exists()
    assert open_tour(wide).frames[0].image.dtype == np.uint16


def test_video_frames_carry_the_header_s_frame_rate(tmp_path):
    from tunnelsense.io import open_tour
    from tunnelsense.tunnel._detect import open_frames

    path = tmp_path / "v9.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 9, (64, 48),
                             False)
    for i in range(3):
        writer.write(np.full((48, 64), 3 * i, np.uint8))
    writer.release()
    frames, total = open_frames(path)
    assert [r.payload["frame_rate"] for r in frames] == [9.0] * total
    assert {r.payload["frame_rate"] for r in open_tour(path).frames} == {9.0}
