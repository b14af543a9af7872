"""isoslab.extract() in process (issue 34): the program's bytes and messages without a child
process or a temporary file, progress, and stops from the callable and from Ctrl-C."""
import os
import re
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import isoslab

PROGRAM = os.environ.get("ISOSLAB_PROGRAM", "isoslab")
PHILIPS = os.path.join(os.path.dirname(__file__), "..", "..", "..", "shared", "data", "ct-philips-head")


class Watch:
    """Records, while it is active, every child process of this one (from /proc, every 2 ms) and
    every process or temporary file that Python's audit events show being started or made."""
    events = []
    _hooked = False

    def __init__(self):
        self.children = set()
        self._stop = threading.Event()
        if not Watch._hooked:
            sys.addaudithook(Watch._audit)
            Watch._hooked = True

    @staticmethod
    def _audit(event, args):
        if event in ("subprocess.Popen", "os.posix_spawn", "os.fork", "os.exec", "os.system", "tempfile.mkstemp",
                     "tempfile.mkdtemp"):
            Watch.events.append(event)

    def _poll(self):
        tasks = f"/proc/{os.getpid()}/task"
        while not self._stop.is_set():
            for task in os.listdir(tasks):
                try:
                    with open(f"{tasks}/{task}/children") as f:
                        self.children.update(f.read().split())
                except OSError:
                    pass
            time.sleep(0.002)

    def __enter__(self):
        Watch.events.clear()
        self._thread = threading.Thread(target=self._poll, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()


def test_the_watch_sees_a_child_process(tmp_path):
    # The check below must be able to fail: a program started meanwhile is seen both ways.
    with Watch() as w:
        subprocess.run(["sleep", "0.05"], check=True)
    assert w.children and "subprocess.Popen" in Watch.events


@pytest.mark.skipif(not os.path.isdir(PHILIPS), reason="../shared/data is absent")
def test_philips_series_gives_the_programs_bytes_in_process(tmp_path):
    with Watch() as w:
        report = isoslab.extract(PHILIPS, tmp_path / "a.glb", iso=350, threads=2, normals=True, report=tmp_path / "a.json")
    assert not w.children and not Watch.events, (w.children, Watch.events)
    subprocess.run([PROGRAM, "extract", PHILIPS, "--iso", "350", "--threads", "2", "--normals", "-q", "-o",
                    str(tmp_path / "b.glb")], check=True)
    assert (tmp_path / "a.glb").read_bytes() == (tmp_path / "b.glb").read_bytes()
    assert report["reader"] == "dicom" and report["triangles"] > 100000
    assert report["output"]["bytes"] == (tmp_path / "a.glb").stat().st_size
    assert sorted(os.listdir(tmp_path)) == ["a.glb", "a.json", "b.glb"]


def test_array_gives_the_programs_bytes_without_a_temporary_file(tmp_path, monkeypatch):
    volume = (np.random.default_rng(4).normal(size=(30, 32, 34)) * 100).astype(np.int16)
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    monkeypatch.setenv("TMPDIR", str(temporary))
    out = tmp_path / "out"
    out.mkdir()
    with Watch() as w:
        report = isoslab.extract(volume, out / "a.ply", iso=50, spacing=(2, 1, 0.5), threads=2,
                                 sequential_voxels=0)
    assert not w.children and not Watch.events, (w.children, Watch.events)
    assert os.listdir(temporary) == [] and os.listdir(out) == ["a.ply"]
    volume.tofile(tmp_path / "v.raw")
    subprocess.run([PROGRAM, "extract", str(tmp_path / "v.raw"), "--raw-dims", "34,32,30", "--raw-type", "i16",
                    "--spacing", "0.5,1,2", "--iso", "50", "-q", "-o", str(tmp_path / "b.ply")], check=True)
    assert (out / "a.ply").read_bytes() == (tmp_path / "b.ply").read_bytes()
    assert report["input"] == "array" and report["voxel_type"] == "i16" and report["spacing"] == [0.5, 1, 2]


def test_progress_rises_to_one_over_both_passes(tmp_path):
    calls = []
    isoslab.extract("phantom:head?n=64", tmp_path / "a.ply", keep_largest=1,
                    progress=lambda fraction, stage: calls.append((fraction, stage)))
    fractions = [f for f, _ in calls]
    assert fractions == sorted(fractions) and len(set(fractions)) == len(fractions)
    assert fractions[-1] == 1 and all(0 < f < 1 for f in fractions[:-1])
    stages = [s for _, s in calls]
    assert stages[0] == "components" and stages[-1] == "extract"
    assert max(f for f, s in calls if s == "components") <= 0.5


class Stop(Exception):
    pass


@pytest.mark.parametrize("output", ["a.glb", "a.ply", "a.drc"])
def test_an_exception_from_the_callable_stops_the_run_and_leaves_nothing(tmp_path, output):
    def progress(fraction, stage):
        if fraction > 0.3:
            raise Stop(f"at {fraction:.2f}")

    with pytest.raises(Stop):
        isoslab.extract("phantom:head?n=200", tmp_path / output, report=tmp_path / "a.json", threads=2,
                        progress=progress)
    assert os.listdir(tmp_path) == []


def test_ctrl_c_stops_within_a_slab_and_leaves_nothing(tmp_path):
    seen = []

    def progress(fraction, stage):
        seen.append(time.monotonic())
        if len(seen) == 5:
            os.kill(os.getpid(), signal.SIGINT)  # as Ctrl-C: Python's handler raises in this thread

    with pytest.raises(KeyboardInterrupt):
        isoslab.extract("phantom:head?n=300", tmp_path / "a.glb", progress=progress)
    assert len(seen) < 50, "the run went on long after the interrupt"
    assert os.listdir(tmp_path) == []


def test_errors_raise_the_programs_one_line(tmp_path):
    cases = [
        (dict(inputs="phantom:head?n=20", output=tmp_path / "a.ply", report=tmp_path / "a.ply"),
         ["phantom:head?n=20", "--report", str(tmp_path / "a.ply"), "-o", str(tmp_path / "a.ply")]),
        (dict(inputs="phantom:head?n=20", output=tmp_path / "a.ply", smooth=3, pass_band=5),
         ["phantom:head?n=20", "--smooth", "3", "--pass-band", "5", "-o", str(tmp_path / "a.ply")]),
        (dict(inputs=str(tmp_path / "absent.nii"), output=tmp_path / "a.ply", iso=3),
         [str(tmp_path / "absent.nii"), "--iso", "3", "-o", str(tmp_path / "a.ply")]),
    ]
    for kwargs, argv in cases:
        with pytest.raises(isoslab.Error) as e:
            isoslab.extract(kwargs.pop("inputs"), kwargs.pop("output"), **kwargs)
        run = subprocess.run([PROGRAM, "extract", *argv], capture_output=True, text=True)
        assert run.returncode != 0 and run.stderr == f"isoslab: error: {e.value}\n"
    assert os.listdir(tmp_path) == []


def test_unknown_options_are_refused():
    with pytest.raises(TypeError, match="unexpected keyword argument 'smoothness'"):
        isoslab.extract("phantom:head?n=20", "a.ply", smoothness=3)


CHILD = """
import sys, isoslab
isoslab.extract("phantom:head?n=200", sys.argv[1], progress={"default": None, "on": True, "off": False}[sys.argv[2]])
"""


def test_progress_takes_a_callable_true_or_false():
    labels = np.zeros((6, 6, 6), np.int32)
    labels[2:4, 2:4, 2:4] = 1
    for progress in (True, False, None, np.bool_(True), lambda fraction, stage: None):
        assert list(isoslab.label_surfaces(labels, progress=progress)[0]) == [1]
    for call in (lambda p: isoslab.label_surfaces(labels, progress=p),
                 lambda p: isoslab.extract("phantom:voxel", "a.ply", progress=p)):
        with pytest.raises(TypeError, match=r"progress must be callable, True or False \(got int 3\)"):
            call(3)


@pytest.mark.parametrize("progress", ["default", "on", "off"])
def test_a_progress_bar_on_a_terminal_unless_turned_off(tmp_path, progress):
    pytest.importorskip("tqdm")
    import fcntl
    import pty
    import struct
    import termios
    main, secondary = pty.openpty()
    fcntl.ioctl(secondary, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))  # a terminal's size
    run = subprocess.run([sys.executable, "-c", CHILD, str(tmp_path / "a.ply"), progress], stderr=secondary,
                         env=dict(os.environ), timeout=120)
    os.close(secondary)
    seen = b""
    try:
        while chunk := os.read(main, 65536):
            seen += chunk
    except OSError:
        pass  # the terminal closed
    os.close(main)
    assert run.returncode == 0
    if progress != "off":
        # tqdm's bar, redrawn in place up to 100%, then cleared (leave=False).
        shown = [int(p) for p in re.findall(rb"isoslab extract: +(\d+)%", seen)]
        assert len(shown) > 5 and shown == sorted(shown) and shown[-1] == 100, seen[-300:]
        assert seen.endswith(b"\r"), seen[-100:]
    else:
        assert seen == b""
