"""What on this machine shapes lccopt's floating point beyond the library versions.

With the same case, seed, versions and worker count a run repeats exactly on one machine; on
another its values can differ in the last bits, and the optimiser amplifies that into other
designs. Two choices made at load time decide it (README, "Reproducibility"): the kernels
OpenBLAS picks for the CPU (``OPENBLAS_CORETYPE`` overrides the pick) and the SIMD loops numpy
dispatches to (``NPY_DISABLE_CPU_FEATURES`` turns some off). Measured: pinning both repeats
another machine's runs to the last printed digit. They are recorded with the versions of each
run (run.json, the journal, results.h5), in each evaluation's file (the worker's entries) and
in ``lccopt simulate``'s file, and compared on resume, with the fingerprint of the code that
computed them (the version number changes at releases only: two checkouts of one version can
model the track differently).
"""

from __future__ import annotations

import ctypes
import functools
import re
import sys


def blas_kernels() -> str:
    """OpenBLAS's kernel set for each OpenBLAS loaded by numpy and scipy, e.g. "SkylakeX"
    (one name if both agree); "unknown" where it cannot be read (another BLAS, not Linux)."""
    import numpy  # noqa: F401 - load the libraries whose kernels are asked
    import scipy.linalg  # noqa: F401

    names = []
    for path in _loaded_openblas():
        try:
            lib = ctypes.CDLL(path)  # already loaded: the same handle, no second copy
        except OSError:
            continue
        for symbol in ("openblas_get_corename", "openblas_get_corename64_",
                       "scipy_openblas_get_corename", "scipy_openblas_get_corename64_"):
            fn = getattr(lib, symbol, None)
            if fn is not None:
                fn.restype = ctypes.c_char_p
                names.append((fn() or b"?").decode("ascii", "replace"))
                break
    names = sorted(set(names))
    return " ".join(names) if names else "unknown"


def _loaded_openblas() -> list[str]:
    if not sys.platform.startswith("linux"):
        return []
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as fh:
            paths = {line.split()[-1] for line in fh if "openblas" in line.lower()}
    except OSError:
        return []
    return sorted(p for p in paths if p.startswith("/"))


def numpy_simd() -> str:
    """The SIMD targets numpy dispatches to on this CPU (its dispatchable ones that are on),
    e.g. "X86_V3 X86_V4 AVX512_ICL"; "unknown" for a numpy that does not say."""
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:
        try:
            from numpy.core._multiarray_umath import __cpu_dispatch__, __cpu_features__
        except ImportError:
            return "unknown"
    return " ".join(f for f in __cpu_dispatch__ if __cpu_features__.get(f)) or "none"


# The entries, as recorded (beside the versions, in evaluation files' /info).
ENTRIES = ("blas_kernels", "numpy_simd", "lccopt_code")
# How the resume note names them
LABELS = {"lccopt_code": "lccopt's code"}


@functools.cache  # fixed once the libraries are loaded
def describe() -> dict:
    """The entries recorded beside the library versions: the machine's numerics and the code
    that computes with them."""
    from .version import code_fingerprint

    try:
        blas = blas_kernels()
    except Exception:  # noqa: BLE001 - a record, never a reason to stop a run
        blas = "unknown"
    try:
        code = code_fingerprint()
    except OSError:    # a package file unreadable: a record, never a reason to stop a run
        code = "unknown"
    return {"blas_kernels": blas, "numpy_simd": numpy_simd(), "lccopt_code": code}


# Versions and entries whose change makes a resumed run's later designs differ from an
# uninterrupted run's (lccopt's version number says less than its code's fingerprint)
NUMERIC_KEYS = ("numpy", "scipy", *ENTRIES)


def resume_note(started: dict, now: dict) -> str | None:
    """A one-line note when the numerics of this session differ from the run's start, with the
    environment that pins the machine entries back where that is possible; None if alike."""
    if not isinstance(started, dict):
        return None
    started = {k: _plain(v) for k, v in started.items() if k in NUMERIC_KEYS}
    now = {k: _plain(v) for k, v in now.items() if k in NUMERIC_KEYS}
    changed = [k for k in NUMERIC_KEYS if k in started and k in now and started[k] != now[k]]
    if not changed:
        return None
    was = ", ".join(f"{LABELS.get(k, k)} {started[k]}" for k in changed)
    here = ", ".join(f"{LABELS.get(k, k)} {now[k]}" for k in changed)
    pins = _pins(started, now, changed)
    hint = f" (resume with {pins} to match its start)" if pins else ""
    code = (", and this code's model values them (lccopt --version prints a code's fingerprint)"
            if "lccopt_code" in changed else "")
    return (f"this run began with {was}; here {here}: the designs it evaluates from here on may "
            f"differ from an uninterrupted run's{code}{hint}")


def _plain(value) -> str:
    """A recorded entry as shown and compared: words of letters, digits and ._+- only (the
    journal is a file: nothing from it reaches the terminal or a suggested command as is)."""
    text = str(value)
    return text if len(text) <= 100 and re.fullmatch(r"[\w.+\- ]*", text, re.ASCII) else "unknown"


def _pins(started: dict, now: dict, changed: list[str]) -> str | None:
    """Environment settings that give this session the run's starting machine entries, or
    None when a changed entry cannot be pinned (a library version, a SIMD target this CPU
    lacks, an unknown entry)."""
    pins = []
    for key in changed:
        old, new = started[key], now[key]
        if key == "blas_kernels" and old != "unknown" and " " not in old:
            pins.append(f"OPENBLAS_CORETYPE={old}")
        elif (key == "numpy_simd" and "unknown" not in (old, new)
              and set(old.split()) <= set(new.split())):
            off = [f for f in new.split() if f not in old.split()]
            pins.append(f'NPY_DISABLE_CPU_FEATURES="{" ".join(off)}"')
        else:
            return None
    return " ".join(pins)
