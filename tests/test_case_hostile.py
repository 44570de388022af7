"""Hostile and absurd case files: each gets one line `file:line: key: message` and exit 2,
through the installed command as a user (or an attacker) runs it."""

from __future__ import annotations

import re

import pytest

from tests.conftest import REFERENCE

R = REFERENCE.as_posix()
LOL = "a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n" + "".join(
    f"{chr(97 + i)}: &{chr(97 + i)} [{', '.join(['*' + chr(96 + i)] * 9)}]\n" for i in range(1, 10))

HOSTILE = {  # file content -> (line, key, words of the message)
    "binary": (b"name: a\n\x00\x01\x02\n", 2, "<file>", "binary data"),
    "latin-1": ("name: caf\xe9\n".encode("latin-1"), 1, "<file>", "not UTF-8"),
    "utf-16": ("name: x\n".encode("utf-16"), 1, "<file>", "not UTF-8"),
    "deep nesting": (("name: x\nvehicle: " + "[" * 5000 + "]" * 5000 + "\n").encode(), 2, "<yaml>",
                     "nested more than"),
    "24-digit integer": (f"extends: {R}\nname: b\nvehicle:\n  speed: 123456789012345678901234\n".encode(),
                         4, "vehicle.speed", "not a plausible value"),
    "merge key": (f"extends: {R}\nname: m\nvehicle:\n  <<: {{speed: 30}}\n".encode(), 4, "vehicle",
                  "merge keys"),
    "python tag": (f"extends: {R}\nname: !!python/object/apply:os.system [echo hi]\n".encode(), 2, "name",
                   "tags"),
    "python scalar tag": (f"extends: {R}\nname: !!python/name:os.system x\n".encode(), 2, "<yaml>",
                          "constructor"),
    "custom tag": (f"extends: {R}\nname: !foo x\n".encode(), 2, "<yaml>", "constructor"),
    "alias bomb": (LOL.encode(), 1, "<yaml>", "aliases"),
    "300-character name": (f"extends: {R}\nname: {'a' * 300}\n".encode(), 2, "name", "1-64 letters"),
    "name '..'": (f'extends: {R}\nname: ".."\n'.encode(), 2, "name", "1-64 letters"),
    "budget 1e12": (f"extends: {R}\nname: b\noptimisation:\n  objectives: [F_max]\n  budget: 1e12\n"
                    f"  initial_points: 10\n".encode(), 5, "optimisation.budget", "<= 100000"),
    "time_step 0.05": (f"extends: {R}\nname: t\nsimulation:\n  time_step: 0.05\n".encode(), 4,
                       "simulation.time_step", "time_step <="),
    "time_step 1000": (f"extends: {R}\nname: t\nsimulation:\n  time_step: 1000\n".encode(), 4,
                       "simulation.time_step", "too coarse"),
    "entry_length 1e9": (f"extends: {R}\nname: t\ntrack:\n  layout:\n    entry_length: 1e9\n".encode(), 5,
                         "track.layout.entry_length", "<= 2000"),
    "element_length 1e-6": (f"extends: {R}\nname: t\nsimulation:\n  element_length: 1e-6\n".encode(), 4,
                            "simulation.element_length", ">= 0.01"),
    "speed 1e6": (f"extends: {R}\nname: t\nvehicle:\n  speed: 1e6\n".encode(), 4, "vehicle.speed", "<= 150"),
    "stiffness 1e300": (f"extends: {R}\nname: t\ntrack:\n  railpad:\n    stiffness: 1e300\n".encode(), 5,
                        "track.railpad.stiffness", "not a plausible value"),
    "300 railpads": ((f"extends: {R}\nname: t\ndesign:\n  railpad_stiffness:\n    count: 300\n"
                      f"    reference: [{', '.join(['1120e6'] * 300)}]\n").encode(), 5,
                     "design.railpad_stiffness.count", "<= 50"),
    "huge file": (b"name: x\n" + b"# padding\n" * 200_000, 1, "<file>", "characters"),
}


@pytest.mark.parametrize("kind", list(HOSTILE))
def test_a_hostile_case_file_gets_one_line_and_exit_2(tmp_path, run_cli, kind):
    content, line, key, words = HOSTILE[kind]
    case = tmp_path / "case.yaml"
    case.write_bytes(content)
    r = run_cli("check", case, timeout=20)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith(f"lccopt: error: {case}:{line}: {key}: "), lines[0]
    assert words in lines[0]


def test_a_time_step_just_fine_enough_passes(tmp_path, run_cli):
    """The limit is the one the message states, not a guess: just below it is accepted,
    just above it refused with the same limit."""
    case = tmp_path / "case.yaml"
    case.write_text(f"extends: {R}\nname: t\nsimulation:\n  time_step: 0.05\n")
    r = run_cli("check", case)
    found = re.search(r"time_step <= ([0-9.e-]+) s", r.stderr)
    assert r.returncode == 2 and found, r.stderr
    limit = float(found.group(1))
    case.write_text(f"extends: {R}\nname: t\nsimulation:\n  time_step: {limit * 0.99:.6g}\n"
                    f"  element_length: 0.1\n")
    assert run_cli("check", case).returncode == 0
    case.write_text(f"extends: {R}\nname: t\nsimulation:\n  time_step: {limit * 1.02:.6g}\n"
                    f"  element_length: 0.1\n")
    r = run_cli("check", case)
    assert r.returncode == 2 and f"time_step <= {found.group(1)} s" in r.stderr
