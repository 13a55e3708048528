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


@pytest.mark.parametrize("radius", ["100", "1e6"])
def test_a_radius_too_large_for_one_patch_gets_the_radius_that_fits(ball, radius, capsys):
    """Issue 28 item 9: a 1e6 mm radius was told to "pick a larger radius"; now the advice is a
    radius under the distance where the surface turns away from the point's normal."""
    code = main(["region", str(ball), "--at=30,0,0", "--radius", radius, "--units", "mm"])
    out = capsys.readouterr()
    text = " ".join((out.out + out.err).split())
    assert code in (EXIT_OK, EXIT_BAD_INPUT) and "larger radius" not in text
    if code == EXIT_OK:
        assert "which one patch cannot follow: pick a --radius under that" in text and "surface_tolerance_mm" not in text
        fits = float(text.split("point's normal ")[1].split(" mm away")[0])
    else:
        assert "too large for one patch here" in text and "pick a radius under that" in text
        fits = float(text.split("point's normal ")[1].split(" mm away")[0])
    assert 20 < fits < 45  # 84 degrees around a 30 mm ball
    assert main(["region", str(ball), "--at=30,0,0", "--radius", f"{0.9 * fits:g}", "--units", "mm"]) == EXIT_OK


def test_a_point_off_the_surface_gets_the_nearest_surface_point_and_the_bounding_box(ball, capsys):
    """Issue 28 item 9: no help to find a surface point."""
    assert main(["region", str(ball), "--at=0,0,50", "--radius", "2", "--units", "mm"]) == EXIT_BAD_INPUT
    err = " ".join(capsys.readouterr().err.split())
    assert "is 20 mm from the object's outer surface" in err
    near = [float(x) for x in err.split("nearest outer surface point is [")[1].split("]")[0].split(",")]
    assert near[2] == pytest.approx(30, abs=0.5) and abs(near[0]) < 1 and abs(near[1]) < 1
    assert "[-30, 30] x [-30, 30] x [-30, 30] mm" in err
    assert main(["region", str(ball), f"--at={near[0]},{near[1]},{near[2]}", "--radius", "2", "--units", "mm"]) == EXIT_OK


@pytest.mark.parametrize("at", ["1e308,0,0", "nan,0,0", "0,inf,0"])
def test_an_at_beyond_any_mesh_is_refused_before_numpy_overflows(ball, at, capsys):
    """The sweep: --at 1e308,0,0 printed numpy's overflow warning and 'inf mm from the surface'."""
    assert main(["region", str(ball), f"--at={at}", "--radius", "3", "--units", "mm"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "--at takes three numbers" in err and "Warning" not in err
