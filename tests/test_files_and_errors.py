"""Nothing a user saved is lost, and bad input is a clear error before any work starts."""

from __future__ import annotations

import io
import json
import logging
import shutil
import signal
import time

import pytest
from rich.console import Console

from prehension.atomic import check_output_path
from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main
from prehension.errors import PrehensionError, WorldFileError
from prehension.tasks.cuik_import import import_world
from prehension.tasks.cuik_parser import parse_world
from prehension.tasks.yaml_io import dumps_task, loads_task
from conftest import CUIK_DIR, requires_cuik
from tiny_tasks import pincer_task


@pytest.fixture
def task_file(tmp_path):
    path = tmp_path / "t.yaml"
    path.write_text(dumps_task(pincer_task(30.0)))
    return path


def _err(capsys) -> str:
    return capsys.readouterr().err


# -- outputs checked before any work ------------------------------------------------------------
def test_html_onto_the_task_file_is_refused_and_the_task_kept(task_file, tmp_path, capsys):
    before = task_file.read_text()
    assert main(["solve", str(task_file), "--html", str(task_file), "-o", str(tmp_path / "r.json")]) == EXIT_BAD_INPUT
    assert "is an input of this command" in _err(capsys)
    assert task_file.read_text() == before and not (tmp_path / "r.json").exists()


def test_result_onto_the_task_file_is_refused(task_file, capsys):
    before = task_file.read_text()
    assert main(["solve", str(task_file), "-o", str(task_file)]) == EXIT_BAD_INPUT
    assert task_file.read_text() == before


def test_a_folder_as_output_is_refused_and_left_alone(task_file, tmp_path, capsys):
    folder = tmp_path / "keep"
    folder.mkdir()
    (folder / "mine.txt").write_text("precious")
    assert main(["solve", str(task_file), "-o", str(folder)]) == EXIT_BAD_INPUT
    assert "is a folder" in _err(capsys)
    assert (folder / "mine.txt").read_text() == "precious" and not list(tmp_path.glob("keep.~*~"))


@pytest.mark.parametrize("flag", ["-o", "--html", "--checkpoint"])
def test_a_missing_folder_is_refused_before_solving(task_file, tmp_path, capsys, flag):
    started = time.perf_counter()
    argv = ["solve", str(task_file), "-o", str(tmp_path / "r.json"), flag, str(tmp_path / "nope" / "x.json")]
    assert main(argv) == EXIT_BAD_INPUT
    assert "does not exist" in _err(capsys)
    assert not (tmp_path / "r.json").exists() and time.perf_counter() - started < 5


def test_an_unwritable_folder_is_refused_before_solving(task_file, tmp_path, capsys, monkeypatch):
    """(Permissions do not stop root, so the probe of the folder is made to fail as a
    read-only file system would make it.)"""
    import prehension.atomic as atomic

    def read_only(folder):
        raise OSError(30, "Read-only file system")

    monkeypatch.setattr(atomic, "open_atomic_probe", read_only)
    assert main(["solve", str(task_file), "-o", str(tmp_path / "r.json")]) == EXIT_BAD_INPUT
    err = _err(capsys)
    assert "cannot write in folder" in err and "Read-only file system" in err


def test_view_onto_its_own_result_is_refused(task_file, tmp_path, capsys):
    result = tmp_path / "r.json"
    assert main(["solve", str(task_file), "-o", str(result), "--quiet"]) == EXIT_OK
    before = result.read_text()
    assert main(["view", str(result), "-o", str(result)]) == EXIT_BAD_INPUT
    assert result.read_text() == before


def test_view_needs_an_html_name(task_file, tmp_path, capsys):
    assert main(["view", str(task_file), "-o", str(tmp_path / "v.png")]) == EXIT_BAD_INPUT
    assert ".html" in _err(capsys)


def test_render_writes_the_format_its_name_asks_for(task_file, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    jpg, svg = tmp_path / "g.jpg", tmp_path / "g.svg"
    assert main(["render", str(task_file), "-o", str(jpg), "--size", "200x150"]) == EXIT_OK
    assert jpg.read_bytes()[:3] == b"\xff\xd8\xff"  # JPEG, not PNG bytes under a .jpg name
    assert main(["render", str(task_file), "-o", str(svg), "--size", "200x150"]) == EXIT_OK
    assert b"<svg" in svg.read_bytes()[:400]
    assert main(["render", str(task_file), "-o", str(tmp_path / "g.bmp")]) == EXIT_BAD_INPUT
    assert "must end in" in _err(capsys)


def test_check_output_path_in_the_library(tmp_path):
    with pytest.raises(PrehensionError, match="is a folder"):
        check_output_path(tmp_path, "result file")
    inp = tmp_path / "in.yaml"
    inp.write_text("x")
    with pytest.raises(PrehensionError, match="is an input"):
        check_output_path(tmp_path / "." / "in.yaml", "out", inputs=[inp])
    assert check_output_path(tmp_path / "out.json", "out") == tmp_path / "out.json"


def test_batch_output_cannot_be_a_folder(tmp_path, capsys):
    tasks = tmp_path / "tasks.jsonl"
    tasks.write_text(json.dumps({"id": "a", "task": "teapot-lid-lifting"}) + "\n")
    assert main(["batch", str(tasks), "-o", str(tmp_path), "--quiet"]) == EXIT_BAD_INPUT
    assert "is a folder" in _err(capsys)


# -- CuikSuite files ------------------------------------------------------------------------------
@requires_cuik
def test_import_inside_the_world_folder_names_the_task(tmp_path, monkeypatch, capsys):
    src = CUIK_DIR / "teapot" / "2_contacts_index_thumb"
    work = tmp_path / "cuik" / "teapot" / "lid"
    shutil.copytree(src, work)
    shutil.copytree(CUIK_DIR / "bodies", tmp_path / "cuik" / "bodies")
    monkeypatch.chdir(work)
    assert main(["import-cuik", "SAHandplusTeapot.world", "-o", "t.yaml"]) == EXIT_OK
    assert loads_task((work / "t.yaml").read_text(), base_dir=work).name == "lid"
    assert main(["solve", "SAHandplusTeapot.world", "--method", "local", "--quiet"]) == EXIT_OK
    assert (work / "lid.result.json").is_file() and not list(work.glob(".*.json"))
    assert main(["import-cuik", "SAHandplusTeapot.world", "-o", "SAHandplusTeapot.world", "--force"]) == EXIT_BAD_INPUT


@requires_cuik
def test_a_world_naming_a_missing_body_file_is_refused(tmp_path):
    src = CUIK_DIR / "teapot" / "2_contacts_index_thumb" / "SAHandplusTeapot.world"
    world = tmp_path / "a" / "b" / "w.world"
    world.parent.mkdir(parents=True)
    world.write_text(src.read_text())
    with pytest.raises(WorldFileError, match=r"body file 'bodies/.*\.off' not found"):
        import_world(world)


def test_a_dangling_operator_is_blamed_on_its_own_line():
    with pytest.raises(WorldFileError, match=r"line 2: the expression ends with a dangling '\*'"):
        parse_world("[CONSTANTS]\na := 2 *\n\nb := 3\n")


# -- task files -----------------------------------------------------------------------------------
def test_numbers_with_an_exponent_are_numbers_in_task_files():
    text = dumps_task(pincer_task(30.0)).replace("prehension: task/1", "prehension: task/1\nhand_limits_deg: {j1: [0, 9e1]}")
    task = loads_task(text)
    assert task.hand.upper[0] == pytest.approx(1.5707963267948966)


def test_limits_beyond_a_turn_are_reported_in_degrees():
    text = dumps_task(pincer_task(30.0)).replace("prehension: task/1", "prehension: task/1\nhand_limits_deg: {j1: [-720, 720]}")
    with pytest.raises(PrehensionError, match=r"\[-720, 720\] deg"):
        loads_task(text)


# -- arguments ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "argv, message",
    [
        (["solve", "teapot-lid-lifting", "--seed", "-1"], "--seed: must be an integer >= 0"),
        (["solve", "teapot-lid-lifting", "--time-limit", "-5"], "--time-limit: must be a number of seconds >= 0"),
        (["solve", "teapot-lid-lifting", "--time-limit", "nan"], "--time-limit: expected a finite number"),
        (["render", "teapot-lid-lifting", "--elev", "nan"], "--elev: expected a finite number"),
        (["batch", "x.jsonl", "-o", "y.jsonl", "--time-limit", "-1"], "--time-limit: must be a number of seconds"),
    ],
)
def test_bad_arguments_are_refused_by_name(argv, message, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == EXIT_BAD_INPUT
    assert message in _err(capsys)


def test_time_limits_default_to_300_s_and_0_means_none():
    from prehension.cli import build_parser
    from prehension.cli.args import time_limit

    args = build_parser().parse_args(["solve", "teapot-lid-lifting"])
    assert args.time_limit == 300.0 and time_limit(args.time_limit) == 300.0
    assert time_limit(build_parser().parse_args(["solve", "x", "--time-limit", "4e1"]).time_limit) == 40.0
    assert time_limit(0.0) is None


# -- progress reaches logs ------------------------------------------------------------------------
def test_progress_is_plain_lines_and_log_records_when_not_on_a_terminal(caplog):
    from prehension.cli.progress import LiveProgress

    stream = io.StringIO()
    console = Console(file=io.StringIO(), force_terminal=False)
    with caplog.at_level(logging.INFO, logger="prehension"):
        with LiveProgress(console, interval=0.05, time_limit_s=300, stream=stream) as update:
            update({"stage": "complete solver"})
            update({"boxes": 7, "open": 3})
            time.sleep(0.3)
    lines = stream.getvalue().splitlines()
    assert len(lines) >= 2 and all(line.startswith("[") for line in lines)
    assert "complete solver: boxes 7  open 3; stops within" in lines[-1]
    assert any("boxes 7" in r.getMessage() for r in caplog.records)


def test_quiet_progress_is_silent():
    from prehension.cli.progress import LiveProgress

    stream = io.StringIO()
    with LiveProgress(Console(file=io.StringIO()), enabled=False, interval=0.01, stream=stream) as update:
        assert update is None
        time.sleep(0.05)
    assert stream.getvalue() == ""


# -- Ctrl-C ---------------------------------------------------------------------------------------
def test_local_cluster_workers_ignore_ctrl_c(default_signals):
    """A terminal's Ctrl-C reaches every process of the group: the workers ignore it (the
    command stops them), so that no worker prints a traceback."""
    from prehension.parallel import cluster

    with cluster(None, 1) as client:
        handlers = client.run(lambda: signal.getsignal(signal.SIGINT) == signal.SIG_IGN)
    assert list(handlers.values()) == [True]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # this process takes it again


def test_offline_and_export_hand_check_their_outputs_first(tmp_path, capsys):
    assert main(["offline", "sa", "-o", str(tmp_path / "nope" / "s.json"), "--M", "4", "--N", "2", "--imax", "1"]) == EXIT_BAD_INPUT
    assert "does not exist" in _err(capsys)
    assert main(["offline", "sa", "-o", str(tmp_path / "s.txt"), "--M", "4", "--N", "2", "--imax", "1"]) == EXIT_BAD_INPUT
    assert "must end in .json" in _err(capsys)
    assert main(["export-hand", "sa", "-o", str(tmp_path)]) == EXIT_BAD_INPUT
    with pytest.raises(SystemExit):
        main(["offline", "sa", "-o", str(tmp_path / "s.json"), "--seed", "-3"])


def test_a_display_mesh_file_is_read_when_the_task_is(tmp_path, capsys):
    """Any mesh format for display; a file that is not a mesh is refused when the task is
    read (by `show` too), not later when drawing."""
    import trimesh

    good = tmp_path / "cube.stl"
    trimesh.creation.box((10, 10, 10)).export(good)
    bad = tmp_path / "notes.obj"
    bad.write_text("this is not a mesh\n")
    base = dumps_task(pincer_task(30.0))
    for name, mesh in (("good", good), ("bad", bad)):
        text = base.replace("object:\n", f"object:\n  display: {{mesh_file: {mesh.name}}}\n", 1)
        (tmp_path / f"{name}.yaml").write_text(text)
    assert main(["show", str(tmp_path / "good.yaml")]) == EXIT_OK
    assert main(["show", str(tmp_path / "bad.yaml")]) == EXIT_BAD_INPUT
    assert "notes.obj" in _err(capsys)
