"""The main job's lead (tools/vrig/paper_tests.py): the default runs with the lead the tuner found
with its gains, sent as the console's `lead F`, the factor on the board's lead of the kind. The
board truncates F times its lead's ticks in float (Board::prepare_future): every lead of the
tuner's grid that the console's range 0..2 allows must land on its own tick, and none is sent
where it is the board's own or out of range.
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "vrig"))
import paper_tests  # noqa: E402


BOARD_LEAD_S = {"sine": 5.25, "steps": 10.0}  # sma::lead_for, as bench_tracking writes it


def _tracking(tmp_path, test, lead_s, board_lead_s=True):
    p = tmp_path / "tracking.json"
    row = {"test": test, "condition": "rig-like", "controller": "lead", "scalar": "double",
           "kp": 25, "ki": 0.25, "kd": 0.08, "lead_s": lead_s}
    if board_lead_s:
        row["board_lead_s"] = BOARD_LEAD_S["sine" if test == "sine" else "steps"]
    p.write_text(json.dumps({"runs": [row]}))
    return str(p)


def _board_ticks(command, board_lead_s):
    f = np.float32(float(command.split()[1]))  # the console's value, a float on the AVR
    return int(np.float32(f * np.float32(round(board_lead_s * 100))))  # trunc_u32


def test_each_lead_of_the_grid_lands_on_its_tick(tmp_path):
    for test, grid in (("sine", (1, 2, 3, 4, 6)), ("steps", (1, 2, 3, 4, 6, 8, 12, 20))):
        board = BOARD_LEAD_S[test]
        for lead_s in grid:
            got = paper_tests.lead_command(_tracking(tmp_path, "sine" if test == "sine" else "multi-step", lead_s), test)
            assert got is not None, (test, lead_s)
            assert got[1] == lead_s
            assert _board_ticks(got[0], board) == round(lead_s * 100), (test, lead_s, got[0])


def test_the_boards_own_lead_and_one_out_of_range_send_nothing(tmp_path):
    assert paper_tests.lead_command(_tracking(tmp_path, "sine", 5.25), "sine") is None
    assert paper_tests.lead_command(_tracking(tmp_path, "multi-step", 10.0), "steps") is None
    assert paper_tests.lead_command(_tracking(tmp_path, "sine", 12.0), "sine") is None  # F = 2.3: outside 0..2
    assert paper_tests.lead_command(str(tmp_path / "missing.json"), "sine") is None
    # A tuner's row without the board's lead (an older tracking.json): nothing is sent.
    assert paper_tests.lead_command(_tracking(tmp_path, "sine", 4.0, board_lead_s=False), "sine") is None


def test_the_benchmark_names_the_boards_lead():
    """bench_tracking's lead rows carry sma::lead_for's lead as board_lead_s (the one source)."""
    path = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                        "build", "bench-results", "tracking.json")
    if not os.path.isfile(path):
        import pytest
        pytest.skip("no build/bench-results/tracking.json (scripts/bench writes it)")
    for test in ("sine", "steps"):
        r = paper_tests.tuned_row(path, test, "lead")
        if r is None or "board_lead_s" not in r:
            import pytest
            pytest.skip("tracking.json from before board_lead_s")
        assert r["board_lead_s"] == BOARD_LEAD_S[test]
