"""Progress on stderr: a redrawn line on a terminal, one plain line per evaluation otherwise."""

from __future__ import annotations

import math
import sys
import time


def hms(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    s = int(round(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def fmt(v) -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.6g}"


class Progress:
    def __init__(self, budget: int, stream=None, enabled: bool = True):
        self.stream = stream or sys.stderr
        self.budget = budget
        self.enabled = enabled
        self.tty = enabled and hasattr(self.stream, "isatty") and self.stream.isatty()
        self.t0 = time.monotonic()
        self.done0: int | None = None   # evaluations already done when this session started
        self._drawn = False

    def log(self, message: str) -> None:
        """A message on its own line (clears a drawn progress line first)."""
        if self._drawn:
            self.stream.write("\r\033[K")
            self._drawn = False
        self.stream.write(f"lccopt: {message}\n")
        self.stream.flush()

    def update(self, table, running: int, last: dict | None = None) -> None:
        if not self.enabled:
            return
        done, failed = table.n_done, table.n_failed
        if self.done0 is None:
            self.done0 = done
        elapsed = time.monotonic() - self.t0
        new = done - self.done0
        left = (self.budget - done) * elapsed / new if new > 0 else math.nan
        best = table.best()
        best_s = f"best {fmt(best['value'])} (#{best['id']})" if best else "best -"
        width = len(str(self.budget))
        head = f"[{done:>{width}}/{self.budget}] {best_s}  failed {failed}  running {running}  " \
               f"elapsed {hms(elapsed)}  left ~{hms(left)}"
        if self.tty:
            frac = min(1.0, done / max(1, self.budget))
            bar = "#" * int(20 * frac) + "-" * (20 - int(20 * frac))
            self.stream.write(f"\r\033[K{bar} {head}")
            self._drawn = True
        elif last is not None:
            what = (f"#{last['id']} {last['phase']} value {fmt(last['value'])}" if last["status"] == "ok"
                    else f"#{last['id']} {last['phase']} FAILED: {last['reason']}")
            self.stream.write(f"lccopt: {head}  | {what}\n")
        self.stream.flush()

    def close(self) -> None:
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False
