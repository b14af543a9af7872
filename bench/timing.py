"""What the bench scripts share: a command's wall time and peak RSS."""

import os
import subprocess
import sys
import tempfile
import time


def timed(cmd):
    """Runs cmd: (wall seconds, peak RSS MiB, stdout). The wall time is the interval from before the
    fork to the child's exit (perf_counter, so finer than /usr/bin/time's 10 ms); the peak is the
    child's own (wait4's ru_maxrss). Exits naming the calling script and the command when it
    fails."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        start = time.perf_counter()
        child = subprocess.Popen(cmd, stdout=out, stderr=err)
        _, status, usage = os.wait4(child.pid, 0)
        wall = time.perf_counter() - start
        child.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        if child.returncode != 0:
            sys.exit(f"{os.path.basename(sys.argv[0])}: {' '.join(cmd)} failed: {err.read().strip()}")
        return wall, usage.ru_maxrss / 1024, out.read()
