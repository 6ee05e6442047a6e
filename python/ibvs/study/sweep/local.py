"""The local worker pool: batches of episodes on worker processes, each on its own pipe."""

from __future__ import annotations

import multiprocessing
import os
import signal
import traceback
from typing import Optional

from .episodes import run_batch
from .spec import SweepSpec

# Nothing public: the local process pool of ibvs.study.sweep.sweep, used inside ibvs only.
__all__: list[str] = []


def worker(conn, spec: SweepSpec, factories: Optional[dict], inherited: list, parent: int) -> None:
    """A local worker process: runs the batches the parent sends on its own pipe until it sends None
    (or closes the pipe). Ctrl-C and SIGTERM are the parent's, which kills the workers. A parent that
    dies without a word (SIGKILL) is noticed within a second: the worker exits after its batch."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    for c in inherited:  # the parent's ends of the pipes, copied by fork: held here, they would hide its death
        c.close()
    while True:
        try:
            while not conn.poll(1.0):
                if os.getppid() != parent:
                    return
            chunk = conn.recv()
        except EOFError:
            return
        if chunk is None:
            return
        try:
            reply = ("rows", run_batch(spec, chunk, factories), None)
        except Exception as e:  # re-raised in the parent, as a pool would, with the worker's traceback
            reply = ("error", e, traceback.format_exc())
        try:
            conn.send(reply)
        except Exception as e:  # an unpicklable result or exception: its text
            what = RuntimeError(f"{type(reply[1]).__name__}: {reply[1]}") if reply[0] == "error" else e
            conn.send(("error", what, traceback.format_exc()))


def run_local(n_workers: int, spec: SweepSpec, chunks: list, factories: Optional[dict], take) -> None:
    """The batches on worker processes, each with its own pipe: no lock is shared between processes, so
    an interruption can kill the workers at any moment (multiprocessing.Pool.terminate can deadlock on its
    task queue's lock when a signal arrives while an idle worker holds it)."""
    from multiprocessing.connection import wait

    ctx = multiprocessing.get_context()
    workers: list = []
    finished = False
    try:
        fork = ctx.get_start_method() == "fork"
        for _ in range(min(n_workers, len(chunks))):
            parent, child = ctx.Pipe()
            inherited = [c for _, c in workers] + [parent] if fork else []
            p = ctx.Process(target=worker, args=(child, spec, factories, inherited, os.getpid()), daemon=True)
            p.start()
            child.close()
            workers.append((p, parent))
        todo = iter(chunks)
        busy = {}
        for p, conn in workers:
            chunk = next(todo, None)
            if chunk is not None:
                conn.send(chunk)
                busy[conn] = p
        while busy:
            for conn in wait(list(busy)):
                try:
                    kind, value, where = conn.recv()
                except EOFError:
                    busy[conn].join(1)  # reaped, so that its exit code is known
                    raise RuntimeError(f"a sweep worker died (exit code {busy[conn].exitcode})") from None
                if kind == "error":
                    raise value from RuntimeError(f"in the sweep worker:\n{where}")
                take(value)
                chunk = next(todo, None)
                if chunk is None:
                    del busy[conn]
                else:
                    conn.send(chunk)
        for _, conn in workers:
            conn.send(None)
        finished = True
    finally:  # normal end: the workers exit by themselves; an interruption or an error: killed now
        for p, conn in workers:
            if finished:
                p.join(timeout=5)
            if p.exitcode is None:
                p.kill()
                p.join()
            conn.close()
