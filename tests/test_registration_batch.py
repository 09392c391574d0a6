"""`twincell register` without its start-up cost: the numpy readers give what the reference
readers give (numpy.loadtxt, trimesh), a prepared model (.twm) gives the model file's pose to
the bit and refuses a wrong or old file, a batch writes one line per scan (a bad scan is a
line with its error), and the register path imports no simulation, job or recording."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from registration import FormatError, load_model, load_points, match
from registration.io.mesh_files import read_mesh
from registration.io.ply import read_ply
from registration.io.stl import read_binary_stl
from registration.io.text import read_csv, read_xyz
from registration.prepared import FORMAT_VERSION, load_prepared
from scenarios.cli.app import main

ROOT = Path(__file__).resolve().parent.parent
STANFORD = ROOT / "tests" / "data" / "stanford"
PLY_FILES = sorted(STANFORD.glob("*/*.ply"))
DRAGON = STANFORD / "dragon"


def _reference_mesh(p: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Vertices and faces (None without faces) as trimesh reads them."""
    loaded = trimesh.load(p, process=False)
    faces = getattr(loaded, "faces", None)
    faces = None if faces is None or len(faces) == 0 else np.asarray(faces)
    return np.asarray(loaded.vertices, dtype=float), faces


@pytest.mark.parametrize("path", PLY_FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_the_ply_reader_reads_the_shipped_scans_and_models_as_trimesh(path: Path) -> None:
    read = read_ply(path)
    assert read is not None, "a shipped file left to trimesh"
    vertices, faces = _reference_mesh(path)
    np.testing.assert_array_equal(read[0], vertices)
    assert (read[1] is None) == (faces is None)
    if faces is not None:
        np.testing.assert_array_equal(read[1], faces)


def test_the_ply_reader_reads_ascii_big_endian_and_extra_properties(tmp_path) -> None:
    mesh = trimesh.creation.icosphere(subdivisions=2)
    mesh.visual.vertex_colors = np.random.default_rng(0).integers(0, 255, (len(mesh.vertices), 4))
    files = []
    for encoding in ("ascii", "binary"):
        mesh.export(tmp_path / f"mesh_{encoding}.ply", encoding=encoding)
        cloud = trimesh.PointCloud(mesh.vertices)
        cloud.export(tmp_path / f"cloud_{encoding}.ply", encoding=encoding)
        files += [tmp_path / f"mesh_{encoding}.ply", tmp_path / f"cloud_{encoding}.ply"]
    # Big-endian doubles and int indices, written by hand (trimesh writes little-endian).
    header = (
        f"ply\nformat binary_big_endian 1.0\nelement vertex {len(mesh.vertices)}\n"
        "property double x\nproperty double y\nproperty double z\nproperty uchar quality\n"
        f"element face {len(mesh.faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    vertex = np.zeros(len(mesh.vertices), [("xyz", ">f8", (3,)), ("q", "u1")])
    vertex["xyz"] = mesh.vertices
    face = np.zeros(len(mesh.faces), [("n", "u1"), ("i", ">i4", (3,))])
    face["n"], face["i"] = 3, mesh.faces
    big = tmp_path / "big_endian.ply"
    big.write_bytes(header.encode() + vertex.tobytes() + face.tobytes())
    files.append(big)
    for path in files:
        read = read_ply(path)
        assert read is not None, path.name
        vertices, faces = _reference_mesh(path)
        np.testing.assert_array_equal(read[0], vertices, err_msg=path.name)
        if faces is not None:
            np.testing.assert_array_equal(read[1], faces, err_msg=path.name)
        # A range scan stored as a mesh: its vertices are the points, its faces not read.
        np.testing.assert_array_equal(read_mesh(path, points_only=True)[0], vertices)
    text = (tmp_path / "mesh_ascii.ply").read_text()
    (tmp_path / "cut_ascii.ply").write_text(text[: text.index("end_header") + 200])
    with pytest.raises(FormatError, match=r"cut_ascii.ply: its header declares \d+ vertices"):
        load_points(tmp_path / "cut_ascii.ply")


def test_polygons_other_than_triangles_are_left_to_trimesh(tmp_path) -> None:
    quad = tmp_path / "quad.ply"
    quad.write_text(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
        "end_header\n0 0 0\n0.01 0 0\n0.01 0.01 0\n0 0.01 0\n4 0 1 2 3\n"
    )
    assert read_ply(quad) is None
    _, faces = read_mesh(quad, points_only=False)
    assert faces is not None and faces.shape == (2, 3)  # trimesh splits the quad


def test_the_stl_reader_reads_binary_stl_as_trimesh_and_leaves_ascii_to_it(tmp_path) -> None:
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    mesh.export(tmp_path / "binary.stl")
    read = read_binary_stl(tmp_path / "binary.stl")
    assert read is not None
    vertices, faces = _reference_mesh(tmp_path / "binary.stl")  # trimesh, unprocessed
    np.testing.assert_array_equal(read[0], vertices)
    np.testing.assert_array_equal(read[1], faces)
    (tmp_path / "ascii.stl").write_text(trimesh.exchange.stl.export_stl_ascii(mesh))
    assert read_binary_stl(tmp_path / "ascii.stl") is None
    np.testing.assert_allclose(read_mesh(tmp_path / "ascii.stl", False)[0], vertices, atol=1e-6)
    data = (tmp_path / "binary.stl").read_bytes()
    (tmp_path / "cut.stl").write_bytes(data[: len(data) - 30])
    assert read_binary_stl(tmp_path / "cut.stl") is None  # trimesh says what is wrong


def test_a_truncated_binary_ply_is_named_with_its_counts(tmp_path) -> None:
    data = (DRAGON / "scan_stand072.ply").read_bytes()
    (tmp_path / "cut.ply").write_bytes(data[: len(data) // 2])
    with pytest.raises(FormatError, match=r"cut.ply: its header declares \d+ vertices but \d+"):
        load_points(tmp_path / "cut.ply")


@pytest.fixture(scope="module")
def scan_texts(tmp_path_factory) -> list[tuple[Path, np.ndarray]]:
    """Every shipped scan as text files of the common kinds, each with the array that
    numpy.loadtxt (the reference) reads from it."""
    d = tmp_path_factory.mktemp("text")
    out = []
    for k, path in enumerate(sorted(STANFORD.glob("*/scan_*.ply"))):
        points, _ = read_mesh(path, points_only=True)
        plain = d / f"{k}_plain.xyz"
        np.savetxt(plain, points, fmt="%.9g")
        counted = d / f"{k}_count.pts"
        np.savetxt(counted, points * 1e3, fmt="%.4f", header=str(len(points)), comments="")
        commented = d / f"{k}_comments.txt"
        np.savetxt(commented, np.c_[points, np.arange(len(points))], header="x y z index")
        table = d / f"{k}_table.csv"
        np.savetxt(table, points, delimiter=",", header="x,y,z", comments="", fmt="%.6e")
        out += [
            (plain, np.loadtxt(plain)),
            (counted, np.loadtxt(counted, skiprows=1)),
            (commented, np.loadtxt(commented)[:, :3]),
            (table, np.loadtxt(table, delimiter=",", skiprows=1)),
        ]
    return out


def test_the_text_readers_read_the_shipped_scans_as_loadtxt(scan_texts) -> None:
    for path, reference in scan_texts:
        read = read_csv(path) if path.suffix == ".csv" else read_xyz(path)
        assert read.shape == reference.shape, path.name
        np.testing.assert_array_equal(read, reference, err_msg=path.name)


IRREGULAR = {
    # file text: what each must give (rows or a part of the error), as the line reader did
    "1 2 3\n4 5 6 7 8\n9 10 11\n": [[1, 2, 3], [4, 5, 6], [9, 10, 11]],  # extra columns
    "# a comment\n\n3\n1 2 3 # a note\n4 5 6\n7\t8 9\n": [[1, 2, 3], [4, 5, 6], [7, 8, 9]],
    "1_0 2 3\n4 5 6\n": [[10, 2, 3], [4, 5, 6]],  # Python's float() reads underscores
    "1 2 3\x0c4 5 6\n": [[1, 2, 3], [4, 5, 6]],  # a form feed breaks the line
    "1 2 3\n4 five 6\n": "2: expected numbers",
    "1 2\n3 4\n": "1: expected x y z, got 2 value(s)",
    "1 2 3\n4\n": "2: expected x y z, got 1 value(s)",
    "2.5\n1 2 3\n": "a count line must be a whole number",
    "5\n1 2 3\n": "its count line says 5 points, but it holds 1 rows",
    "x y z\n": "holds no points",
}


@pytest.mark.parametrize("text", list(IRREGULAR), ids=range(len(IRREGULAR)))
def test_irregular_text_files_read_as_before(tmp_path, text: str) -> None:
    path = tmp_path / "scan.xyz"
    path.write_text(text)
    expected = IRREGULAR[text]
    if isinstance(expected, str):
        with pytest.raises(FormatError, match=re.escape(expected)):
            read_xyz(path)
    else:
        np.testing.assert_array_equal(read_xyz(path), np.array(expected, dtype=float))


@pytest.fixture(scope="module")
def prepared(tmp_path_factory) -> tuple[Path, Path]:
    """The dragon's mesh and its prepared model, written by `twincell prepare`."""
    d = tmp_path_factory.mktemp("prepared")
    twm = d / "dragon.twm"
    assert main(["prepare", str(DRAGON / "model.ply"), "--out", str(twm)]) == 0
    return DRAGON / "model.ply", twm


def _result(args: list[str], out: Path) -> dict:
    assert main(["register", *args, "--json", str(out)]) == 0
    return json.loads(out.read_text())


def test_a_prepared_model_gives_the_model_files_pose_to_the_bit(prepared, tmp_path, capsys):
    model, twm = prepared
    scan = str(DRAGON / "scan_stand216.ply")
    from_file = _result([scan, str(model), "--seed", "7"], tmp_path / "file.json")
    from_twm = _result([scan, str(twm), "--seed", "7"], tmp_path / "twm.json")
    capsys.readouterr()
    assert from_file["T_model_data"] == from_twm["T_model_data"]
    for key in ("rms", "inlier_fraction", "ambiguity", "worst_predicted_tre", "verdict"):
        assert from_file[key] == from_twm[key], key
    assert from_twm["verdict"] == "accepted"
    # In Python: the restored model matches as the model read from its file.
    data = load_points(scan)
    T_file = match(data, load_model(model), seed=2).T_model_data
    T_twm = match(data, load_prepared(twm).shape, seed=2).T_model_data
    np.testing.assert_array_equal(T_file, T_twm)


def test_a_prepared_point_model_in_mm_round_trips(tmp_path, capsys) -> None:
    points, _ = read_mesh(DRAGON / "model.ply", points_only=True)
    model = tmp_path / "model_mm.xyz"
    np.savetxt(model, points * 1e3, fmt="%.6f")
    twm = tmp_path / "points.twm"
    assert main(["prepare", str(model), "--units", "mm", "--out", str(twm)]) == 0
    scan = str(DRAGON / "scan_stand072.ply")
    args = ["--model-units", "mm", "--seed", "1"]
    from_file = _result([scan, str(model), *args], tmp_path / "f.json")
    from_twm = _result([scan, str(twm), "--seed", "1"], tmp_path / "t.json")
    capsys.readouterr()
    assert from_file["T_model_data"] == from_twm["T_model_data"]
    assert load_prepared(twm).source.units == "mm"


def _rewritten(good: Path, path: Path, **changes: object) -> Path:
    """The prepared model `good` with entries changed (None: removed), written to `path`."""
    with np.load(good) as archive:
        entries = {name: archive[name] for name in archive.files}
    for name, value in changes.items():
        if value is None:
            entries.pop(name)
        else:
            entries[name] = np.asarray(value)
    with path.open("wb") as f:
        np.savez(f, **entries)
    return path


def test_a_wrong_or_old_prepared_model_is_refused(prepared, tmp_path, capsys) -> None:
    model, twm = prepared
    (tmp_path / "text.twm").write_text("not an archive\n")
    with (tmp_path / "array.twm").open("wb") as f:
        np.save(f, np.zeros((3, 3)))
    copy = tmp_path / "model.ply"
    copy.write_bytes(model.read_bytes())
    stale = tmp_path / "stale.twm"
    assert main(["prepare", str(copy), "--out", str(stale)]) == 0
    copy.write_bytes(model.read_bytes() + b"\n")  # the model changed after preparing
    with (tmp_path / "pickled.twm").open("wb") as f:
        np.savez(f, format=np.array([{"evil": 1}], dtype=object))
    cases = {
        "text": (tmp_path / "text.twm", "not a numpy archive"),
        "one array": (tmp_path / "array.twm", "a single numpy array, not an archive"),
        "pickle": (tmp_path / "pickled.twm", "an entry cannot be read"),
        "other archive": (_rewritten(twm, tmp_path / "other.twm", format="something else"),
                          "not a prepared model (its format entry is 'something else'"),
        "old layout": (_rewritten(twm, tmp_path / "old.twm", version=FORMAT_VERSION - 1),
                       f"format version {FORMAT_VERSION - 1}; this twincell reads version "
                       f"{FORMAT_VERSION}"),
        "other code": (_rewritten(twm, tmp_path / "code.twm", code="0123456789abcdef"),
                       "prepared by other registration code (code 0123456789abcdef"),
        "stale": (stale, "out of date: its model"),
        "no faces": (_rewritten(twm, tmp_path / "nofaces.twm", faces=None),
                     "a damaged prepared model"),
        "bad faces": (_rewritten(twm, tmp_path / "badfaces.twm", faces=np.full((5, 3), 10**7)),
                      "its faces do not index its"),
    }  # fmt: skip
    # A missing model is refused by the MODEL argument itself (tests/test_cli.py).
    scan = str(DRAGON / "scan_stand072.ply")
    for label, (path, message) in cases.items():
        out = tmp_path / f"{label}.json"
        code = main(["register", scan, str(path), "--json", str(out)])
        err = capsys.readouterr().err
        assert code == 2, (label, err)
        assert message in err, (label, err)
        assert str(path) in err and err.count("\n") == 1, (label, err)
        assert not out.exists(), label
    # Units that disagree with those it was prepared in.
    code = main(["register", scan, str(twm), "--model-units", "mm"])
    err = capsys.readouterr().err
    assert code == 2 and "was prepared from a model in m" in err, err


def test_a_model_that_is_not_a_file_is_named(tmp_path) -> None:
    """The library's refusal of a model or prepared model that is missing or a folder (the
    command's MODEL argument refuses them first: tests/test_cli.py)."""
    for folder in ("scans", "folder.twm"):
        (tmp_path / folder).mkdir()
    cases = {
        "folder as model": (lambda: load_model(tmp_path / "scans", "m"),
                            "scans is a folder, not a model file; valid: .stl, .obj, .ply"),
        "missing model": (lambda: load_model(tmp_path / "nope.stl", "m"),
                          "model file not found"),
        "folder as prepared model": (lambda: load_prepared(tmp_path / "folder.twm"),
                                     "folder.twm is a folder, not a prepared model file (.twm)"),
        "missing prepared model": (lambda: load_prepared(tmp_path / "nope.twm"),
                                   "prepared model file not found"),
    }  # fmt: skip
    for load, message in cases.values():
        with pytest.raises(FormatError, match=re.escape(message)):
            load()


def test_prepare_refuses_what_it_cannot_write(prepared, tmp_path, capsys) -> None:
    model, twm = prepared
    cases = {
        "not .twm": ([str(model), "--out", str(tmp_path / "model.npz")], "must end in .twm"),
        "no folder": ([str(model), "--out", str(tmp_path / "no" / "m.twm")], "does not exist"),
        "a .twm": ([str(twm)], "already a prepared model"),
    }  # a missing model: refused by the MODEL argument itself (tests/test_cli.py)
    for label, (args, message) in cases.items():
        code = main(["prepare", *args])
        err = capsys.readouterr().err
        assert code == 2 and message in err and err.count("\n") == 1, (label, err)
    assert not list(tmp_path.iterdir())


def test_a_batch_writes_one_line_per_scan_and_a_bad_scan_is_a_line(prepared, tmp_path, capsys):
    _, twm = prepared
    good = [str(DRAGON / "scan_stand072.ply"), str(DRAGON / "scan_stand288.ply")]
    (tmp_path / "nan.xyz").write_text("0 0 0\n0.01 nan 0\n0 0.01 0\n")
    scans = [good[0], str(tmp_path / "nan.xyz"), str(tmp_path / "missing.xyz"), good[1]]
    out = tmp_path / "batch.jsonl"
    code = main(["register", *scans, str(twm), "--seed", "3", "--json", str(out)])
    captured = capsys.readouterr()
    assert code == 2
    assert "2 of 4 data files failed" in captured.err
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert [line["data"] for line in lines] == scans
    assert all(line["model"] == str(twm) for line in lines)
    assert "NaN or inf" in lines[1]["error"] and "not found" in lines[2]["error"]
    assert not lines[1]["internal"] and "T_model_data" not in lines[1]
    # The good scans' lines are the one-scan form's results.
    for line, scan in zip((lines[0], lines[3]), good, strict=True):
        one = _result([scan, str(twm), "--seed", "3"], tmp_path / "one.json")
        assert line["T_model_data"] == one["T_model_data"]
        assert line["verdict"] == one["verdict"] == "accepted"
    assert len(captured.out.splitlines()) == 4  # one summary line per scan
    # Without --json the lines go to standard output, and nothing else does.
    capsys.readouterr()
    assert main(["register", good[0], good[1], str(twm), "--seed", "3"]) == 0
    printed = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [p["data"] for p in printed] == good
    assert printed[0]["T_model_data"] == lines[0]["T_model_data"]


def test_the_register_path_imports_no_simulation_job_or_recording(prepared, tmp_path) -> None:
    _, twm = prepared
    code = (
        "import sys\n"
        "from scenarios.cli import main\n"
        f"assert main(['register', {str(DRAGON / 'scan_stand072.ply')!r}, {str(twm)!r}, "
        f"'--json', {str(tmp_path / 'r.json')!r}]) == 0\n"
        "print(' '.join(sorted(sys.modules)))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr
    loaded = set(done.stdout.split())
    # (scenarios.results, the run's value types offered as scenarios.RunResult, needs only
    # numpy: it may load.)
    heavy = ("mujoco", "pinocchio", "rerun", "matplotlib", "dask", "distributed", "trimesh",
             "yaml", "cell", "models.registry", "scenarios.jobs", "scenarios.campaign",
             "scenarios.stages", "scenarios.realcell")  # fmt: skip
    imported = sorted(m for m in loaded if any(m == h or m.startswith(h + ".") for h in heavy))
    assert imported == [], imported


def _range_scan(tmp_path: Path, encoding: str) -> tuple[Path, np.ndarray, np.ndarray | None]:
    """A range scanner's PLY as the Stanford 3D Scanning Repository's Cyberware scans (the
    bunny's bun000.ply) have it: the points, then a `range_grid` element of one list per
    grid cell (empty, or the index of the point seen there); in binary, with the faces
    between neighbouring points after the grid, as other scanners write them."""
    rng = np.random.default_rng(1)
    points = rng.uniform(-0.05, 0.05, (300, 3)).astype(np.float32)
    cells = np.full(40 * 20, -1)
    cells[rng.choice(len(cells), len(points), replace=False)] = np.arange(len(points))
    faces = np.array([[i, i + 1, i + 2] for i in range(0, 297, 3)])
    header = (
        f"ply\nformat {encoding} 1.0\nobj_info num_cols 40\nobj_info num_rows 20\n"
        f"element vertex {len(points)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element range_grid {len(cells)}\nproperty list uchar int vertex_indices\n"
    )
    path = tmp_path / f"range_{encoding}.ply"
    if encoding == "ascii":
        rows = [" ".join(repr(float(v)) for v in p) for p in points]
        rows += ["0" if c < 0 else f"1 {c}" for c in cells]
        path.write_text(header + "end_header\n" + "\n".join(rows) + "\n")
        return path, points.astype(float), None
    header += f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    grid = b"".join(
        np.uint8(0).tobytes() if c < 0 else np.uint8(1).tobytes() + np.int32(c).tobytes()
        for c in cells
    )
    face = np.zeros(len(faces), [("n", "u1"), ("i", "<i4", (3,))])
    face["n"], face["i"] = 3, faces
    path.write_bytes(header.encode() + points.tobytes() + grid + face.tobytes())
    return path, points.astype(float), faces


@pytest.mark.parametrize("encoding", ["ascii", "binary_little_endian"])
def test_the_ply_reader_skips_a_range_grid(tmp_path: Path, encoding: str) -> None:
    """The points and faces the file was written with come back, the grid skipped (trimesh
    reads the ascii file the same, and cannot read the binary one)."""
    path, points, faces = _range_scan(tmp_path, encoding)
    read = read_ply(path)
    assert read is not None, "a range scan left to trimesh's slow parser"
    np.testing.assert_array_equal(read[0], points)
    if faces is None:
        assert read[1] is None
        np.testing.assert_array_equal(_reference_mesh(path)[0], points)
    else:
        np.testing.assert_array_equal(read[1], faces)
    np.testing.assert_array_equal(load_points(path), points)
