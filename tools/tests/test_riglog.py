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


def log_with(row, n=200):
    """n good rows at 100 Hz with `row` as data line 101 (file line 102)."""
    lines = ["t_s,v_V,d_mm"] + ["%.2f,1,0.5" % (0.01 * k) for k in range(100)] + [row]
    lines += ["%.2f,1,0.5" % (0.01 * k) for k in range(100, n)]
    return "\n".join(lines) + "\n"


BAD_ROWS = [("0.995,1", "2 fields, the header has 3"),
            ("0.995,x,0", "'x' is not a number"),
            ("0.995,nan,0", "'nan' is not finite"),
            ("0.005,1,0", "must increase")]


@pytest.mark.parametrize("row,why", BAD_ROWS)
def test_a_bad_row_is_dropped_with_a_warning_naming_file_and_line(tmp_path, capsys, row, why):
    """As the C++ reader (rig_log.hpp): the row is dropped and counted, every other row kept."""
    path = write(tmp_path, log_with(row))
    log = riglog.read(path)
    assert len(log) == 200 and log.rows_read == 201
    assert log.dropped == [(102, log.dropped[0][1])] and why in log.dropped[0][1]
    err = capsys.readouterr().err
    assert "log.csv: dropped 1 bad rows of 201" in err and "log.csv:102: " in err and why in err
    assert list(log["t_s"][99:102]) == [0.99, 1.0, 1.01]  # the rows around it are all there


@pytest.mark.parametrize("row,why", BAD_ROWS)
def test_strict_refuses_at_the_first_bad_row(tmp_path, row, why):
    with pytest.raises(riglog.RigLogError) as e:
        riglog.read(write(tmp_path, log_with(row)), strict=True)
    assert "log.csv:102:" in str(e.value) and why in str(e.value)


def test_a_file_with_more_bad_rows_than_the_cpp_reader_allows_is_refused(tmp_path):
    """More than 1 % of the rows bad: refused, naming the count and the lines (LogReadOptions)."""
    path = write(tmp_path, "t_s,v_V,d_mm\n0,0,0\n0.01,0,0\n0.02,x,0\n0.03,0,0\n")
    with pytest.raises(riglog.RigLogError) as e:
        riglog.read(path)
    assert "refused: 1 bad rows of 4" in str(e.value) and "log.csv:4: 'x' is not a number" in str(e.value)


def test_a_byte_order_mark_before_the_header_is_not_data(tmp_path):
    p = tmp_path / "log.csv"
    p.write_bytes(b"\xef\xbb\xbft_s,v_V,d_mm\n0,0,0.1\n0.01,1,0.2\n")
    assert list(riglog.read(str(p))["d_mm"]) == [0.1, 0.2]


def test_missing_required_column_is_named(tmp_path):
    with pytest.raises(riglog.RigLogError, match="lacks the column.*d_mm"):
        riglog.read(write(tmp_path, "t_s,v_V\n0,0\n"))


def test_a_file_without_header_is_refused_unless_empty_is_allowed(tmp_path):
    path = write(tmp_path, "# only a comment\n")
    with pytest.raises(riglog.RigLogError, match="no header"):
        riglog.read(path)
    log = riglog.read(path, empty_ok=True)
    assert len(log) == 0 and log.rows() == [] and log.comments == ["only a comment"]
