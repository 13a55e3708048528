"""An output that exists and is not a regular file is refused, by name, and left as it was.

Issue 28, item 1: ``-o`` naming a named pipe or a device node replaced it with a regular
file.  Every kind of special file is tried on every command that writes a file, and on the
library's one atomic writer (:func:`prehension.atomic.open_atomic`).
"""

from __future__ import annotations

import os
import socket
import stat
import tempfile
from pathlib import Path

import pytest

from prehension.atomic import check_output_path, special_file_kind, write_text_atomic
from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main
from prehension.errors import PrehensionError
from prehension.tasks.yaml_io import dumps_task
from tiny_tasks import pincer_task


def _fifo(path: Path) -> None:
    os.mkfifo(path)


def _socket(path: Path) -> socket.socket:
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.bind(str(path))
    return sock


def _char_device(path: Path) -> None:
    """A character device with /dev/null's numbers (needs the right to mknod; else skip)."""
    try:
        os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except PermissionError:
        pytest.skip("mknod of a character device is not permitted here")


def _link_to_dev_null(path: Path) -> None:
    os.symlink("/dev/null", path)


def _folder(path: Path) -> None:
    path.mkdir()
    (path / "mine.txt").write_text("precious")


def _dangling_link(path: Path) -> None:
    os.symlink(path.parent / "nowhere" / "x.json", path)


KINDS = {
    "fifo": (_fifo, "named pipe"), "socket": (_socket, "socket"), "char-device": (_char_device, "character device"),
    "link-to-dev-null": (_link_to_dev_null, "symbolic link to a character device"), "folder": (_folder, "folder"),
    "dangling-link": (_dangling_link, "symbolic link to nothing"),
}  # fmt: skip


@pytest.fixture
def short_dir():
    """A folder with a short path (a UNIX socket's path must stay under ~100 bytes)."""
    with tempfile.TemporaryDirectory(prefix="ph-") as name:
        yield Path(name)


@pytest.fixture(params=sorted(KINDS))
def special(request, short_dir):
    """(path, words of the message, kind name): a special file that must survive the test."""
    make, words = KINDS[request.param]

    def made(name: str) -> Path:
        path = short_dir / name
        keep = make(path)
        request.addfinalizer(lambda: keep.close() if keep is not None else None)
        return path

    return made, words, request.param


def _fingerprint(path: Path):
    st = os.lstat(path)
    return stat.S_IFMT(st.st_mode), st.st_ino, (os.readlink(path) if stat.S_ISLNK(st.st_mode) else None)


def _task_file(folder: Path) -> Path:
    path = folder / "t.yaml"
    path.write_text(dumps_task(pincer_task(30.0)))
    return path


def _result_file(folder: Path) -> Path:
    path = folder / "r.json"
    assert main(["solve", str(_task_file(folder)), "-o", str(path), "--method", "local", "--quiet"]) == EXIT_OK
    return path


# every command that writes a file, with the output's name in its suffix (a check of the
# suffix never hides the check of the kind)
COMMANDS = {
    "solve -o": lambda d, out: ["solve", str(_task_file(d)), "-o", str(out), "--quiet"],
    "solve --html": lambda d, out: ["solve", str(_task_file(d)), "-o", str(d / "r.json"), "--html", str(out), "--quiet"],
    "solve --checkpoint": lambda d, out: ["solve", str(_task_file(d)), "-o", str(d / "r.json"), "--checkpoint", str(out),
                                          "--quiet"],
    "view": lambda d, out: ["view", str(_task_file(d)), "-o", str(out)],
    "render": lambda d, out: ["render", str(_task_file(d)), "-o", str(out), "--size", "100x100"],
    "export-hand": lambda d, out: ["export-hand", "sa", "-o", str(out), "--force"],
    "offline": lambda d, out: ["offline", "sa", "-o", str(out), "--M", "2", "--N", "2", "--imax", "1", "--force"],
    "batch": lambda d, out: ["batch", str(_task_file(d)), "-o", str(out), "--quiet"],
    "simulate": lambda d, out: ["simulate", str(_result_file(d)), "-o", str(out)],
}  # fmt: skip
SUFFIX = {"view": ".html", "solve --html": ".html", "render": ".png", "export-hand": ".urdf", "batch": ".jsonl"}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_command_refuses_a_special_output_and_leaves_it(special, command, short_dir, capsys):
    if command == "render":
        pytest.importorskip("matplotlib")
    if command == "simulate":
        pytest.importorskip("mujoco")
    made, words, _ = special
    out = made("out" + SUFFIX.get(command, ".json"))
    before = _fingerprint(out)
    assert main(COMMANDS[command](short_dir, out)) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert words in err and out.name in err
    assert _fingerprint(out) == before
    assert not [p for p in short_dir.iterdir() if p.name.startswith(".")]  # no temporary file left


def test_the_atomic_writer_refuses_a_special_file_too(special):
    made, words, _ = special
    out = made("direct.json")
    before = _fingerprint(out)
    with pytest.raises(PrehensionError, match=words):
        write_text_atomic(out, "{}")
    assert _fingerprint(out) == before
    with pytest.raises(PrehensionError, match=words):
        check_output_path(out, "result file")


def test_regular_files_and_links_to_them_are_outputs(tmp_path):
    target = tmp_path / "data" / "kept.json"
    target.parent.mkdir()
    target.write_text("old")
    link = tmp_path / "link.json"
    os.symlink(target, link)
    assert special_file_kind(target) is None and special_file_kind(link) is None
    assert special_file_kind(tmp_path / "absent.json") is None
    assert check_output_path(link, "result file") == link
    write_text_atomic(link, "new")  # written through: the link stays, its target is replaced
    assert link.is_symlink() and target.read_text() == "new"
    assert sorted(p.name for p in target.parent.iterdir()) == ["kept.json"]


def test_solve_onto_a_link_keeps_the_old_result(tmp_path):
    """``solve`` moves an existing result aside as ``NAME.~1~``: a link is moved, so the file
    it points to is kept as it was and the backup still leads to it."""
    target = tmp_path / "kept.json"
    target.write_text("my old result")
    link = tmp_path / "r.json"
    os.symlink(target, link)
    assert main(["solve", str(_task_file(tmp_path)), "-o", str(link), "--method", "local", "--quiet"]) == EXIT_OK
    backup = tmp_path / "r.json.~1~"
    assert target.read_text() == "my old result" and backup.is_symlink() and backup.resolve() == target
    assert link.is_file() and '"status": "solved"' in link.read_text()
