"""Messages for an 80-column terminal: a list of items in lines that do not wrap."""

from __future__ import annotations

WIDTH = 80


def wrap_items(items: list[str], head: str, width: int = WIDTH) -> list[str]:
    """ITEMS joined by ', ' after HEAD, in lines of at most WIDTH characters where the items
    allow (an item is never split), continuation lines indented as far as HEAD."""
    lines, line = [], head
    for i, item in enumerate(items):
        piece = item + ("," if i < len(items) - 1 else "")
        if line != head and len(line) + 1 + len(piece) > width:
            lines.append(line)
            line = " " * len(head) + piece
        else:
            line += ("" if line == head else " ") + piece
    return lines + [line]
