"""`twincell register`: files in, transform and quality out; bad input as one line, exit 2."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from registration import pose_error
from registration.synthetic import asymmetric_blob, partial_scan
from scenarios.cli import main

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
    }  # fmt: skip
    (tmp_path / "count.xyz").write_text("100\n0 0 0\n0.1 0 0\n0 0.1 0\n0 0 0.1\n")
    np.savetxt(tmp_path / "mm.xyz", np.loadtxt(d / "scan.xyz", skiprows=1) * 1e3)
    (tmp_path / "t.json").write_text("{not json")
    full = (d / "scan.ply").read_bytes()
    (tmp_path / "cut.ply").write_bytes(full[: len(full) // 2])
    for label, (args, message) in cases.items():
        out = tmp_path / f"{label}.json"
        code, err = _run(["register", *args, "--json", str(out)], capsys)
        assert code == 2, label
        assert message in err, (label, err)
        assert err.count("\n") == 1 and "Traceback" not in err, label
        assert not out.exists(), label  # nothing written


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
