"""Scan planning in the virtual cell (scan.plan: auto): the virtual cell's rays against the
cell's geometry, and the skull job scanned with the passes it chooses."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cell.robots import irb2400
from cell.virtual import VirtualCell
from models.robot import RACK_POS, TABLE_TOP_POS
from scenarios.cli import main


def test_a_ray_straight_down_meets_the_table_top_where_the_layout_puts_it() -> None:
    """From 0.3 m above the table frame's origin, straight down: the table top (the layout's
    TABLE_TOP_POS height) at 0.3 m, its normal up; sideways, nothing within 0.2 m."""
    cell = VirtualCell.of(irb2400(), RACK_POS)
    cell.set_table(0.0)
    T = cell.T_world_site("table_top")
    assert T[2, 3] == pytest.approx(TABLE_TOP_POS[2], abs=1e-9)
    origin = T[:3, 3] + [0.0, 0.0, 0.3]
    dist, normal, names = cell.cast(origin, np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]), 0.2)
    assert np.isinf(dist).all()  # the table is 0.3 m away: beyond 0.2 m
    dist, normal, names = cell.cast(origin, np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]), 1.0)
    assert dist[0] == pytest.approx(0.3, abs=1e-9)
    np.testing.assert_allclose(normal[0], [0.0, 0.0, 1.0], atol=1e-9)
    assert names[1] == ""


def test_the_skull_job_scanned_with_the_chosen_passes_meets_its_goals(tmp_path: Path) -> None:
    """scan.plan auto: the passes chosen in the virtual cell predict every target below the
    goal within the budget; the job runs them and its targets, measured against the truth,
    meet the skull goals (RMS <= 0.5 mm, max <= 1 mm)."""
    code = main(
        ["run", "skull", "--set", "localization.scan.plan=auto", "--out", str(tmp_path),
         "--quiet", "--no-rrd"]
    )  # fmt: skip
    assert code == 0
    results = json.loads((tmp_path / "latest" / "results.json").read_text())
    plan = results["scan_plan"]
    assert plan["mode"] == "auto" and plan["passes"] == len(plan["chosen"]) >= 2
    assert plan["predicted_tre_max_m"] <= 2.5e-4 + 1e-12
    assert sum(c["information_share"] for c in plan["chosen"]) == pytest.approx(1.0)
    assert plan["scan_time_s"] > 0
    assert results["status"] == "complete"
    assert results["target_error_rms_m"] <= 0.5e-3
    assert results["target_error_max_m"] <= 1.0e-3
