"""Virtual models from diagnostic images: CT (and MR) volumes read with their patient frame,
bone segmented and meshed, plans in image coordinates, and a CT scanner simulated on the
phantom so that the model error is the one a CT-derived model really has."""

from models.ct.bone import BoneCheck, BoneModel, bone_model
from models.ct.ct_scanner import CTSettings, ct_scan
from models.ct.readers import read_volume
from models.ct.volume import Volume, VolumeError
from models.ct.volume_plan import read_plan

__all__ = [
    "BoneCheck",
    "BoneModel",
    "CTSettings",
    "Volume",
    "VolumeError",
    "bone_model",
    "ct_scan",
    "read_plan",
    "read_volume",
]
