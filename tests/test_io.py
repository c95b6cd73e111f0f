"""The one output writer (ndrql.io): atomic replace, symlinks, FIFOs, umask, no debris, clear errors."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import stat
import threading
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from ndrql import io as nio
from ndrql.io import atomic as nio_atomic
from ndrql.errors import NdrqlError, OutputError


def _listing(folder: Path) -> list[str]:
    return sorted(os.listdir(folder))


def test_write_bytes_and_text_round_trip(tmp_path):
    assert nio.write_bytes(tmp_path / "a.bin", b"\x00\x01") == tmp_path / "a.bin"
    assert (tmp_path / "a.bin").read_bytes() == b"\x00\x01"
    nio.write_text(tmp_path / "b.txt", "h\u00e9\n")
    assert (tmp_path / "b.txt").read_bytes() == "h\u00e9\n".encode()
    assert _listing(tmp_path) == ["a.bin", "b.txt"]


def test_replaces_atomically_with_a_new_inode(tmp_path):
    target = tmp_path / "out.json"
    target.write_text("old")
    old_inode = target.stat().st_ino
    held = open(target)  # a reader that opened the old file keeps seeing the old contents
    nio.write_json(target, {"x": 1})
    assert held.read() == "old"
    held.close()
    assert json.loads(target.read_text()) == {"x": 1}
    assert target.stat().st_ino != old_inode
    assert _listing(tmp_path) == ["out.json"]


def test_write_json_converts_numpy_paths_and_non_finite(tmp_path):
    obj = {"a": np.arange(3), "b": np.float32(0.5), "c": (1, 2), "d": Path("x/y"), "e": float("nan"),
           "f": np.int64(7), 3: [float("inf")]}
    nio.write_json(tmp_path / "o.json", obj)
    assert json.loads((tmp_path / "o.json").read_text()) == {
        "a": [0, 1, 2], "b": 0.5, "c": [1, 2], "d": "x/y", "e": None, "f": 7, "3": [None]}
    nio.write_json(tmp_path / "c.json", {"k": [1, 2]}, indent=None)
    assert (tmp_path / "c.json").read_text() == '{"k":[1,2]}\n'


@pytest.mark.parametrize("write", [lambda p: nio.write_text(p, "new"), lambda p: nio.save_npz(p, a=np.arange(3)),
                                   lambda p: nio.atomic_path(p).__enter__(), lambda p: nio.open_log(p)])
def test_symlink_at_the_name_is_refused_and_nothing_changes(tmp_path, write):
    real = tmp_path / "real.txt"
    real.write_text("old")
    link = tmp_path / "link.txt"
    link.symlink_to(real)
    with pytest.raises(OutputError, match="symbolic link"):
        write(link)
    dangling = tmp_path / "dangling.txt"
    dangling.symlink_to(tmp_path / "made.txt")
    with pytest.raises(OutputError, match="symbolic link"):
        write(dangling)
    assert real.read_text() == "old" and link.is_symlink() and dangling.is_symlink()
    assert _listing(tmp_path) == ["dangling.txt", "link.txt", "real.txt"]


def test_symlink_planted_during_the_write_is_refused_not_followed(tmp_path):
    victim = tmp_path / "victim.png"
    victim.write_bytes(b"precious")
    out = tmp_path / "out.png"

    def plant(fh):  # the output name becomes a link while the contents are written
        fh.write(b"figure")
        out.symlink_to(victim)

    with pytest.raises(OutputError, match="became a symbolic link"):
        nio.atomic_write(out, plant)
    assert victim.read_bytes() == b"precious" and out.is_symlink() and _listing(tmp_path) == ["out.png", "victim.png"]


def test_the_runs_inputs_and_the_package_are_never_written(tmp_path):
    from ndrql.io import readset

    src = tmp_path / "map.png"
    nio.write_text(src, "outside a run: a plain file")  # the API outside a CLI run records nothing
    src.write_bytes(b"map")
    twin = tmp_path / "twin.png"
    os.link(src, twin)
    with nio.run_inputs():
        nio.note_input(src, "the map")
        for target in (src, twin):
            with pytest.raises(OutputError, match="this run reads"):
                nio.write_bytes(target, b"x")
        nio.write_bytes(tmp_path / "other.png", b"ok")
    assert src.read_bytes() == b"map" and twin.read_bytes() == b"map"
    shipped = readset.PACKAGE_ROOT / "data" / "sample_map.png"
    before = shipped.read_bytes()
    for target in (shipped, readset.PACKAGE_ROOT / "data" / "new.json"):
        with pytest.raises(OutputError, match="installed ndrql package"):
            nio.write_json(target, {})
    assert shipped.read_bytes() == before and not (readset.PACKAGE_ROOT / "data" / "new.json").exists()


def test_fifo_is_written_directly_not_replaced(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    nio.write_json(fifo, {"through": "the pipe"})
    reader.join(timeout=30)
    assert not reader.is_alive()
    assert json.loads(got[0]) == {"through": "the pipe"}
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert _listing(tmp_path) == ["pipe"]


def test_symlink_to_a_fifo_writes_the_fifo(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    link = tmp_path / "out.npz"
    link.symlink_to(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    nio.save_npz(link, a=np.arange(4))
    reader.join(timeout=30)
    assert not reader.is_alive()
    assert got[0][:2] == b"PK"  # a zip archive came through the pipe
    assert link.is_symlink() and stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_character_device_is_not_replaced(tmp_path):
    """A /dev/null-like node made in tmp_path (needs root); the system's /dev/null is never touched."""
    node = tmp_path / "null"
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except (PermissionError, OSError):
        pytest.skip("cannot create a character device here (needs root)")
    before = os.lstat(node)
    nio.write_text(node, "discarded\n")
    link = tmp_path / "out.json"
    link.symlink_to(node)
    nio.write_json(link, {"also": "discarded"})
    after = os.lstat(node)
    assert stat.S_ISCHR(after.st_mode) and after.st_ino == before.st_ino and after.st_rdev == before.st_rdev
    assert link.is_symlink() and _listing(tmp_path) == ["null", "out.json"]


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_new_file_honours_the_umask(tmp_path, umask):
    old = os.umask(umask)
    try:
        nio.write_bytes(tmp_path / "f", b"x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "f").stat().st_mode) == 0o666 & ~umask


def test_replaced_file_keeps_its_mode(tmp_path):
    target = tmp_path / "f"
    target.write_bytes(b"old")
    target.chmod(0o640)
    nio.write_bytes(target, b"new")
    assert stat.S_IMODE(target.stat().st_mode) == 0o640 and target.read_bytes() == b"new"


def test_failing_write_leaves_old_contents_and_no_debris(tmp_path):
    target = tmp_path / "keep.txt"
    target.write_text("old")

    def boom(fh):
        fh.write(b"partial")
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        nio.atomic_write(target, boom)
    assert target.read_text() == "old"
    with pytest.raises(RuntimeError):
        nio.atomic_write(tmp_path / "new.txt", boom)
    assert _listing(tmp_path) == ["keep.txt"]


def test_os_error_inside_the_write_is_one_output_error(tmp_path):
    def enospc(fh):
        raise OSError(28, "No space left on device")

    with pytest.raises(OutputError, match=r"^cannot write .*new\.bin: No space left on device$"):
        nio.atomic_write(tmp_path / "new.bin", enospc)
    assert _listing(tmp_path) == []


def test_named_temporary_fallback_leaves_no_debris_and_sweeps_stale(tmp_path, monkeypatch):
    monkeypatch.setattr(nio_atomic, "_anonymous_supported", lambda: False)
    # debris of a killed writer (a pid that cannot be running) and of a live one (ours: kept)
    stale = tmp_path / f".out.bin.{2**22 + 12345}.deadbeef{nio_atomic._TMP_SUFFIX}"
    stale.write_bytes(b"junk")
    nio.write_bytes(tmp_path / "out.bin", b"data")
    assert _listing(tmp_path) == ["out.bin"]

    def boom(fh):
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError):
        nio.atomic_write(tmp_path / "out.bin", boom)
    assert _listing(tmp_path) == ["out.bin"] and (tmp_path / "out.bin").read_bytes() == b"data"


def test_parent_folders_are_created(tmp_path):
    nio.write_text(tmp_path / "a" / "b" / "c.txt", "x")
    assert (tmp_path / "a" / "b" / "c.txt").read_text() == "x"


@contextmanager
def _unprivileged():
    """Permission checks as an ordinary user: root drops its effective uid to nobody for the block."""
    if os.geteuid() != 0:
        yield
        return
    os.seteuid(65534)
    try:
        yield
    finally:
        os.seteuid(0)


def test_read_only_folder_is_one_line():
    base = Path(tempfile.mkdtemp(prefix="ndrql-ro-"))
    try:
        base.chmod(0o755)
        folder = base / "ro"
        folder.mkdir()
        folder.chmod(0o555)
        with _unprivileged():
            with pytest.raises(OutputError) as err:
                nio.write_json(folder / "x.json", {})
            with pytest.raises(OutputError, match="cannot create its folder"):
                nio.write_text(folder / "sub" / "x.txt", "x")
            with pytest.raises(OutputError, match="Permission denied"):
                nio.check_writable(folder / "x.json")
        assert str(err.value) == f"cannot write {folder / 'x.json'}: Permission denied"
        assert _listing(folder) == []
    finally:
        shutil.rmtree(base)


def test_folder_in_the_way_and_file_in_the_way(tmp_path):
    (tmp_path / "d").mkdir()
    with pytest.raises(OutputError, match="it is a folder"):
        nio.write_text(tmp_path / "d", "x")
    (tmp_path / "f").write_text("x")
    with pytest.raises(OutputError, match=r"cannot write .*f/x\.txt: a file is in the way \(.*f\)$"):
        nio.write_text(tmp_path / "f" / "x.txt", "x")
    with pytest.raises(OutputError, match="a file is in the way"):
        nio.check_writable(tmp_path / "f" / "sub" / "x.txt")
    with pytest.raises(OutputError, match="it is a folder"):
        nio.check_writable(tmp_path / "d")
    assert nio.check_writable(tmp_path / "new" / "x.txt") == tmp_path / "new" / "x.txt"
    with pytest.raises(OutputError, match="a file is in the way"):
        nio.make_folder(tmp_path / "f")
    assert issubclass(OutputError, NdrqlError)
    assert _listing(tmp_path) == ["d", "f"] and _listing(tmp_path / "d") == []


def test_error_message_stays_one_line(tmp_path):
    (tmp_path / "a\nb").mkdir()
    with pytest.raises(OutputError) as err:
        nio.write_text(tmp_path / "a\nb", "x")
    assert "\n" not in str(err.value)


def test_save_npz_and_digest(tmp_path):
    nio.save_npz(tmp_path / "a.npz", {"x": np.arange(5)}, y=np.ones(2, np.float32))
    with np.load(tmp_path / "a.npz") as z:
        assert sorted(z.files) == ["x", "y"] and z["x"].tolist() == [0, 1, 2, 3, 4]
    nio.write_bytes(tmp_path / "abc", b"abc")
    assert nio.file_digest(tmp_path / "abc") == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"


def test_save_figure_by_extension(tmp_path):
    from ndrql.viz.maps import new_figure

    fig = new_figure(figsize=(1, 1), dpi=20)
    nio.save_figure(fig, tmp_path / "f.png")
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(OutputError, match="cannot save a figure as 'nope'"):
        nio.save_figure(fig, tmp_path / "f.nope")
    assert _listing(tmp_path) == ["f.png"]


def test_bad_mode_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="mode"):
        nio.atomic_write(tmp_path / "x", lambda fh: None, mode="a")


def test_kill_9_during_a_write_leaves_no_debris(tmp_path):
    import signal
    import subprocess
    import sys

    target = tmp_path / "last.pt"
    target.write_bytes(b"old")
    code = ("import sys, time\nfrom ndrql import io\n"
            "def slow(fh):\n    fh.write(b'x' * 1000)\n    fh.flush()\n    print('writing', flush=True)\n    time.sleep(60)\n"
            f"io.atomic_write({str(target)!r}, slow)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "writing"
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        proc.kill()
        proc.wait()
        proc.stdout.close()
    assert _listing(tmp_path) == ["last.pt"] and target.read_bytes() == b"old"


def test_atomic_path_for_writers_that_want_a_file_name(tmp_path):
    target = tmp_path / "m.npy"
    target.write_bytes(b"old")
    target.chmod(0o644)
    with nio.atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".npy" and tmp.name.startswith(".m.npy.")
        np.save(tmp, np.arange(3))
    assert np.load(target).tolist() == [0, 1, 2] and stat.S_IMODE(target.stat().st_mode) == 0o644
    with pytest.raises(RuntimeError):
        with nio.atomic_path(target) as tmp:
            tmp.write_bytes(b"partial")
            raise RuntimeError("boom")
    assert np.load(target).tolist() == [0, 1, 2]
    assert _listing(tmp_path) == ["m.npy"]
    # a FIFO target receives the bytes, and stays a FIFO
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    with nio.atomic_path(fifo) as tmp:
        tmp.write_bytes(b"through")
    reader.join(timeout=30)
    assert got == [b"through"] and stat.S_ISFIFO(os.lstat(fifo).st_mode)
    with pytest.raises(OutputError, match="it is a folder"):
        with nio.atomic_path(tmp_path):
            pass


def test_non_strict_json_round_trips_nan(tmp_path):
    nio.write_json(tmp_path / "n.json", {"x": float("nan"), "y": [float("inf"), 1.5]}, indent=None, strict=False)
    back = json.loads((tmp_path / "n.json").read_text())
    assert np.isnan(back["x"]) and back["y"] == [float("inf"), 1.5]


def test_process_substitution_path_is_written_through(tmp_path):
    """``--json >(gzip > x.gz)`` hands over /dev/fd/N: a magic link to a pipe that realpath cannot resolve."""
    r, w = os.pipe()
    try:
        nio.write_json(f"/proc/self/fd/{w}", {"via": "fd"})
        os.close(w)
        w = -1
        with os.fdopen(r, "rb") as fh:
            r = -1
            assert json.loads(fh.read()) == {"via": "fd"}
    finally:
        for fd in (r, w):
            if fd >= 0:
                os.close(fd)
    assert _listing(tmp_path) == []


def test_a_closed_pipe_is_a_broken_pipe_not_an_output_error():
    """``--json /dev/stdout | head``: the CLI stops quietly (141) on BrokenPipeError, so the writer keeps it."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        with pytest.raises(BrokenPipeError):
            nio.write_text(f"/proc/self/fd/{write_end}", "x" * 100_000)
    finally:
        os.close(write_end)
