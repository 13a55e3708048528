"""``prehension region`` arguments (issue 28, item 9): a negative ``--at`` is a point, a
radius must be > 0."""

from __future__ import annotations

import pytest

from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main
from prehension.cli.args import join_negative_values


@pytest.fixture
def ball(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    path = tmp_path / "ball.stl"
    trimesh.creation.icosphere(subdivisions=3, radius=30.0).export(path)
    return path


def test_negative_coordinates_after_at_are_a_point(ball, capsys):
    assert main(["region", str(ball), "--at", "-30,0,0", "--point", "--units", "mm"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "surface point (-30" in out or "surface point (-29" in out


@pytest.mark.parametrize("radius", ["0", "-2", "nan"])
def test_a_radius_must_be_positive(ball, radius, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["region", str(ball), "--at=30,0,0", "--radius", radius, "--units", "mm"])
    assert exit_.value.code == EXIT_BAD_INPUT and "--radius" in capsys.readouterr().err


def test_only_number_lists_are_joined():
    assert join_negative_values(["region", "m.stl", "--at", "-30,0,1e-3"]) == ["region", "m.stl", "--at=-30,0,1e-3"]
    assert join_negative_values(["--at", "--point"]) == ["--at", "--point"]
    assert join_negative_values(["--name", "-30,0,0"]) == ["--name", "-30,0,0"]
