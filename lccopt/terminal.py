"""Messages for an 80-column terminal: a list of items in lines that do not wrap."""

from __future__ import annotations

import sys

from .errors import printable_lines

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


def echo(message: str = "", err: bool = False) -> None:
    """Say one message, as a line on standard output (``err``: on standard error), flushed:
    the library's default for the messages of a long job (a report's warnings, a check that
    takes a while). A program passes its own function of the same signature (the command
    line passes ``typer.echo``; a notebook may pass a logger's)."""
    stream = sys.stderr if err else sys.stdout
    if stream is None:
        return
    stream.write(f"{message}\n")
    stream.flush()


STREAM_NAMES = {0: "standard input", 1: "standard output", 2: "standard error"}


def guard_streams() -> None:
    """Make the command's standard streams safe to use whatever it was started with.

    A descriptor 0, 1 or 2 that is closed (``2>&-``) is opened on /dev/null first: otherwise
    the next file opened (a run's journal) would take its number, and anything written to
    "stderr" (a library's warning, a worker's) would land in that file. stdout and stderr are
    then wrapped in :class:`PipeGuard`."""
    import io
    import os

    closed = []
    for fd in (0, 1, 2):
        try:
            os.fstat(fd)
        except OSError:
            closed.append(fd)
    for fd in closed:
        null = os.open(os.devnull, os.O_RDWR)
        if null != fd:
            os.dup2(null, fd)
            os.close(null)
    for fd, attr in ((1, "stdout"), (2, "stderr")):
        stream = getattr(sys, attr)
        if isinstance(stream, PipeGuard):
            continue
        if stream is None or fd in closed:  # the interpreter found no stream: a fresh one
            stream = io.TextIOWrapper(io.FileIO(fd, "w", closefd=False), encoding="utf-8",
                                      errors="backslashreplace", line_buffering=True)
        guard = PipeGuard(stream, STREAM_NAMES[fd])
        if fd in closed:
            guard.failed = "it was closed"
        setattr(sys, attr, guard)


class PipeGuard:
    """A text stream that survives its reader going away (``lccopt ... | head``) and any other
    failure to write (a closed descriptor, ``>/dev/full``, an I/O error).

    The first write or flush that meets a closed pipe points the descriptor at /dev/null and
    sets :attr:`closed_pipe`; every later write goes nowhere. The command then finishes what
    it must not leave half done (a simulation's files, a run's journal and snapshot) and the
    command line exits 141, as a process killed by SIGPIPE would.

    Every line written is made printable (``errors.printable_lines``): a run's stored strings
    never reach the terminal as control sequences, whichever command prints them.

    Any other failure (the stream was closed, the disk behind it is full, an I/O error) sets
    :attr:`failed` (why) and :attr:`lost` (something was not written); later writes go nowhere
    and the command carries on: its work never depends on being able to print. The command
    line exits 2 when standard output lost something, naming it; standard error (progress
    and messages) is best effort."""

    closed_pipe = False   # class-wide: any guarded stream that met a closed pipe

    def __init__(self, stream, name: str = "the output"):
        self._stream = stream
        self.name = name
        self.failed: str | None = None   # why this stream writes nowhere (not a closed pipe)
        self.lost = False                # something written to it did not arrive
        self.encoding = getattr(stream, "encoding", "utf-8")
        self.errors = getattr(stream, "errors", "strict")

    def __getattr__(self, name):  # isatty, fileno, buffer, ...
        return getattr(self._stream, name)

    @property
    def raw(self):
        """The stream itself, for a writer that makes its own control sequences (the live
        progress line on a terminal) and escapes what it shows."""
        return self._stream

    def _to_devnull(self) -> None:
        import os

        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)
        except (OSError, ValueError, AttributeError):
            pass

    def _closed(self) -> None:
        PipeGuard.closed_pipe = True
        self._to_devnull()

    def _failed(self, exc: BaseException) -> None:
        self.lost = True
        if self.failed is None:
            self.failed = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
            self._to_devnull()
            try:  # what the stream still buffers now goes to /dev/null, not to a later failure
                self._stream.flush()
            except (OSError, ValueError):
                pass

    def write(self, text: str) -> int:
        if PipeGuard.closed_pipe:
            return len(text)
        if self.failed is not None:
            self.lost = self.lost or bool(text)
            return len(text)
        try:
            self._stream.write(printable_lines(text))
            return len(text)
        except BrokenPipeError:
            self._closed()
        except (OSError, ValueError) as exc:  # closed, full, I/O error
            self._failed(exc)
        return len(text)

    def flush(self) -> None:
        if PipeGuard.closed_pipe or self.failed is not None:
            return
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._closed()
        except (OSError, ValueError) as exc:
            self._failed(exc)
