"""`twincell model`: the check table, the export, and one-line errors with exit status 2."""

from __future__ import annotations

import re

import matplotlib.image
import numpy as np
import pytest
import trimesh

from scenarios.cli.app import main

#: The extents' printed rounding [mm].
PRINTED_MM = 0.05


def test_model_prints_the_check_of_a_builtin_part(capsys) -> None:
    assert main(["model", "bracket"]) == 0
    out = capsys.readouterr().out
    assert "watertight" in out and "yes" in out
    assert "80.00 x 50.00 x 56.00" in out  # extents [mm]
    assert "extents [mm]" in out
    assert "convex pieces" in out and "screw_base_left" in out


def test_model_real_differs_from_the_virtual(capsys) -> None:
    assert main(["model", "lid", "--real", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "model error (0.30 mm RMS, seed 3)" in out
    assert "100.00 x 70.00 x 14.00" not in out  # the real lid is not the drawing


@pytest.mark.parametrize(("units", "length"), [("mm", 100.0), ("m", 0.1)])
def test_model_out_writes_the_mesh_in_the_units(tmp_path, capsys, units, length) -> None:
    out_file = tmp_path / "lid.stl"
    assert main(["model", "lid", "--units", units, "--out", str(out_file)]) == 0
    assert "wrote" in capsys.readouterr().out
    written = trimesh.load(out_file, force="mesh")
    assert written.is_watertight
    assert written.extents.max() == pytest.approx(length, rel=1e-6)
    # and it reads back as a model file with the same figures
    assert main(["model", str(out_file), "--units", units]) == 0
    assert "100.00 x 70.00 x 14.00" in capsys.readouterr().out


def test_model_of_a_user_file_warns_about_open_meshes(tmp_path, capsys) -> None:
    box = trimesh.creation.box(extents=(50.0, 40.0, 30.0))
    trimesh.Trimesh(box.vertices, np.asarray(box.faces)[1:]).export(tmp_path / "open.ply")
    assert main(["model", str(tmp_path / "open.ply")]) == 0
    captured = capsys.readouterr()
    assert "NO" in captured.out  # watertight: NO
    assert "not watertight" in captured.err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["model", "gearbox"], "unknown model 'gearbox'; built-in models are"),
        (["model", "{tmp}/absent.stl"], "no such file"),
        (["model", "{tmp}/empty.obj"], "the file is empty"),
        (["model", "{tmp}/corrupt.ply"], "cannot be read as PLY"),
        (["model", "{tmp}/notes.txt"], "not a mesh file"),
        (["model", "{tmp}/nan.obj"], "NaN"),
        (["model", "bracket", "--units", "furlong"], "units must be one of"),
        (["model", "bracket", "--out", "{tmp}/no/such/dir.stl"], "does not exist"),
        (["model", "bracket", "--out", "{tmp}/bracket.step"], "cannot write suffix"),
        (
            ["model", "bracket", "--up-axis", "y"],
            "--up-axis: the model's axis that points up, away from the table, is one of "
            "+x, -x, +y, -y, +z, -z (got 'y')",
        ),
        (["model", "bracket", "--roll", "200"], "--roll: Input should be less than or equal"),
        (["model", "bracket", "--picture", "{tmp}/no/such/dir.png"], "does not exist"),
        (["model", "bracket", "--picture", "{tmp}/bracket.jpg"], "a .png file"),
    ],
)
def test_bad_input_is_one_line_and_exit_status_2(tmp_path, capsys, args, message) -> None:
    (tmp_path / "empty.obj").write_bytes(b"")
    (tmp_path / "corrupt.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement")
    (tmp_path / "notes.txt").write_text("not a mesh")
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in args]
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("twincell: error: ") and message in lines[0]
    leftovers = {p.name for p in tmp_path.iterdir()}
    assert leftovers == {"empty.obj", "corrupt.ply", "notes.txt", "nan.obj"}  # nothing written


def _table_extents(out: str) -> dict[str, tuple[float, float, float]]:
    """The extents table's rows: table axis -> (from, to, size) [mm]."""
    rows = re.findall(r"^\W*([xyz])\W+(-?\d+\.\d) \.\. (-?\d+\.\d)\W+(\d+\.\d)\W*$", out, re.M)
    return {axis: (float(lo), float(hi), float(size)) for axis, lo, hi, size in rows}


def test_model_shows_how_a_y_up_part_lies_on_the_table(tmp_path, capsys) -> None:
    # A rod 200 mm long along the mesh's y, 40 mm across (a y-up mesh), in mm.
    rod = trimesh.creation.cylinder(radius=20.0, height=200.0, sections=64)
    rod.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    rod.export(tmp_path / "rod.stl")
    picture = tmp_path / "rod.png"
    argv = ["model", str(tmp_path / "rod.stl"), "--up-axis", "+y", "--yaw", "30"]
    assert main([*argv, "--picture", str(picture)]) == 0
    out = capsys.readouterr().out
    lo, hi, size = _table_extents(out)["z"]
    # Standing: its 200 mm vertical, its lowest point a job's lift (4 mm) above the top.
    assert (lo, hi, size) == pytest.approx((4.0, 204.0, 200.0), abs=PRINTED_MM)
    assert _table_extents(out)["x"][2] <= 40.0 + PRINTED_MM
    assert "up +y, roll 0, pitch 0, yaw 30 deg" in out
    image = matplotlib.image.imread(picture)
    assert image.shape[1] > image.shape[0] > 300 and float(np.std(image[..., :3])) > 0.05
    # As modelled (up +z) it lies on its side, 40 mm high; with --out the picture is beside it.
    assert main(["model", str(tmp_path / "rod.stl"), "--out", str(tmp_path / "out.ply")]) == 0
    assert _table_extents(capsys.readouterr().out)["z"] == pytest.approx(
        (4.0, 44.0, 40.0), abs=PRINTED_MM
    )
    assert (tmp_path / "out_on_table.png").is_file()
