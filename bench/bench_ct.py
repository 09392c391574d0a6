"""A CT volume of 512 x 512 x 300 voxels to a decimated, checked bone mesh: time and memory.

    python bench/bench_ct.py [--out /tmp/twincell_bench_ct] [--short]

The volume is the skull phantom CT-scanned in simulation on a 512 x 512 x 300 grid
(0.41 x 0.33 x 0.68 mm voxels, blur 0.7 mm, noise 20 HU), saved once. Then, each in a fresh
process (its peak memory is its own): ours (`models.ct.bone_model`: threshold, largest
component, cavities closed, marching cubes, Taubin, decimation to 100,000 faces, the check)
and the peer, scikit-image's marching cubes alone on the raw threshold (no component, no
cavities, no smoothing, no decimation, no check): the floor of any marching-cubes mesher.
Goal: under 10 s and 4 GB on 2 cores.

--short: the same on a 128 x 128 x 75 grid (voxels four times as large; a few seconds), the
goal not judged.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

FULL = (512, 512, 300)
SHORT = (128, 128, 75)


def _make(path: Path, shape: tuple[int, int, int]) -> None:
    from models.ct import CTSettings, ct_scan
    from models.registry import builtin_model

    skull = builtin_model("skull")
    extent = np.ptp(np.asarray(skull.mesh.vertices), axis=0) * 1e3 + 10.0
    voxel = tuple(float(v) for v in extent / (np.array(shape) - 1))
    volume = ct_scan(skull.mesh, CTSettings(voxel_mm=voxel, margin_mm=5.0),
                     np.random.default_rng(0))  # fmt: skip
    np.savez(path, data=volume.data, affine=volume.affine_lps)


def _run(path: Path, which: str) -> dict[str, float]:
    from models.ct import bone_model
    from models.ct.volume import Volume

    saved = np.load(path)
    volume = Volume(saved["data"], saved["affine"], "CT", "LPS", str(path))
    t0 = time.perf_counter()
    if which == "ours":
        bone = bone_model(volume, iso_hu=300.0)
        faces, watertight = bone.check.faces, bone.check.watertight
    else:
        from skimage.measure import marching_cubes

        _v, f, _n, _ = marching_cubes(volume.data, level=300.0)
        faces, watertight = len(f), False
    seconds = time.perf_counter() - t0
    peak_gb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    return {"seconds": seconds, "peak_gb": peak_gb, "faces": faces, "watertight": watertight,
            "voxels": int(volume.data.size)}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="/tmp/twincell_bench_ct")
    parser.add_argument("--short", action="store_true", help="a 128 x 128 x 75 volume")
    parser.add_argument("--run", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    out = Path(args.out)
    shape = SHORT if args.short else FULL
    size = " x ".join(str(n) for n in shape)
    path = out / f"volume-{size.replace(' ', '')}.npz"
    if args.run:
        print(json.dumps(_run(path, args.run)))
        return
    out.mkdir(parents=True, exist_ok=True)
    if not path.is_file():
        _make(path, shape)
    rows = {}
    for which in ("ours", "peer"):
        command = [sys.executable, __file__, "--out", str(out), "--run", which]
        done = subprocess.run(
            command + (["--short"] if args.short else []),
            capture_output=True, text=True, check=True,
        )  # fmt: skip
        rows[which] = json.loads(done.stdout.strip().splitlines()[-1])
    print(f"volume: {rows['ours']['voxels']:,} voxels ({size})")
    print(f"{'':28s} {'seconds':>8s} {'peak GB':>8s} {'faces':>10s} watertight")
    for which, label in (("ours", "ours (bone_model)"), ("peer", "peer (marching cubes only)")):
        r = rows[which]
        print(f"{label:28s} {r['seconds']:8.1f} {r['peak_gb']:8.2f} {r['faces']:10d} "
              f"{r['watertight']}")  # fmt: skip
    ours = rows["ours"]
    if args.short:
        print("goal: judged on the 512 x 512 x 300 volume only")
        return
    met = ours["seconds"] < 10.0 and ours["peak_gb"] < 4.0
    print(f"goal: under 10 s and 4 GB: {'met' if met else 'NOT met'}")


if __name__ == "__main__":
    main()
