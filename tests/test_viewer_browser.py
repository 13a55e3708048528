"""The viewer page in a real headless Chromium: it runs without errors and draws the scene.

Two independent checks for errors: the page's own error trap (``window.onerror``,
unhandled rejections and ``console.error`` write into ``#viewer-status``, read back from
``--dump-dom``), and Chromium's log (``--enable-logging=stderr``), in which every console
message of the page appears as a ``CONSOLE`` line -- the viewer writes none when all is
well.  A screenshot must show the scene: many pixels unlike the background, many colours.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from prehension.results import write_result
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.solve import solve
from prehension.tasks.library import load_builtin_task
from prehension.viewer import build_scene, load_grasp, write_html
from prehension.viewer.stages import with_stage
from prehension.viewer.model import BACKGROUND

CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser") if shutil.which(n)), None)
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="chromium is not installed (Debian: apt-get install chromium); the browser test needs it"
)
WINDOW = (1000, 720)


def _chromium(page, profile, *args) -> subprocess.CompletedProcess:
    """Run headless Chromium on a local page; its stdout and stderr (the log) as text."""
    command = [
        CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-extensions",
        f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0", "--virtual-time-budget=4000",
        f"--window-size={WINDOW[0]},{WINDOW[1]}", *args, page.resolve().as_uri(),
    ]  # fmt: skip
    return subprocess.run(command, capture_output=True, text=True, timeout=90)


def _status(dom: str) -> dict[str, str]:
    match = re.search(r'<div id="viewer-status"([^>]*)>(.*?)</div>', dom, re.S)
    assert match, "no #viewer-status in the page Chromium rendered"
    attrs = dict(re.findall(r'([\w-]+)="([^"]*)"', match.group(1)))
    attrs["text"] = match.group(2)
    return attrs


def _console_lines(log: str, page) -> list[str]:
    return [line for line in log.splitlines() if "CONSOLE" in line and page.name in line]


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """A solved grasp's page and a task's page."""
    folder = tmp_path_factory.mktemp("browser")
    result = solve(load_builtin_task("teapot-lid-lifting"), "local")
    write_result(result, folder / "lid.json", quality_entries(result), approach_entries_of(result))
    write_html(build_scene(result.task, result.solutions[0]), folder / "grasp.html")
    write_html(build_scene(load_builtin_task("scalpel-handling")), folder / "task.html")
    loaded = load_grasp(folder / "lid.json")  # the stored pre-grasp and squeeze: a stage selector
    scene = build_scene(loaded.task, loaded.pose, status=loaded.status)
    for stage in ("pregrasp", "grasp", "squeeze"):
        write_html(with_stage(scene, stage), folder / f"{stage}.html")
    return folder


@pytest.mark.parametrize("name", ["grasp.html", "task.html"])
def test_the_page_runs_without_errors(pages, name, tmp_path):
    page = pages / name
    run = _chromium(page, tmp_path / "profile", "--dump-dom")
    status = _status(run.stdout)
    assert status.get("data-status") == "ok", status["text"]
    assert int(status["data-triangles"]) > 1000
    assert _console_lines(run.stderr, page) == []
    assert 'type="checkbox"' in run.stdout and 'data-layer="contacts"' in run.stdout  # the panel was built


def test_the_screenshot_shows_the_scene(pages, tmp_path):
    image = pytest.importorskip("matplotlib.image")
    shot = tmp_path / "shot.png"
    run = _chromium(pages / "grasp.html", tmp_path / "profile", f"--screenshot={shot}")
    assert shot.is_file(), run.stderr[-2000:]
    assert _console_lines(run.stderr, pages / "grasp.html") == []
    pixels = image.imread(shot)[..., :3]
    assert pixels.shape[:2] == (WINDOW[1], WINDOW[0])
    background = np.array([int(BACKGROUND[i : i + 2], 16) for i in (1, 3, 5)]) / 255
    differs = np.abs(pixels - background).max(axis=2) > 10 / 255
    scene_part = differs[:, WINDOW[0] // 2 :]  # right of the panel: the drawing only
    assert scene_part.mean() > 0.06
    colours = np.unique(np.round(pixels[:, WINDOW[0] // 2 :][scene_part] * 31), axis=0)
    assert len(colours) > 60  # shaded hand, translucent object, coloured regions and arrows


def test_the_error_trap_reports_a_broken_page(pages, tmp_path):
    """The checks above mean something: a page whose script fails is reported as failed."""
    page = tmp_path / "broken.html"
    html = (pages / "grasp.html").read_text()
    page.write_text(html.replace('"layers":[', '"layers":[{"key":"bad"},', 1))  # a layer without meshes
    run = _chromium(page, tmp_path / "profile", "--dump-dom")
    status = _status(run.stdout)
    assert status.get("data-status") == "error" and "error:" in status["text"]
    assert _console_lines(run.stderr, page)  # Chromium logged the uncaught error too


def test_the_stage_selector_is_built_and_each_stage_draws_its_hand(pages, tmp_path):
    image = pytest.importorskip("matplotlib.image")
    run = _chromium(pages / "squeeze.html", tmp_path / "profile", "--dump-dom")
    assert _status(run.stdout).get("data-status") == "ok" and _console_lines(run.stderr, pages / "squeeze.html") == []
    assert re.search(r'<fieldset id="stages" data-stage="squeeze"', run.stdout)
    radios = re.findall(r'<input type="radio" name="stage" data-stage="(\w+)"', run.stdout)
    assert radios == ["pregrasp", "grasp", "squeeze"]
    assert 'data-layer="hand"' not in run.stdout  # the hands are chosen by stage, not by a checkbox
    shots = {}
    for stage in ("pregrasp", "grasp"):
        shot = tmp_path / f"{stage}.png"
        _chromium(pages / f"{stage}.html", tmp_path / f"profile-{stage}", f"--screenshot={shot}")
        shots[stage] = image.imread(shot)[..., :3][:, WINDOW[0] // 2 :]
    assert (np.abs(shots["pregrasp"] - shots["grasp"]).max(axis=2) > 0.1).mean() > 0.005  # the fingers stand elsewhere
