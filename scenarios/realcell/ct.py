"""The virtual model made as a hospital makes it: the real object (the phantom, the truth)
CT-scanned in simulation, the scan segmented and meshed by the same code a user's CT goes
through (models.ct). The planner gets the mesh; the truth stays the phantom."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from models.ct import CTSettings, bone_model, ct_scan
from models.model import ObjectModel
from scenarios.configuration.cell_sections import CTSection
from scenarios.scenario_errors import ScenarioError


def ct_virtual_model(real: ObjectModel, section: CTSection, seed: int) -> ObjectModel:
    """The virtual model of `real` from its simulated CT (`section`), the scanner's noise from
    the run's seed (its own random stream); the plan (burr holes, frames) is the real
    object's, in the same frame (the CT's patient frame is the object's model frame)."""
    try:
        settings = CTSettings(
            voxel_mm=section.voxel_mm,
            blur_mm=section.blur_mm,
            noise_hu=section.noise_hu,
            iso_hu=section.iso_hu,
        )
    except ValueError as exc:
        raise ScenarioError(f"model.ct: {exc}") from None
    rng = np.random.default_rng(np.random.SeedSequence([seed, 11]))
    volume = ct_scan(real.mesh, settings, rng)
    bone = bone_model(volume, iso_hu=section.iso_hu)
    voxel = " x ".join(f"{v:g}" for v in section.voxel_mm)
    return replace(
        real,
        mesh=bone.mesh,
        source=f"{real.source}, CT {voxel} mm, blur {section.blur_mm:g} mm, noise "
        f"{section.noise_hu:g} HU, bone at {section.iso_hu:g} HU",
    )
