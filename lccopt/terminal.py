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


def wrap_message(text: str, width: int | None = None) -> str:
    """TEXT in lines of the terminal's width (at most WIDTH if it cannot be told), continuation
    lines indented by two spaces; words (a file path, a key) are never split."""
    import shutil
    import textwrap

    width = width or shutil.get_terminal_size((WIDTH, 24)).columns
    return "\n".join(textwrap.wrap(text, width=max(40, width), subsequent_indent="  ",
                                   break_long_words=False, break_on_hyphens=False))


class PipeGuard:
    """A text stream that survives its reader going away (``lccopt ... | head``).

    The first write or flush that meets a closed pipe points the descriptor at /dev/null and
    sets :attr:`closed_pipe`; every later write goes nowhere. The command then finishes what
    it must not leave half done (a simulation's files, a run's journal and snapshot) and the
    command line exits 141, as a process killed by SIGPIPE would."""

    closed_pipe = False   # class-wide: any guarded stream that met a closed pipe

    def __init__(self, stream):
        self._stream = stream
        self.encoding = getattr(stream, "encoding", "utf-8")
        self.errors = getattr(stream, "errors", "strict")

    def __getattr__(self, name):  # isatty, fileno, buffer, ...
        return getattr(self._stream, name)

    def _closed(self) -> None:
        import os

        PipeGuard.closed_pipe = True
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)
        except (OSError, ValueError, AttributeError):
            pass

    def write(self, text: str) -> int:
        if PipeGuard.closed_pipe:
            return len(text)
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._closed()
            return len(text)

    def flush(self) -> None:
        if PipeGuard.closed_pipe:
            return
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._closed()
