"""Messages for an 80-column terminal."""
import subprocess
import sys
from pathlib import Path

from lccopt.terminal import wrap_items

ROOT = Path(__file__).resolve().parents[1]


def test_items_fill_lines_up_to_the_width_and_are_never_split():
    items = [f"x_{i}={i * 111.5:g} MN/m" for i in range(12)]
    lines = wrap_items(items, "  x: ", width=40)
    assert len(lines) > 1 and all(len(line) <= 40 for line in lines)
    assert lines[0].startswith("  x: ") and all(line.startswith(" " * 5) for line in lines[1:])
    assert " ".join(line.strip() for line in lines)[3:] == ", ".join(items)
    # each line is full: its successor's first item would not have fitted
    for line, nxt in zip(lines, lines[1:]):
        assert len(line) + 1 + len(nxt.strip().split(", ")[0]) > 40


def test_an_item_longer_than_the_width_gets_a_line_of_its_own():
    lines = wrap_items(["a", "b" * 50, "c"], "> ", width=20)
    assert lines == ["> a,", "  " + "b" * 50 + ",", "  c"]
    assert wrap_items([], "> ") == ["> "]


def test_check_prints_lines_of_at_most_80_characters():
    reference = ROOT / "configs" / "reference.yaml"
    proc = subprocess.run([sys.executable, "-m", "lccopt", "check", str(reference)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert "ok: case 'reference', 8 design variables" in lines[0]
    assert all(len(line) <= 80 for line in lines[1:]), lines
    assert "x_l [0, 12] m in 0.1 m steps" in proc.stdout
