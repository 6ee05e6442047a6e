"""The Dask path: the same batches of episodes on a dask.distributed scheduler."""

from __future__ import annotations

import math
from typing import Optional

from .episodes import chunks, run_batch
from .spec import SweepSpec

# What ibvs.study.sweep re-exports (and documents); the other names here are its own helpers.
__all__ = ["CONNECT_TIMEOUT", "SchedulerLost"]

#: Seconds a Dask scheduler address has to answer.
CONNECT_TIMEOUT = 5.0


def connect(scheduler):
    """A dask.distributed Client of an address (ConnectionError within CONNECT_TIMEOUT s when it
    does not answer), or the Client given."""
    try:
        from dask.distributed import Client
    except ImportError as e:
        raise ImportError('scheduler= needs Dask: pip install ".[distributed]" from the ibvs repository') from e
    if isinstance(scheduler, Client):
        return scheduler
    if not isinstance(scheduler, str):
        raise TypeError(f"scheduler must be an address string or a dask.distributed Client, got "
                        f"{type(scheduler).__name__}")
    from distributed.comm.addressing import parse_address, parse_host_port

    try:  # a malformed address is refused here: a Client that fails to parse one hangs on exit
        kind, where = parse_address(scheduler, strict=False)
        if kind != "inproc" and parse_host_port(where)[1] <= 0:
            raise ValueError
    except (ValueError, TypeError):
        raise ValueError(f"scheduler: {scheduler!r} is not a scheduler address such as tcp://127.0.0.1:8786") \
            from None
    import logging

    # distributed logs every failed attempt; the one-line error below says it all.
    quiet = [logging.getLogger(n) for n in ("distributed.client", "distributed.comm.core", "distributed.core")]
    levels = [q.level for q in quiet]
    for q in quiet:
        q.setLevel(logging.CRITICAL)
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as e:
        raise ConnectionError(f"scheduler: no Dask scheduler answers at {scheduler!r} within "
                              f"{CONNECT_TIMEOUT:g} s ({type(e).__name__})") from None
    finally:
        for q, level in zip(quiet, levels):
            q.setLevel(level)


class SchedulerLost(ConnectionError):
    """The Dask scheduler stopped answering during a sweep (it died, or its host or the network went
    away): the rows finished before are in the CSV."""


def _lost(client, e: BaseException) -> bool:
    """Whether exception e, raised while waiting for the sweep's results, means the scheduler is gone."""
    if isinstance(e, (KeyboardInterrupt, SystemExit)):
        return False
    try:
        from distributed.client import FutureCancelledError
        from distributed.comm import CommClosedError
    except ImportError:  # pragma: no cover - run_dask imports distributed first
        return False
    if isinstance(e, FutureCancelledError):
        return e.reason == "scheduler-connection-lost" or client.status != "running"
    return isinstance(e, (CommClosedError, OSError, TimeoutError)) or client.status not in ("running", "newly-created")


def run_dask(client, own: bool, spec: SweepSpec, todo: list, factories: dict, batch: Optional[int], take) -> None:
    """The batches on a Dask client, each handed to take() as it finishes. SchedulerLost (one line, no
    traceback of Dask's) when the scheduler stops answering; distributed's own log lines about the
    lost connection are silenced meanwhile (that exception says it)."""
    import logging

    from dask.distributed import as_completed

    address = getattr(getattr(client, "scheduler", None), "address", None) or "its address"
    quiet = [logging.getLogger(n) for n in ("distributed.client", "distributed.comm", "distributed.core",
                                            "distributed.batched", "distributed.utils")]
    levels = [q.level for q in quiet]
    lost = False
    futures: list = []
    try:
        try:
            workers = max(1, sum(client.nthreads().values()))
            size = batch or max(1, min(256, math.ceil(len(todo) / (4 * workers))))
            futures = [client.submit(run_batch, spec, chunk, factories, pure=False)
                       for chunk in chunks(todo, size)]
            for q in quiet:  # from here a lost scheduler is reported by SchedulerLost alone
                q.setLevel(logging.CRITICAL + 1)
            for fut in as_completed(futures, loop=client.loop):
                take(fut.result())
        except BaseException as e:
            lost = _lost(client, e)
            try:
                if futures:
                    client.cancel(futures)
            except Exception:
                if not lost:
                    raise
            if lost:
                raise SchedulerLost(f"scheduler: lost the Dask scheduler at {address} (its connection closed)") \
                    from None
            raise
    finally:
        try:
            if own:
                client.close(timeout=CONNECT_TIMEOUT)
        except Exception:
            if not lost:
                raise
        finally:
            for q, level in zip(quiet, levels):
                q.setLevel(level)
