"""The dashboard's and the console's reading of the board's lines when the board streams plotter
lines (Teleplot `>name:value`, Arduino Serial Plotter `label:value,...`) beside or instead of the
rig-log telemetry: the lines are ignored (not plotted, not recorded, not echoed per tick), named
once on the page and in the terminal, and the replies and rows around them still work."""

from sma import console, dashboard

PLOTTER = [">d_mm:0.4123", ">v_V:1.2000|np", ">T_C:1712345:61.5", "d_mm:0.41,ref_mm:0.40,v_V:1.2",
           "0.41 0.40 1.2", "0.41\t0.40"]


class Port:
    def __init__(self, data):
        self.data = data

    def read(self, n):
        data, self.data = self.data[:n], self.data[n:]
        return data

    def write(self, data):
        pass


def stream():
    rows = ["%.2f,1.2,0.41,0.40,0.0576" % (0.01 * k) for k in range(1, 4)]
    lines = PLOTTER + [rows[0], "OK pos 0.4000 ffpid"] + PLOTTER + rows[1:] + ["ERR pos: out of range"] + PLOTTER
    return ("\r\n".join(lines) + "\r\n").encode()


def test_plotter_lines_are_classified_apart_from_rows_and_other_text():
    for s in PLOTTER:
        assert console.classify(s)[0] == "plotter", s
    assert console.classify("1.0,1.2,0.41,0.40,0.0576")[0] == "row"
    for s in ("sma_firmware float ready: heater off; try help", "garbage", "1.2,nan,0.5,0.4,0.04", ""):
        assert console.classify(s)[0] in ("other", "empty"), s


def test_console_ignores_plotter_lines_and_names_them_once(tmp_path):
    echoed = []
    with open(tmp_path / "rec.csv", "w") as f:
        rec = console.Recorder(f, "fake")
        c = console.ConsoleClient(Port(stream()), recorder=rec, echo=echoed.append)
        kinds = [k for k, _ in c.feed(stream())]
    assert kinds.count("row") == 3 and kinds.count("reply") == 2 and kinds.count("plotter") == 3 * len(PLOTTER)
    assert c.plotter == 3 * len(PLOTTER) and c.other == 0 and rec.rows == 3
    assert [e for e in echoed if "plotter lines" in e] == ["(%s)" % console.PLOTTER_NOTE]
    assert "OK pos 0.4000 ffpid" in echoed and "ERR pos: out of range" in echoed
    assert not [e for e in echoed if e.startswith(">") or "d_mm:" in e]
    text = (tmp_path / "rec.csv").read_text()
    assert ">" not in text and "d_mm:" not in text and len(text.strip().splitlines()) == 5  # comment, header, 3 rows


def test_dashboard_plots_the_rows_and_names_the_plotter_lines_once():
    terminal = []
    rig = dashboard.Rig("fake", 115200, log=terminal.append)
    rig.client = console.ConsoleClient(Port(b""))
    for chunk in (stream(), stream()):
        for kind, payload in rig.client.feed(chunk):
            rig._handle(kind, payload)
    assert [row[0] for _, row in rig.rows] == [0.01, 0.02, 0.03] * 2
    page = [text for _, kind, text in rig.lines]
    assert page.count(console.PLOTTER_NOTE) == 1 and terminal.count(console.PLOTTER_NOTE) == 1
    assert not [t for t in page if t.startswith(">") or "d_mm:" in t]
    assert "ERR pos: out of range" in page
