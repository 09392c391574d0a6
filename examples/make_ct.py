"""A CT of the skull phantom and a plan made on it, as a hospital would hand them over: the
phantom's simulated head CT (1 mm voxels, a reconstruction kernel's blur, 20 HU of noise:
models.ct.ct_scan) written as NIfTI, and its four burr holes as a plan in the
volume's own frame (RAS for NIfTI, mm), each an entry and a target.

    python examples/make_ct.py [FOLDER]

writes FOLDER/phantom_ct.nii.gz and FOLDER/plan.json (FOLDER: `ct`). Then, as with your own:

    twincell model ct/phantom_ct.nii.gz --out skull.stl
    twincell run skull --model ct/phantom_ct.nii.gz --targets ct/plan.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import nibabel as nib
import numpy as np

from models.ct import CTSettings, ct_scan
from models.ct.volume import RAS_FROM_LPS
from models.registry import builtin_model

#: The volume's voxels [mm]: a head CT reconstructed at 1 mm (a clinical protocol's 0.5 mm
#: in-plane is CTSettings' default; 1 mm keeps the example's volume at 7 million voxels).
VOXEL_MM = (1.0, 1.0, 1.0)


def main(folder: Path) -> None:
    phantom = builtin_model("skull", 0)
    settings = CTSettings(voxel_mm=VOXEL_MM)
    volume = ct_scan(phantom.mesh, settings, np.random.default_rng(0))  # LPS = model [mm]
    folder.mkdir(parents=True, exist_ok=True)
    affine_ras = RAS_FROM_LPS @ volume.affine_lps
    image = nib.Nifti1Image(np.round(volume.data).astype(np.int16), affine_ras)
    image.header.set_xyzt_units("mm")
    nib.save(image, folder / "phantom_ct.nii.gz")
    to_ras = RAS_FROM_LPS[:3, :3]
    targets = []
    for hole in phantom.burr_holes:
        entry_mm = hole.p_entry * 1e3
        target_mm = (hole.p_entry + hole.depth * hole.direction) * 1e3
        targets.append({
            "name": hole.name,
            "entry": np.round(to_ras @ entry_mm, 2).tolist(),
            "target": np.round(to_ras @ target_mm, 2).tolist(),
        })  # fmt: skip
    (folder / "plan.json").write_text(json.dumps({"frame": "RAS", "targets": targets}, indent=1))
    print(f"wrote {folder / 'phantom_ct.nii.gz'} {volume.data.shape} and {folder / 'plan.json'}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=Path("ct"), help="default: ct")
    main(parser.parse_args().folder)
