"""What the bench scripts share: a command's wall time and peak RSS through /usr/bin/time."""

import os
import subprocess
import sys
import tempfile


def timed(cmd):
    """Runs cmd under /usr/bin/time: (wall seconds, peak RSS MiB, stdout). Exits naming the calling
    script and the command when it fails."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as t:
        r = subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", t.name, *cmd], capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"{os.path.basename(sys.argv[0])}: {' '.join(cmd)} failed: {r.stderr.strip()}")
        wall, kib = t.read().split()[-2:]
        return float(wall), int(kib) / 1024, r.stdout
