"""Case files: typed values, and one clear line (file:line: key: message) for each kind of bad
input."""

import numpy as np
import pytest

from lccopt.config import load_case, parse_design
from lccopt.errors import CaseError
from tests.conftest import CONFIGS

REFERENCE = (CONFIGS / "reference.yaml").read_text()


def test_reference_case_reads_paper_values():
    case = load_case(CONFIGS / "reference.yaml")
    assert case.track["railpad"]["stiffness"] == 1120e6          # written 1120.0e6
    assert case.vehicle["speed"] == pytest.approx(140 / 3.6)
    assert case.names == ["x_r1", "x_r2", "x_r3", "x_n", "x_s1", "x_s2", "x_s3", "x_l"]
    assert list(case.reference) == [1120e6] * 3 + [8, 6, 6, 4, 0]
    assert list(case.integer) == [False] * 3 + [True] * 5
    assert case.optimisation is None


def test_pyyaml_style_exponent_without_dot_is_a_number(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text(REFERENCE.replace("stiffness: 1120.0e6", "stiffness: 1120e6"))
    assert load_case(p).track["railpad"]["stiffness"] == 1120e6


def line_of(text, needle):
    return text.splitlines().index(next(l for l in text.splitlines() if needle in l)) + 1


BAD = [  # (replace this, with this, key path in the message, words in the message)
    ("  speed: 140 km/h", "  sped: 140 km/h", "vehicle.sped", "unknown key"),
    ("  speed: 140 km/h", "  speed: fast", "vehicle.speed", "expected a number"),
    ("  speed: 140 km/h", "  speed: -5.0", "vehicle.speed", "must be > 0"),
    ("    reference: 8\n", "    reference: 25\n", "design.strengthened_sleepers.reference",
     "outside the bounds"),
    ("    bounds: [0.3 m, 0.7 m]", "    bounds: [0.3 m, 0.75 m]", "design.sleeper_spans.bounds",
     "0.75 m is not a multiple of 0.1 m"),
    ("    reference: [0.6 m, 0.6 m, 0.4 m]", "    reference: [0.6 m, 0.6 m]",
     "design.sleeper_spans.reference", "expected 3 values"),
    # a case written before lengths took their unit: the count of 0.1 m elements it meant
    ("    bounds: [0.3 m, 0.7 m]", "    bounds: [3, 7]", "design.sleeper_spans.bounds",
     "did you mean `bounds: [0.3 m, 0.7 m]`?"),
    ("    reference: [0.6 m, 0.6 m, 0.4 m]", "    reference: [6, 6, 4]",
     "design.sleeper_spans.reference", "(a bare number counted 0.1 m elements before): did "
     "you mean `reference: [0.6 m, 0.6 m, 0.4 m]`?"),
    ("    reference: 0 m", "    reference: 20", "design.type_ii_strip.reference",
     "did you mean `reference: 2 m`?"),
    ("    reference: [0.6 m, 0.6 m, 0.4 m]", "    reference: [0.6, 0.6, 0.4]",
     "design.sleeper_spans.reference", "did you mean `reference: [0.6 m, 0.6 m, 0.4 m]`?"),
    ("    bounds: [0, 20]", "    bounds: [0, 200]", "design.strengthened_sleepers.bounds",
     "the entry side holds 166 sleepers"),
    ("  sleepers: 20", "  sleepers: 400", "evaluation.sleepers", "entry side holds 166"),
    ("  element_length: 0.05", "  element_length: 0.03", "simulation.element_length", "divide 0.1"),
    ("    kind: continuous", "    kind: integer", "design.railpad_stiffness.kind",
     "must be one of"),
    ("  gravity: 9.8", "  gravity: [9.8]", "vehicle.gravity", "expected a number"),
    ("  time_step: 5.0e-4", "  time_step: .nan", "simulation.time_step", "finite"),
    ("    # bounds: by default", "    bounds: [0 m, 20 m]\n    # bounds: by default",
     "design.type_ii_strip.bounds", "upper bound 20 m is longer than the 12 m ERS: at most 12 m"),
]


@pytest.mark.parametrize("old,new,key,words", BAD)
def test_bad_values_name_file_line_and_key(tmp_path, old, new, key, words):
    assert old in REFERENCE
    text = REFERENCE.replace(old, new, 1)
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(CaseError) as exc:
        load_case(p)
    msg = str(exc.value)
    assert "\n" not in msg
    assert msg.startswith(f"{p}:")
    line = int(msg.split(":")[1])
    if key != "design":
        assert line == line_of(text, new.strip().split("\n")[0])
    assert f" {key}: " in msg or f" {key}[" in msg
    assert words in msg


def test_missing_key_and_yaml_syntax(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text(REFERENCE.replace("  hertz_constant: 5.13e-8", ""))
    with pytest.raises(CaseError, match=r"vehicle: missing key 'hertz_constant'"):
        load_case(p)
    p.write_text(REFERENCE.replace("  gravity: 9.8", "  gravity: [9.8"))
    with pytest.raises(CaseError, match=r"c\.yaml:\d+: <yaml>"):
        load_case(p)
    p.write_text("")
    with pytest.raises(CaseError, match="empty"):
        load_case(p)
    with pytest.raises(CaseError, match="cannot read"):
        load_case(tmp_path / "nope.yaml")


def test_extends_overrides_and_reports_the_right_file(tmp_path):
    (tmp_path / "reference.yaml").write_text(REFERENCE)
    child = tmp_path / "child.yaml"
    child.write_text("extends: reference.yaml\nname: child\nsimulation:\n  run_in: 12.0\n")
    case = load_case(child)
    assert case.name == "child" and case.simulation["run_in"] == 12.0
    assert case.simulation["time_step"] == 5e-4                       # inherited
    child.write_text("extends: reference.yaml\nname: child\nsimulation:\n  run_inn: 12.0\n")
    with pytest.raises(CaseError, match=r"child\.yaml:4: simulation\.run_inn: unknown key"):
        load_case(child)
    (tmp_path / "reference.yaml").write_text(REFERENCE.replace("  speed: 140 km/h", "  speed: x"))
    child.write_text("extends: reference.yaml\nname: child\n")
    with pytest.raises(CaseError, match=r"reference\.yaml:\d+: vehicle\.speed"):
        load_case(child)


def test_design_vector_checks():
    case = load_case(CONFIGS / "reference.yaml")
    x = parse_design("214,155,50,5,0.6,0.7,0.3,0", case)   # as on screen: MN/m, m
    assert np.array_equal(x, [214e6, 155e6, 50e6, 5, 6, 7, 3, 0])
    for bad, words in [("214,155", "has 8 values"),
                       ("214,155,50,5.5,0.6,0.7,0.3,0", "whole number"),
                       ("214,155,50,5,0.65,0.7,0.3,0", "x_s1 = 0.65 m is not a multiple of 0.1 m"),
                       ("214,155,50,5,6,7,3,0", "x_s1 = 6 m is outside"),
                       ("1,155,50,5,0.6,0.7,0.3,0", "outside"),
                       ("214e6,155,50,5,0.6,0.7,0.3,0", "outside"), ("a,b", "comma-separated")]:
        with pytest.raises(ValueError, match=words):
            parse_design(bad, case)


# -- log scales ----------------------------------------------------------------------------
LINEAR = "\n".join(l for l in REFERENCE.splitlines() if not l.strip().startswith("scale:")) + "\n"
PADS = "  railpad_stiffness:"


def with_pad_lines(extra: str) -> str:
    """The reference case with ``extra`` lines in the railpad_stiffness design group."""
    head, _, tail = LINEAR.partition("    kind: continuous\n")
    assert PADS in head.splitlines()[-1]
    return head + "    kind: continuous\n" + extra + tail


def test_scale_log_marks_the_pads_for_a_log_search(tmp_path):
    from lccopt.problem import Problem

    p = tmp_path / "c.yaml"
    p.write_text(with_pad_lines("    scale: log\n")
                 + "optimisation:\n  objectives: [F_max]\n  budget: 30\n  initial_points: 10\n")
    case = load_case(p)
    assert case.log.tolist() == [True] * 3 + [False] * 5
    space = Problem.from_case(case).space()
    assert space.log == [True] * 3 + [False] * 5
    assert space.to_unit(np.array([np.sqrt(50e6 * 1200e6)] * 3 + [0, 3, 3, 3, 0]))[:3] == \
        pytest.approx([0.5] * 3)
    p.write_text(with_pad_lines("    scale: linear\n"))
    assert not load_case(p).log.any()


def test_a_case_without_scale_resolves_as_before(tmp_path):
    # A run keeps the sha256 of its resolved case; a case written before scales existed must
    # resolve to the same text, or its runs could not be resumed.
    p = tmp_path / "c.yaml"
    p.write_text(LINEAR + "optimisation:\n  objectives: [F_max]\n  budget: 30\n"
                 "  initial_points: 10\n")
    case = load_case(p)
    assert "scale" not in case.resolved and not case.log.any()
    from lccopt.problem import Problem
    assert "log" not in Problem.from_case(case).space().to_dict()


@pytest.mark.parametrize("extra, where, key, words", [
    ("    scale: cubic\n", "pads", "design.railpad_stiffness.scale", "must be one of"),
    ("    scale: log\n", "integer", "design.strengthened_sleepers.scale", "unknown key"),
    # a pad of 0 N/m is refused by the bounds before a log scale could be
    ("    bounds: [0.0, 1200.0e6]\n    scale: log\n", "pads-bounds",
     "design.railpad_stiffness.bounds[0]", "must be >= 10 MN/m"),
])
def test_bad_scale_names_file_line_and_key(tmp_path, extra, where, key, words):
    if where == "integer":
        text = LINEAR.replace("  strengthened_sleepers:",
                              "  strengthened_sleepers:\n" + extra.rstrip("\n"), 1)
    else:
        text = with_pad_lines(extra)
        if where == "pads-bounds":  # the group's own bounds line comes later: drop it
            text = text.replace("    bounds: [50 MN/m, 1200 MN/m]", "", 1)
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(CaseError) as exc:
        load_case(p)
    msg = str(exc.value)
    assert msg.startswith(f"{p}:") and "\n" not in msg
    assert f" {key}: " in msg and words in msg
    assert int(msg.split(":")[1]) == line_of(text, extra.splitlines()[0].strip())
