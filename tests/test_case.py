"""Case files: typed values, and one clear line (file:line: key: message) for each kind of bad input."""

import numpy as np
import pytest

from lccopt.case import CaseError, load_case, parse_design
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
    ("  speed: 38.88888888888889", "  sped: 38.88888888888889", "vehicle.sped", "unknown key"),
    ("  speed: 38.88888888888889", "  speed: fast", "vehicle.speed", "expected a number"),
    ("  speed: 38.88888888888889", "  speed: -5.0", "vehicle.speed", "must be > 0"),
    ("    reference: 8\n", "    reference: 25\n", "design.strengthened_sleepers.reference", "outside the bounds"),
    ("    bounds: [3, 7]", "    bounds: [3, 7.5]", "design.sleeper_spans.bounds", "whole-number bounds"),
    ("    reference: [6, 6, 4]", "    reference: [6, 6]", "design.sleeper_spans.reference", "expected 3 values"),
    ("    bounds: [0, 20]", "    bounds: [0, 200]", "design", "sleepers"),
    ("  sleepers: 20", "  sleepers: 400", "design", "sleepers"),
    ("  element_length: 0.05", "  element_length: 0.03", "simulation.element_length", "divide 0.1"),
    ("    kind: continuous", "    kind: integer", "design.railpad_stiffness.kind", "must be one of"),
    ("  gravity: 9.8", "  gravity: [9.8]", "vehicle.gravity", "expected a number"),
    ("  time_step: 5.0e-4", "  time_step: .nan", "simulation.time_step", "finite"),
    ("    bounds: [0, 120]", "    bounds: [0, 200]", "design", "longer than the ERS"),
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
    (tmp_path / "reference.yaml").write_text(REFERENCE.replace("  speed: 38.88888888888889", "  speed: x"))
    child.write_text("extends: reference.yaml\nname: child\n")
    with pytest.raises(CaseError, match=r"reference\.yaml:\d+: vehicle\.speed"):
        load_case(child)


def test_design_vector_checks():
    case = load_case(CONFIGS / "reference.yaml")
    x = parse_design("214,155,50,5,6,7,3,0", case)          # pads in MN/m, as on screen
    assert np.array_equal(x, [214e6, 155e6, 50e6, 5, 6, 7, 3, 0])
    for bad, words in [("214,155", "has 8 values"), ("214,155,50,5.5,6,7,3,0", "whole number"),
                       ("1,155,50,5,6,7,3,0", "outside"), ("214e6,155,50,5,6,7,3,0", "outside"),
                       ("a,b", "comma-separated")]:
        with pytest.raises(ValueError, match=words):
            parse_design(bad, case)
