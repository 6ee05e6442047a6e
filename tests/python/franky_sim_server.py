"""franky-sim (libfranka's network protocol on MuJoCo) as a subprocess for the tests: start() runs
`python -m franky_sim.run_server -s mujoco` (its `franky-sim` console script; "auto" tries the Genesis
simulator first), reads the loopback address it bound (it takes the first free one of 127.0.0.1,
127.0.0.2, ..., so several servers can run at once) from its output, and returns (process, address)."""

from __future__ import annotations

import os
import queue
import re
import subprocess
import sys
import threading
import time


def start(timeout: float = 120.0):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-m", "franky_sim.run_server", "-s", "mujoco"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                            start_new_session=True)
    lines: "queue.Queue[str]" = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in proc.stdout], daemon=True).start()
    seen = []
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            line = lines.get(timeout=0.2)
        except queue.Empty:
            if proc.poll() is not None:
                break
            continue
        seen.append(line)
        m = re.search(r"using '([0-9.]+)' as the robot IP", line)
        if m:
            return proc, m.group(1)
    stop(proc)
    raise RuntimeError("franky-sim did not start within %g s; its output:\n%s" % (timeout, "".join(seen)))


def stop(proc) -> None:
    if proc.poll() is None:
        proc.kill()
    proc.wait(timeout=30)
