"""What a user sees on an 80-column terminal: the progress line fits, is redrawn in place and
shows the best design's objectives in kN/J with the change against the reference."""

from __future__ import annotations

import fcntl
import os
import pty
import re
import struct
import subprocess
import termios
import time

import pytest

from tests.conftest import CONFIGS, REFERENCE, lccopt_command, subprocess_env, write_case

# seconds a test: runs on a pseudo-terminal
pytestmark = pytest.mark.slow

ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def _pty_run(args, cwd, columns=80, env=None, timeout=300) -> tuple[int, str]:
    """(exit status, everything written) of `lccopt ARGS` on a terminal of ``columns``."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, columns, 0, 0))
    e = subprocess_env({k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")},
                       TERM="xterm-256color", **(env or {}))
    proc = subprocess.Popen(lccopt_command() + [str(a) for a in args], cwd=cwd, env=e,
                            stdin=slave, stdout=slave, stderr=slave, close_fds=True)
    os.close(slave)
    chunks, deadline = [], time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            data = os.read(master, 65536)
        except OSError:  # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    proc.wait(timeout=60)
    os.close(master)
    return proc.returncode, b"".join(chunks).decode("utf-8", errors="replace")


def run_in_terminal(args, cwd, columns=80, timeout=300) -> str:
    code, text = _pty_run(args, cwd, columns, timeout=timeout)
    assert code == 0, text
    return text


def test_progress_fits_80_columns_and_names_objectives_in_engineering_units(tmp_path):
    write_case(tmp_path, name="tty", budget=8, initial=4)
    out = run_in_terminal(["optimise", "tty.yaml", "--workers", "1"], tmp_path)
    text = ANSI.sub("", out)
    screen_lines = [seg for line in text.split("\n") for seg in line.split("\r")]
    progress = [s for s in screen_lines if re.search(r"\b\d/8\b", s)]
    assert len(progress) >= 8, text           # redrawn in place: one segment per evaluation
    too_wide = [s for s in screen_lines if len(s.rstrip()) > 80]
    assert not too_wide, too_wide
    # an ETA once known
    assert "8/8" in progress[-1] and "-:--:--" not in progress[-1], progress[-1]
    # the best design below the line, in engineering units with the change
    best = [s for s in screen_lines if s.startswith("  best ")]
    assert best and re.search(r"F_max [0-9.]+ kN [+-]\d+%, E_max [0-9.]+ J [+-]\d+%", best[-1]), \
        best
    # the full best-design line is in the summary printed at the end
    assert re.search(r"F_max [0-9.]+ kN", text) and re.search(r"E_max [0-9.]+ J", text), text


def test_long_objective_names_are_never_cut_at_80_columns(tmp_path):
    """A settlement run's three objectives (differential_settlement, maintenance_rate, F_max)
    do not fit beside the bar on 80 columns: they go on the lines below it, wrapped between
    objectives, each name whole."""
    case = tmp_path / "long.yaml"
    case.write_text(f"extends: {CONFIGS / 'settlement.yaml'}\nname: long\noptimisation:\n"
                    "  objectives: [differential_settlement, maintenance_rate, F_max]\n"
                    "  budget: 6\n  initial_points: 4\n", encoding="utf-8")
    code, text = _pty_run(["optimise", "long.yaml", "--workers", "1"], tmp_path,
                          env={"LCCOPT_EVALUATOR": "tests.engine.fakesim:settled"})
    assert code == 0, text
    lines = [seg for line in ANSI.sub("", text).split("\n") for seg in line.split("\r")]
    assert not [s for s in lines if len(s.rstrip()) > 80]
    assert not [s for s in lines if "…" in s], text            # nothing cut
    best = [s for s in lines if s.startswith("  best ")]
    assert best, text
    shown = " ".join(s for s in lines if s.startswith(("  best ", "       ")))
    for name in ("differential_settlement", "maintenance_rate", "F_max"):
        assert re.search(rf"{name} [0-9.]+ \S+ [+-]\d+%", shown), (name, shown)


def test_a_traffic_run_moves_per_condition_from_the_first_simulation(tmp_path):
    """Three conditions per design: the line counts simulations (of 3 x budget) and moves as each
    condition finishes, from the session's start (the reference design's time counts)."""
    conditions = ("conditions:\n  - {name: a, speed: 30.0}\n  - {name: b, speed: 35.0}\n"
                  "  - {name: c, speed: 38.88888888888889}\n")
    case = write_case(tmp_path, name="ttr", budget=6, initial=4, worst=(90000.0, 9.0),
                      extra=conditions)
    env_before = dict(os.environ)
    os.environ.update(LCCOPT_EVALUATOR="tests.engine.fakesim:evaluate", LCCOPT_FAKE_DELAY="0.3")
    try:
        out = run_in_terminal(["optimise", case, "--workers", "1", "--runs", tmp_path / "runs"],
                              tmp_path)
    finally:
        os.environ.clear()
        os.environ.update(env_before)
    text = ANSI.sub("", out)
    counts = [int(m.group(1)) for m in re.finditer(r"\b(\d+)/18\b", text)]
    assert counts and counts[0] == 0, text                # drawn before the first result
    assert {1, 2} <= set(counts), counts   # the reference design's conditions one by one
    assert counts[-1] == 18 and counts == sorted(counts), counts


def _terminal_lines(args, cwd, env=None) -> tuple[int, list[str]]:
    """(exit status, screen lines) of `lccopt ARGS` on an 80-column terminal."""
    code, raw = _pty_run(args, cwd, env=env)
    text = ANSI.sub("", raw)
    screen_lines = [seg for line in text.split("\n") for seg in line.split("\r") if seg.strip()]
    return code, screen_lines


def test_error_messages_fit_an_80_column_terminal(tmp_path):
    long_name = "a-case-file-with-a-rather-long-name-for-my-crossing.yaml"   # a 56-character word
    (tmp_path / long_name).write_text(
        "extends: " + str(REFERENCE) + "\nname: t\nvehicle: {sped: 30}\n")
    for args in (["optimse", "x.yaml"], ["check", long_name],
                 ["optimise", "x.yaml", "--wrokers", "2"],
                 ["resume", "no-such-run-directory-here"]):
        code, lines = _terminal_lines(args, tmp_path)
        assert code == 2, lines
        assert lines[0].startswith("lccopt"), lines
        assert all(len(line) <= 80 for line in lines), lines
        assert all(line.startswith("  ") for line in lines[1:]), lines   # one message, wrapped
