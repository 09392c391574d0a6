"""`twincell model`: the check table, the export, and one-line errors with exit status 2."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from scenarios.cli.app import main


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
