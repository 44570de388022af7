"""The report's words for traffic runs and for a run whose best is the reference design."""

from __future__ import annotations

import json

from lccopt.engine.runner import optimise
from tests.engine.conftest import FAKE, cli_run, write_case

CONDITIONS = """\
conditions:
  - {name: slow, speed: 22.222222222222222}
  - {name: fast, speed: 44.44444444444444}
"""


def test_a_traffic_report_names_the_condition_that_sets_each_worst_case(tmp_path):
    # the stand-in's objectives grow with speed: 'fast' sets both worst cases
    case = write_case(tmp_path, "tr", budget=8, initial=4, worst=(90000.0, 9.0), extra=CONDITIONS)
    run = optimise(case, workers=2, runs=tmp_path, evaluator=FAKE, progress=False)
    r = cli_run("report", run)
    assert r.returncode == 0, r.stderr
    text = (run / "report" / "report.md").read_text()
    assert "F_max (worst case, set by fast)" in text, text
    assert "E_max (worst case, set by fast)" in text, text
    assert "In condition fast (which sets the best design's worst E_max)" in text, text


def test_a_best_design_equal_to_the_reference_is_said_to_be_unchanged(tmp_path):
    case = write_case(tmp_path, "same", objectives=("F_max",), budget=6, initial=4)
    run = optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)
    journal = run / "journal.jsonl"
    lines = [json.loads(line) for line in journal.read_text().splitlines()]
    for ev in lines:   # every design but the reference made worse than it
        if ev["event"] == "evaluated" and ev["id"] > 0:
            ev["value"] = ev["objectives"]["F_max"] = 1e9
    journal.write_text("".join(json.dumps(ev, separators=(",", ":")) + "\n" for ev in lines))
    (run / "results.h5").unlink()
    r = cli_run("report", run)
    assert r.returncode == 0, r.stderr
    text = (run / "report" / "report.md").read_text()
    assert "F_max is unchanged at" in text, text
    assert "The best design is the reference design" in text, text
    assert "rises from" not in text and "+0.0 %" not in text   # an equal value is "0 %"
