"""The Python rig-log reader (sma.riglog) against the rig-log contract (interfaces.md)."""
import pytest

from sma import riglog


def write(tmp_path, text):
    p = tmp_path / "log.csv"
    p.write_text(text)
    return str(p)


def test_comments_header_rows_and_unknown_columns(tmp_path):
    log = riglog.read(write(tmp_path, "# rig: test\nt_s,v_V,d_mm,ref_mm,duty,extra\n0,0,0.1,0.2,0,9\n0.01,1,0.2,0.2,0.5,9\n"))
    assert log.comments == ["rig: test"]
    assert list(log["d_mm"]) == [0.1, 0.2] and "extra" in log and len(log) == 2


@pytest.mark.parametrize("row,why", [("0.02,1", "2 fields, the header has 3"),
                                     ("0.02,x,0", "'x' is not a number"),
                                     ("0.02,nan,0", "'nan' is not finite"),
                                     ("0.005,1,0", "must increase")])
def test_bad_rows_are_named_by_line_or_dropped_and_listed(tmp_path, row, why):
    path = write(tmp_path, "t_s,v_V,d_mm\n0,0,0\n0.01,0,0\n%s\n0.03,0,0\n" % row)
    with pytest.raises(riglog.RigLogError) as e:
        riglog.read(path)
    assert "log.csv:4:" in str(e.value) and why in str(e.value)
    log = riglog.read(path, skip_bad=True)
    assert len(log) == 3 and log.dropped[0][0] == 4


def test_missing_required_column_is_named(tmp_path):
    with pytest.raises(riglog.RigLogError, match="lacks the column.*d_mm"):
        riglog.read(write(tmp_path, "t_s,v_V\n0,0\n"))


def test_a_file_without_header_is_refused_unless_empty_is_allowed(tmp_path):
    path = write(tmp_path, "# only a comment\n")
    with pytest.raises(riglog.RigLogError, match="no header"):
        riglog.read(path)
    log = riglog.read(path, empty_ok=True)
    assert len(log) == 0 and log.rows() == [] and log.comments == ["only a comment"]
