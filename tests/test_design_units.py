"""A design is written in the user's units (pads in MN/m, lengths in m, counts as they are)
wherever a person or a script writes one: the case file's reference, --design and
lccopt.simulate(case, design) give the same simulation; inside, lengths stay 0.1 m elements."""

from __future__ import annotations

import h5py
import pytest

import lccopt
from lccopt.config import load_case
from tests.conftest import write_case

DESIGN = "214,155,50,5,0.6,0.7,0.3,0.5"     # MN/m x 3, a count, m x 4
AS_CASE = ("design:\n"
           "  railpad_stiffness: {reference: [214 MN/m, 155 MN/m, 50 MN/m]}\n"
           "  strengthened_sleepers: {reference: 5}\n"
           "  sleeper_spans: {reference: [0.6 m, 0.7 m, 0.3 m]}\n"
           "  type_ii_strip: {reference: 0.5 m}\n")


def test_one_design_three_ways_simulates_the_same(tmp_path, run_cli):
    plain = write_case(tmp_path, "plain")
    written = write_case(tmp_path, "written", extra=AS_CASE)
    # 1. the case file's reference design, in MN/m and m
    case = lccopt.load_case(written)
    assert case.reference.tolist() == [214e6, 155e6, 50e6, 5.0, 6.0, 7.0, 3.0, 5.0]
    by_file = lccopt.simulate(case).objectives
    # 2. lccopt.simulate(case, design), in the same units
    by_api = lccopt.simulate(plain, [float(v) for v in DESIGN.split(",")]).objectives
    # 3. --design on the command line
    proc = run_cli("simulate", plain, "--design", DESIGN, "--out", tmp_path / "cli", "--no-plots")
    assert proc.returncode == 0, proc.stderr
    with h5py.File(tmp_path / "cli" / "simulation.h5") as f:
        by_cli = {k: float(v) for k, v in f["objectives"].attrs.items() if "_unit" not in k}
        assert f["design"][()].tolist() == case.reference.tolist()   # kept in internal units
    for k in ("F_rms", "F_max", "E_rms", "E_max"):
        assert by_file[k] == by_api[k] == by_cli[k], k
    # the reference design read back in the user's units is the design written
    assert case.to_user().tolist() == pytest.approx([float(v) for v in DESIGN.split(",")])


@pytest.mark.parametrize("design, said", [
    # as the Python API took it before: pads in N/m, lengths in 0.1 m elements
    ([214e6, 155e6, 50e6, 5, 0.6, 0.7, 0.3, 0.5],
     "x_r1 = 2.14e+08 MN/m is outside [50, 1200] MN/m (if that is in N/m, write 214 MN/m)"),
    ([214, 155, 50, 5, 6, 7, 3, 5],
     "x_s1 = 6 m is outside [0.3, 0.7] m (if that counts 0.1 m elements, write 0.6 m)"),
    ([214, 155, 50, 5, 0.65, 0.7, 0.3, 0.5], "x_s1 = 0.65 m is not a multiple of 0.1 m"),
    ([214, 155, 50, 5.5, 0.6, 0.7, 0.3, 0.5], "x_n = 5.5 must be a whole number"),
])
def test_a_design_in_the_old_units_is_told_what_to_write(tmp_path, design, said):
    case = lccopt.load_case(write_case(tmp_path, "old"))
    with pytest.raises(ValueError) as exc:
        lccopt.simulate(case, design)
    assert str(exc.value) == f"design: {said}"


def test_a_case_file_in_the_old_units_gets_one_line_naming_file_line_and_key(tmp_path, run_cli):
    path = write_case(tmp_path, "old", extra="design:\n  sleeper_spans:\n"
                                             "    reference: [6, 7, 3]\n")
    line = path.read_text().splitlines().index("    reference: [6, 7, 3]") + 1
    proc = run_cli("check", path)
    assert proc.returncode == 2
    assert proc.stderr.splitlines() == [
        f"lccopt: error: {path}:{line}: design.sleeper_spans.reference: a length is written "
        f"with its unit (a bare number counted 0.1 m elements before): did you mean "
        f"`reference: [0.6 m, 0.7 m, 0.3 m]`?"]
    # a run's own copy (Case.resolved) holds lengths as bare 0.1 m elements, and reads back
    assert load_case(path, resolved=True).reference[4:7].tolist() == [6.0, 7.0, 3.0]


def test_check_reads_a_runs_own_copy_as_the_run_does(tmp_path, run_cli):
    """A run's case.yaml holds its lengths as 0.1 m elements: `lccopt check` on it says ok
    and shows them in metres; the same text elsewhere is a person's file and gets the hint."""
    case = load_case(write_case(tmp_path, "copy", extra="design:\n  sleeper_spans:\n"
                                                        "    reference: [0.6 m, 0.7 m, 0.3 m]\n"))
    run = tmp_path / "runs" / "copy"
    run.mkdir(parents=True)
    (run / "case.yaml").write_text(case.resolved)
    (run / "journal.jsonl").write_text("")
    proc = run_cli("check", run / "case.yaml")
    assert proc.returncode == 0, proc.stderr
    assert "x_s1 [0.3, 0.7] m in 0.1 m steps" in proc.stdout
    assert load_case(run / "case.yaml").reference[4:7].tolist() == [6.0, 7.0, 3.0]
    (run / "journal.jsonl").unlink()   # not a run any more: a person's file in old units
    proc = run_cli("check", run / "case.yaml")
    assert proc.returncode == 2 and "did you mean" in proc.stderr
