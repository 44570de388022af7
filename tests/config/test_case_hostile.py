"""Hostile and absurd case files: each gets one line `file:line: key: message` and exit 2,
through the installed command as a user (or an attacker) runs it."""

from __future__ import annotations

import os
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
    "24-digit integer": (
        f"extends: {R}\nname: b\nvehicle:\n  speed: 123456789012345678901234\n".encode(),
        4, "vehicle.speed", "not a plausible value"),
    "merge key": (f"extends: {R}\nname: m\nvehicle:\n  <<: {{speed: 30}}\n".encode(), 4, "vehicle",
                  "merge keys"),
    "python tag": (f"extends: {R}\nname: !!python/object/apply:os.system [echo hi]\n".encode(),
                   2, "name", "tags"),
    "python scalar tag": (f"extends: {R}\nname: !!python/name:os.system x\n".encode(), 2, "<yaml>",
                          "constructor"),
    "custom tag": (f"extends: {R}\nname: !foo x\n".encode(), 2, "<yaml>", "constructor"),
    "alias bomb": (LOL.encode(), 1, "<yaml>", "aliases"),
    "300-character name": (f"extends: {R}\nname: {'a' * 300}\n".encode(), 2, "name",
                           "1-64 letters"),
    "name '..'": (f'extends: {R}\nname: ".."\n'.encode(), 2, "name", "1-64 letters"),
    "budget 1e12": (f"extends: {R}\nname: b\noptimisation:\n  objectives: [F_max]\n  budget: 1e12\n"
                    f"  initial_points: 10\n".encode(), 5, "optimisation.budget", "<= 100000"),
    "time_step 0.05": (f"extends: {R}\nname: t\nsimulation:\n  time_step: 0.05\n".encode(), 4,
                       "simulation.time_step", "time_step <="),
    "time_step 1000": (f"extends: {R}\nname: t\nsimulation:\n  time_step: 1000\n".encode(), 4,
                       "simulation.time_step", "too coarse"),
    "entry_length 1e9": (
        f"extends: {R}\nname: t\ntrack:\n  layout:\n    entry_length: 1e9\n".encode(), 5,
        "track.layout.entry_length", "<= 2000"),
    "element_length 1e-6": (
        f"extends: {R}\nname: t\nsimulation:\n  element_length: 1e-6\n".encode(), 4,
        "simulation.element_length", ">= 0.01"),
    "speed 1e6": (f"extends: {R}\nname: t\nvehicle:\n  speed: 1e6\n".encode(), 4, "vehicle.speed",
                  "<= 250 km/h"),
    "stiffness 1e300": (
        f"extends: {R}\nname: t\ntrack:\n  railpad:\n    stiffness: 1e300\n".encode(), 5,
        "track.railpad.stiffness", "not a plausible value"),
    "300 railpads": ((f"extends: {R}\nname: t\ndesign:\n  railpad_stiffness:\n    count: 300\n"
                      f"    reference: [{', '.join(['1120e6'] * 300)}]\n").encode(), 6,
                     "design.railpad_stiffness.reference", "300 values; at most 50"),
    "huge file": (b"name: x\n" + b"# padding\n" * 200_000, 1, "<file>",
                  "bytes; a case file is at most 1,000,000"),
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


# Inputs next to the case file: special files, links, names and rail profiles a case names,
# and quantities that pass the schema's bounds but not what a simulation can do. Each is one
# line `file[:line: key]: problem`, exit 2, no traceback, no hang, no runaway memory.
Q = (REFERENCE.parent / "quickstart.yaml").as_posix()


def _case(tmp_path, body: str) -> str:
    (tmp_path / "case.yaml").write_text(f"extends: {Q}\nname: h\n{body}")
    return "case.yaml"


def _irr(tmp_path, name: str) -> str:
    return _case(tmp_path, f"simulation:\n  irregularity: {name}\n")


def _csv(tmp_path, content) -> str:
    data = content.encode() if isinstance(content, str) else content
    (tmp_path / "p.csv").write_bytes(data)
    return _irr(tmp_path, "p.csv")


def _extends(tmp_path, name: str) -> str:
    (tmp_path / "case.yaml").write_text(f"extends: {name}\nname: h\n")
    return "case.yaml"


def _fifo(tmp_path) -> str:
    os.mkfifo(tmp_path / "fifo")
    return "fifo"


def _dir(tmp_path) -> str:
    (tmp_path / "adir").mkdir()
    return "adir"


def _zero_link(tmp_path) -> str:
    (tmp_path / "z.csv").symlink_to("/dev/zero")
    return "z.csv"


def _loop(tmp_path) -> str:
    (tmp_path / "loop1").symlink_to("loop2")
    (tmp_path / "loop2").symlink_to("loop1")
    return "loop1"


def _chain(tmp_path, n: int, padding: int) -> str:
    """A chain of n case files, each extending the one before, each with ``padding`` bytes of
    comments."""
    base = Q
    for i in range(n):
        text = f"extends: {base}\nname: c{i}\n" + "#" * padding + "\n"
        (tmp_path / f"c{i}.yaml").write_text(text)
        base = f"c{i}.yaml"
    return base


def _conditions(n: int, time_step: float) -> str:
    rows = "".join(f"  - {{name: c{i}}}\n" for i in range(n))
    return f"simulation:\n  time_step: {time_step}\nconditions:\n{rows}"


def _rows(n: int) -> str:
    return "".join(f"{i * 1e-3:.3f},0\n" for i in range(n))


EXT = "case.yaml:1: extends: "
IRR = "case.yaml:4: simulation.irregularity: "
CSV = IRR + "p.csv: "
SIM = "simulation:\n"
FINE_LONG_RUN = SIM + "  element_length: 0.01\n  time_step: 1.0e-4\n  run_in: 1000\n" \
    "track:\n  layout:\n    entry_length: 1100\n"
FINE_LONG_TRACK = SIM + "  element_length: 0.01\n  far_element_length: 0.01\n" \
    "  time_step: 2.0e-5\n  run_in: 90\ntrack:\n  layout:\n    entry_length: 2000\n" \
    "    exit_length: 2000\n"
HALF_CAR_FINE = SIM + "  element_length: 0.01\n  far_element_length: 0.01\n" \
    "  time_step: 2.5e-4\ntrack:\n  layout:\n    entry_length: 2000\n"
HALF_CAR = (REFERENCE.parent / "vehicles" / "virm-half-car.yaml").as_posix()
SPECTRUM = SIM + "  irregularity: {{spectrum: {0}, seed: 1, wavelengths: [{1}, {2}], " \
                 "amplitude_scale: {3}}}\n"

# name -> (make(tmp_path) -> the file to check, message start after "lccopt: error: ", words)
NEXT_TO = {
    "case is a FIFO": (_fifo, "fifo: ", "a FIFO (named pipe), not a regular file"),
    "case is /dev/zero": (lambda t: "/dev/zero", "/dev/zero: ", "a character device"),
    "case is /dev/urandom": (lambda t: "/dev/urandom", "/dev/urandom: ", "a character device"),
    "case is a directory": (_dir, "adir: ", "a directory, not a regular file"),
    "case is /proc/self/environ": (lambda t: "/proc/self/environ",
                                   "/proc/self/environ:1: <file>: ", "binary data"),
    "extends /dev/zero": (lambda t: _extends(t, "/dev/zero"), EXT + "/dev/zero: ",
                          "a character device"),
    "extends /dev/urandom": (lambda t: _extends(t, "/dev/urandom"), EXT + "/dev/urandom: ",
                             "a character device"),
    "extends a FIFO": (lambda t: _extends(t, _fifo(t)), EXT, "a FIFO (named pipe)"),
    "extends a directory": (lambda t: _extends(t, _dir(t)), EXT, "a directory"),
    "extends a loop of links": (lambda t: _extends(t, _loop(t)), EXT, "loop"),
    "extends with NUL": (lambda t: _extends(t, f'"{Q}\\0x"'), EXT, "control character U+0000"),
    "an extends chain of big files": (lambda t: _chain(t, 4, 800_000), "/",   # names c1.yaml
                                      "c1.yaml:1: <file>: the files of the extends chain hold "
                                      "more than 2,000,000 bytes of YAML in all"),
    "irregularity /dev/zero": (lambda t: _irr(t, "/dev/zero"), IRR + "/dev/zero: ",
                               "a character device"),
    "irregularity /dev/urandom": (lambda t: _irr(t, "/dev/urandom"), IRR + "/dev/urandom: ",
                                  "a character device"),
    "irregularity a FIFO": (lambda t: _irr(t, _fifo(t)), IRR + "fifo: ", "a FIFO (named pipe)"),
    "irregularity a directory": (lambda t: _irr(t, _dir(t)), IRR, "a directory"),
    "irregularity a link to /dev/zero": (lambda t: _irr(t, _zero_link(t)), IRR + "z.csv: ",
                                         "a character device"),
    "irregularity with NUL": (lambda t: _irr(t, '"p\\0.csv"'), IRR, "control character U+0000"),
    "irregularity with an escape sequence": (lambda t: _irr(t, '"p\\e[2J.csv"'), IRR, "U+001B"),
    "irregularity with a bidi override": (lambda t: _irr(t, '"a\\u202Evsc.csv"'), IRR, "U+202E"),
    "irregularity an empty name": (lambda t: _irr(t, '""'), IRR, "empty file name"),
    "empty CSV": (lambda t: _csv(t, ""), CSV + "line 1: ", "a profile needs at least two"),
    "CSV of comments only": (lambda t: _csv(t, "# nothing\n\n"), CSV, "0 row(s)"),
    "CSV with nan": (lambda t: _csv(t, "98,0\n98.5,nan\n99,0\n"), CSV + "line 2: ",
                     "dip nan is not a finite"),
    "CSV with inf": (lambda t: _csv(t, "98,0\ninf,0.0001\n"), CSV + "line 2: ",
                     "position inf is not a"),
    "CSV with 1e308": (lambda t: _csv(t, "98,0\n98.5,1e308\n99,0\n"), CSV + "line 2: ",
                       "at most 0.05 m"),
    "CSV in millimetres": (lambda t: _csv(t, "98,0\n98.5,2.5\n99,0\n"), CSV + "line 2: ",
                           "a dip of 2.5 m"),
    "CSV with a header": (lambda t: _csv(t, "position,dip\n98,0\n99,0\n"), CSV + "line 1: ",
                          "is not a number"),
    "CSV of three columns": (lambda t: _csv(t, "98,0,1\n99,0,1\n"), CSV + "line 1: ",
                             "two numbers"),
    "CSV going back": (lambda t: _csv(t, "98,0\n97,0\n"), CSV + "line 2: ", "does not increase"),
    "CSV off the track": (lambda t: _csv(t, "1000,0\n1001,0.001\n"), IRR,
                          "outside the modelled track [0, 134] m"),
    "CSV in UTF-16": (lambda t: _csv(t, "98,0\n99,0\n".encode("utf-16")), CSV + "line 1: ",
                      "not UTF-8"),
    "CSV of 8 million blank lines": (lambda t: _csv(t, b"\n" * 7_999_999), CSV + "line 1: ",
                                     "lines"),
    "CSV of 150 000 rows": (lambda t: _csv(t, _rows(150_000)), CSV + "line 100001: ",
                            "100,000 rows"),
    "CSV of 12 MB": (lambda t: _csv(t, b"1,0\n" * 3_000_000), CSV, "larger than 8,000,000 bytes"),
    "conditions of long profiles": (lambda t: (
        (t / "p.csv").write_text(_rows(100_000)),
        _case(t, "conditions:\n" + "".join(f"  - {{name: c{i}, irregularity: p.csv}}\n"
                                            for i in range(3))))[1],
        "case.yaml:6: conditions[2].irregularity: ", "more than 200,000 rows in all"),
    "inline rows going back": (lambda t: _case(t, SIM + "  irregularity:\n    points: |\n"
                                                  "      98, 0\n      97, 0\n"),
                               "case.yaml:5: simulation.irregularity.points: line 2: ",
                               "does not increase"),
    "time_step 1e-12": (lambda t: _case(t, SIM + "  time_step: 1.0e-12\n"),
                        "case.yaml:4: simulation.time_step: 1e-12 s makes ",
                        "at most 500,000 steps"),
    "a fine mesh over a long run": (lambda t: _case(t, FINE_LONG_RUN),
                                    "case.yaml:3: simulation: 263,649 steps of about ",
                                    "at most 1e+10"),
    "a fine mesh on a long track": (lambda t: _case(t, FINE_LONG_TRACK),
                                    "case.yaml:4: simulation.element_length: one simulation "
                                    "would hold ", "at most 2 GB"),
    "a half car on a fine mesh": (lambda t: (t / "case.yaml").write_text(
        f"extends: {HALF_CAR}\nname: h\n" + HALF_CAR_FINE) and "case.yaml",
        "case.yaml:4: simulation.element_length: one simulation would hold about ",
        "at most 2 GB"),
    "50 conditions of fine steps": (lambda t: _case(t, _conditions(50, 1.5e-5)),
                                    "case.yaml:5: conditions: the 50 conditions take ",
                                    "at most 2,000,000"),
    "amplitude_scale 1e12": (lambda t: _case(t, SPECTRUM.format("erri-low", 3, 25, 1.0e12)),
                             IRR[:-2] + ".amplitude_scale: ", "<= 10"),
    "a spectrum too deep": (lambda t: _case(t, SPECTRUM.format("fra-4", 1, 120, 5)),
                            IRR[:-2] + ".amplitude_scale: ", "beyond 0.05 m"),
    "a condition's spectrum band finer than anything": (
        lambda t: _case(t, "conditions:\n  - {name: a, irregularity: {spectrum: erri-low, "
                           "seed: 1, wavelengths: [1.0e-9, 1]}}\n"),
        "case.yaml:4: conditions[0]: simulation.irregularity.wavelengths: ", "resolve"),
    "a key with terminal escapes": (lambda t: _case(t, 'vehicle:\n  "\\e]0;x\\a\\e[2J": 1\n'),
                                    "case.yaml:4: vehicle.\\x1b]0;x\\x07\\x1b[2J: ",
                                    "unknown key"),
}


@pytest.mark.parametrize("kind", list(NEXT_TO))
@pytest.mark.slow
def test_hostile_files_names_and_sizes_next_to_the_case(tmp_path, run_cli, kind):
    make, start, words = NEXT_TO[kind]
    target = make(tmp_path)
    r = run_cli("check", target, timeout=30)
    assert r.returncode == 2, (r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr                       # no traceback, no numpy warning
    assert lines[0].startswith(f"lccopt: error: {start}"), lines[0]
    assert words in lines[0], lines[0]
    assert "\x1b" not in r.stderr and "\x00" not in r.stderr


@pytest.mark.skipif(not os.access("/proc/kmsg", os.R_OK),
                    reason="/proc/kmsg is readable by root only")
def test_a_kernel_file_that_waits_for_data_is_refused_not_waited_for(tmp_path, run_cli):
    """/proc/kmsg looks like a regular file but its read waits for the next kernel message."""
    r = run_cli("check", _irr(tmp_path, "/proc/kmsg"), timeout=30)
    assert r.returncode == 2 and "would wait for more data" in r.stderr, r.stderr


def test_simulate_refuses_what_check_refuses_before_any_memory_goes(tmp_path, run_cli):
    r = run_cli("simulate", _case(tmp_path, "simulation:\n  time_step: 1.0e-12\n"), "--out", "o",
                timeout=30)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "at most 500,000 steps" in r.stderr and not (tmp_path / "o").exists()


def test_simulate_never_shows_a_non_finite_objective_as_a_result(tmp_path, run_cli):
    """Whatever makes a simulation return nan (here a stand-in that does), `simulate` stops
    with one line and exit 2, and writes nothing."""
    from tests.conftest import ROOT

    (tmp_path / "faults").mkdir()
    env = {"LCCOPT_EVALUATOR": "tests.engine.fakesim:faulty", "LCCOPT_TEST_FAULTS": "nan",
           "LCCOPT_TEST_FAULT_DIR": str(tmp_path / "faults"), "PYTHONPATH": str(ROOT)}
    r = run_cli("simulate", Q, "--design", "214,155,50,5,0.6,0.7,0.3,0", "--out", "o", env=env)
    assert r.returncode == 2, (r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "non-finite objectives: F_rms = nan" in lines[0], r.stderr
    assert "nan" not in r.stdout and not (tmp_path / "o").exists()


def test_a_long_extends_chain_of_small_files_loads(tmp_path, run_cli):
    r = run_cli("check", _chain(tmp_path, 200, 3000), timeout=60)
    assert r.returncode == 0 and "ok: case 'c199'" in r.stdout, r.stderr
