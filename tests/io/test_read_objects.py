"""read_objects: every malformed object table is an InputFormatError naming the line."""

import pytest

from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import read_objects

GOOD = "id,first_scan,last_scan,label,mean_depth\n1,3,9,parked,4.5\n2,10,12,passing,7.0\n"


def test_a_good_table_reads():
    import pathlib
    import tempfile

    path = pathlib.Path(tempfile.mkdtemp()) / "o.csv"
    path.write_text(GOOD)
    objects = read_objects(path)
    assert objects["first_scan"].tolist() == [3, 10]
    assert objects["label"].tolist() == ["parked", "passing"]


@pytest.mark.parametrize("text,message", [
    (b"", "not a CSV object table"),
    (b"\xff\xfe\x00", "not a CSV object table"),
    (b"a,b\n1,2\n", "lacks column"),
    (GOOD.replace("3,9", "3.5,9").encode(), "line 2: first_scan is '3.5'"),
    (GOOD.replace("3,9", "-3,9").encode(), "line 2: first_scan is '-3'"),
    (GOOD.replace("10,12", "10,99999999999999999999").encode(), "line 3: last_scan"),
    (GOOD.replace("3,9", "9,3").encode(), "line 2: first_scan after last_scan"),
    (GOOD.replace("parked", "").encode(), "line 2: an empty label"),
    (GOOD.replace("3,9", "x,9").encode(), "line 2: first_scan is 'x'"),
])
def test_a_bad_table_is_an_input_format_error(tmp_path, text, message):
    path = tmp_path / "o.csv"
    path.write_bytes(text)
    with pytest.raises(InputFormatError, match=message) as info:
        read_objects(path)
    assert str(path) in str(info.value)
