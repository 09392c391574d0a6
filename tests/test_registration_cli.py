"""`twincell register`: files in, transform and quality out; bad input as one line, exit 2."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from registration import pose_error
from registration.synthetic import asymmetric_blob, partial_scan
from scenarios.cli.app import main

V, F = asymmetric_blob(size=0.2, subdivisions=4, seed=0)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("register")
    trimesh.Trimesh(V, F).export(d / "model.stl")
    trimesh.Trimesh(V * 50.0, F).export(d / "model_mm.stl")  # a 10 m model: wrong units
    scan = partial_scan(V, F, 600, noise=1e-4, seed=5)
    np.savetxt(d / "scan.xyz", scan.points, header=str(len(scan.points)), comments="")
    np.savetxt(d / "scan.csv", scan.points, delimiter=",", header="x,y,z", comments="")
    np.save(d / "scan.npy", scan.points)
    trimesh.PointCloud(scan.points).export(d / "scan.ply")
    return d, scan


@pytest.mark.parametrize("name", ["scan.xyz", "scan.csv", "scan.npy", "scan.ply"])
def test_register_writes_the_documented_json(files, name: str, capsys) -> None:
    d, scan = files
    out = d / f"{name}.json"
    assert main(["register", str(d / name), str(d / "model.stl"), "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "verdict" in printed and "T_model_data" in printed
    result = json.loads(out.read_text())
    keys = {"T_model_data", "rotation", "translation", "rms", "inlier_fraction", "ambiguity"}
    keys |= {"iterations", "starts", "seconds", "verdict", "symmetries", "seed", "mode"}
    assert keys <= set(result)
    rot, trans = pose_error(np.array(result["T_model_data"]), scan.T_model_data)
    assert np.degrees(rot) < 0.2 and trans < 0.3e-3
    assert result["verdict"] == "accepted"
    np.testing.assert_allclose(
        np.array(result["rotation"]), np.array(result["T_model_data"])[:3, :3]
    )


def _run(args, capsys) -> tuple[int, str]:
    code = main(args)
    return code, capsys.readouterr().err


def _refused_in_one_line(
    args: list[str], message: str, label: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> str:
    """`twincell ARGS --json FILE` exits 2 with one line holding `message` and writes
    nothing; returns the line."""
    out = tmp_path / f"{label}.json"
    code, err = _run([*args, "--json", str(out)], capsys)
    assert code == 2, label
    assert message in err, (label, err)
    assert err.count("\n") == 1 and "Traceback" not in err, label
    assert not out.exists(), label  # nothing written
    return err


def test_bad_inputs_are_one_line_and_exit_2(files, tmp_path, capsys) -> None:
    d, _ = files
    model = str(d / "model.stl")
    (tmp_path / "nan.xyz").write_text("0 0 0\n1 nan 0\n0 1 0\n")
    (tmp_path / "two.xyz").write_text("0 0 0\n1 1 1\n")
    (tmp_path / "line.xyz").write_text("0 0 0\n1 1 1\n2 2 2\n3 3 3\n")
    (tmp_path / "words.xyz").write_text("0 0 0\nhello world again\n")
    (tmp_path / "pts.dat").write_text("0 0 0\n")
    (tmp_path / "empty.stl").write_text("solid empty\nendsolid empty\n")
    cases = {
        "missing": ([str(tmp_path / "nope.xyz"), model], "not found"),
        "unknown format": ([str(tmp_path / "pts.dat"), model], "unknown format '.dat'"),
        "nan": ([str(tmp_path / "nan.xyz"), model], "NaN or inf"),
        "too few": ([str(tmp_path / "two.xyz"), model], "at least 3"),
        "collinear": ([str(tmp_path / "line.xyz"), model], "one line"),
        "not numbers": ([str(tmp_path / "words.xyz"), model], "expected numbers"),
        "empty mesh": ([str(d / "scan.xyz"), str(tmp_path / "empty.stl")], "empty"),
        "bad mode": ([str(d / "scan.xyz"), model, "--mode", "sideways"], "sideways"),
        "count line": ([str(tmp_path / "count.xyz"), model], "says 100 points, but it holds 4"),
        "mm scan, m model": ([str(tmp_path / "mm.xyz"), model], "with --units mm it would be"),
        "mm model, m scan": ([str(d / "scan.xyz"), str(d / "model_mm.stl")], "same units"),
        "bad units": ([str(d / "scan.xyz"), model, "--units", "inch"], "valid: m, mm"),
        "truncated": ([str(tmp_path / "cut.ply"), model], "cut.ply"),
        "bad targets": ([str(d / "scan.xyz"), model, "--targets", str(tmp_path / "t.json")],
                        "not valid JSON"),
        "refine, no guess": ([str(d / "scan.xyz"), model, "--mode", "refine"], "--init FILE"),
        "guess not 4 x 4": ([str(d / "scan.xyz"), model, "--init", str(tmp_path / "p.txt")],
                            "4 x 4"),
        "guess no rotation": ([str(d / "scan.xyz"), model, "--init", str(tmp_path / "s.npy")],
                              "not a rigid transform"),
    }  # fmt: skip
    (tmp_path / "p.txt").write_text("1 0 0\n0 1 0\n")
    np.save(tmp_path / "s.npy", np.diag([2.0, 1.0, 1.0, 1.0]))
    (tmp_path / "count.xyz").write_text("100\n0 0 0\n0.1 0 0\n0 0.1 0\n0 0 0.1\n")
    np.savetxt(tmp_path / "mm.xyz", np.loadtxt(d / "scan.xyz", skiprows=1) * 1e3)
    (tmp_path / "t.json").write_text("{not json")
    full = (d / "scan.ply").read_bytes()
    (tmp_path / "cut.ply").write_bytes(full[: len(full) // 2])
    for label, (args, message) in cases.items():
        _refused_in_one_line(["register", *args], message, label, tmp_path, capsys)


def test_targets_and_seed_from_the_command_line(files, tmp_path, capsys) -> None:
    d, _ = files
    out = tmp_path / "r.json"
    args = ["register", str(d / "scan.xyz"), str(d / "model.stl"), "--seed", "5",
            "--targets", str(tmp_path / "plan.json"), "--json", str(out)]  # fmt: skip
    (tmp_path / "plan.json").write_text('{"centre": [0, 0, 0], "tip": [0.09, 0, 0]}')
    assert main(args) == 0
    result = json.loads(out.read_text())
    assert result["seed"] == 5 and result["mode"] == "auto"
    assert [t["name"] for t in result["targets"]] == ["centre", "tip"]
    assert all(t["verdict"] == "accepted" for t in result["targets"])
    assert "targets" in capsys.readouterr().out


def test_a_guess_from_the_command_line_starts_refine(files, tmp_path, capsys) -> None:
    # The result file of one call is the guess of the next (translation in --units): the
    # refinement from it stays on the pose, and a guess in mm reads the same.
    d, scan = files
    first, second = tmp_path / "first.json", tmp_path / "second.json"
    base = ["register", str(d / "scan.xyz"), str(d / "model.stl")]
    assert main([*base, "--json", str(first)]) == 0
    T = np.array(json.loads(first.read_text())["T_model_data"])
    T_mm = T.copy()
    T_mm[:3, 3] *= 1e3
    np.savetxt(tmp_path / "guess_mm.txt", T_mm)
    for guess, units in ((first, []), (tmp_path / "guess_mm.txt", ["--units", "mm"])):
        data = d / "scan.xyz" if not units else tmp_path / "scan_mm.xyz"
        np.savetxt(tmp_path / "scan_mm.xyz", np.loadtxt(d / "scan.xyz", skiprows=1) * 1e3)
        model_units = ["--model-units", "m"] if units else []
        args = ["register", str(data), str(d / "model.stl"), "--mode", "refine",
                "--init", str(guess), *units, *model_units, "--json", str(second)]  # fmt: skip
        assert main(args) == 0
        result = json.loads(second.read_text())
        assert result["mode"] == "refine" and result["starts"] == 1
        rot, trans = pose_error(np.array(result["T_model_data"]), scan.T_model_data)
        assert np.degrees(rot) < 0.2 and trans < 0.3e-3, (guess, rot, trans)
    capsys.readouterr()


def test_collinear_nan_and_folder_inputs_are_named(files, tmp_path, capsys) -> None:
    # Points on a 175 m line are refused as collinear before their size is taken for a units
    # mistake; NaN in a mesh is counted, not measured as a span of nan m; a folder is a folder.
    d, _ = files
    model, scan = str(d / "model.stl"), str(d / "scan.xyz")
    line = np.linspace(0.0, 1.0, 50)[:, None] * np.array([100.0, 120.0, 80.0])
    np.savetxt(tmp_path / "line.xyz", line)
    trimesh.PointCloud(line).export(tmp_path / "line.ply")  # float32: on the line within 1e-7
    nan_vertices = V.copy()
    nan_vertices[3, 1] = nan_vertices[7] = np.nan
    trimesh.Trimesh(nan_vertices, F, process=False).export(tmp_path / "nan_model.ply")
    (tmp_path / "nan_model.obj").write_text(
        "v 0 0 0\nv nan 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 2 3\nf 1 3 4\n"
    )
    for folder in ("scans", "folder.xyz"):
        (tmp_path / folder).mkdir()
    n = len(V)
    cases = {
        "line.xyz": ([str(tmp_path / "line.xyz"), model],
                     "line.xyz: its 50 points are collinear (all on one line); a rigid match "
                     "needs at least 3 points spanning a surface"),
        "line.ply": ([str(tmp_path / "line.ply"), model], "line.ply: its 50 points are collinear"),
        "nan mesh .ply": ([scan, str(tmp_path / "nan_model.ply")],
                          f"nan_model.ply: 4 non-finite coordinate(s) (NaN or inf) in 2 of its "
                          f"{n} vertices (the first in row 3"),
        "nan mesh .obj": ([scan, str(tmp_path / "nan_model.obj")],
                          "nan_model.obj: 1 non-finite coordinate(s) (NaN or inf) in 1 of its 4 "
                          "vertices"),
        "folder as points": ([str(tmp_path / "scans"), model],
                             "scans is a folder, not a points file; valid: .xyz, .txt"),
        "folder with a points suffix": ([str(tmp_path / "folder.xyz"), model],
                                        "folder.xyz is a folder, not a points file; valid:"),
    }  # fmt: skip
    # A folder given as the model is refused by the MODEL argument itself (tests/test_cli.py).
    for label, (args, message) in cases.items():
        err = _refused_in_one_line(["register", *args], message, label, tmp_path, capsys)
        assert "wrong units" not in err and "span nan" not in err and "not found" not in err
