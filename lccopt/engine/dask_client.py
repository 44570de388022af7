"""Reaching a Dask scheduler: its address checked before a Client is made, a Client that
goes quietly when it never connected, and distributed's own reports of a lost connection kept
off the terminal (the executor says in one line what it means for the run)."""

from __future__ import annotations

import contextlib
import logging

from .executors import ExecutorError

_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
# distributed's loggers of the client's side of a connection
_CLIENT_LOGGERS = ("distributed.client", "distributed.batched", "distributed.comm",
                   "distributed.core")



def check_scheduler_address(address: str) -> None:
    """Refuse an address distributed cannot use before a Client is made: an unknown scheme, a
    malformed location, a transport that is not installed (ucx) or TLS without certificates
    in Dask's configuration (lccopt has no options of its own for them)."""
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address, strict=False)
        if scheme not in _SCHEMES:
            raise ValueError(f"unknown scheme '{scheme}://' "
                             f"(expected one of {', '.join(_SCHEMES)})")
        parse_host_port(location)
    except (ValueError, TypeError) as exc:
        raise ExecutorError(f"--scheduler {address[:60]!r}: {exc}; expected e.g. "
                            f"tcp://head-node:8786") from None
    try:
        from distributed.comm.registry import get_backend

        get_backend(scheme).get_connector()
    except Exception as exc:  # noqa: BLE001 - ucx without distributed-ucxx warns and raises
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        need = " (it needs the package distributed-ucxx)" if scheme == "ucx" else ""
        raise ExecutorError(f"--scheduler {address[:60]!r}: the {scheme}:// transport cannot "
                            f"be used here{need}: {first[:160]}; use tcp://") from None
    if scheme in ("tls", "wss"):
        import dask

        tls = dask.config.get("distributed.comm.tls", {}) or {}
        client = tls.get("client") or {}
        if not (tls.get("ca-file") and client.get("cert")):
            raise ExecutorError(f"--scheduler {address[:60]!r}: {scheme}:// needs the client's "
                                f"certificates in Dask's configuration (distributed.comm.tls: "
                                f"ca-file, client.cert, client.key; "
                                f"https://docs.dask.org/en/stable/configuration.html), and "
                                f"none are set")


def quiet_client(*args, **kwargs):
    """A dask.distributed Client whose finaliser, for a Client that never connected, neither
    waits 20 s for a scheduler that is not there nor prints a traceback at exit."""
    from distributed import Client

    class QuietClient(Client):
        def __del__(self):
            if getattr(self, "_Client__loop", None) is None:
                return
            with contextlib.suppress(BaseException):
                self.close(timeout=2)
            with contextlib.suppress(BaseException):
                self._loop_runner.stop()

    return QuietClient(*args, **kwargs)


def quiet_client_loggers() -> dict:
    """Silence distributed's loggers of the client's side (reconnecting, giving up, a closed
    connection's traceback would only repeat the executor's line, with a timestamp); return
    their levels for :func:`restore_loggers`."""
    levels = {}
    for name in _CLIENT_LOGGERS:
        logger = logging.getLogger(name)
        levels[name] = logger.level
        logger.setLevel(logging.CRITICAL)
    return levels


def restore_loggers(levels: dict) -> None:
    for name, level in levels.items():
        logging.getLogger(name).setLevel(level)
