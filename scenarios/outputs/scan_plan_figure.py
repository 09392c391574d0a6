"""scan_plan.png: the scan's passes over the object, seen from above, each with the surface
the virtual cell predicts it sees; each pass' share of the plan's information and its cell
time; and, for a chosen plan, the worst predicted TRE as the passes were added, against the
goal."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from registration import transform_points
from scenarios.offline.scan_plan import ScanPlan

#: Points drawn per pass at most, and of the object's outline (seeded subsamples).
MAX_POINTS = 4000


def _subsample(points: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    return points if len(points) <= n else points[rng.choice(len(points), n, replace=False)]


def write_scan_plan_figure(
    path: Path,
    plan: ScanPlan,
    T_table_object: np.ndarray,
    vertices_model: np.ndarray,
    goal_m: float | None = None,
) -> None:
    """Write the figure of `plan` (the object's nominal pose T_table_object (4, 4), its
    vertices (N, 3) in the model frame) to `path` (PNG)."""
    rng = np.random.default_rng(0)
    fig = Figure(figsize=(12, 6.2))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.25, 1.0))
    top = fig.add_subplot(grid[:, 0])
    colours = matplotlib.colormaps["tab10"]
    outline = transform_points(T_table_object, _subsample(vertices_model, MAX_POINTS, rng))
    top.scatter(outline[:, 0] * 1e3, outline[:, 1] * 1e3, s=1, c="0.85", label="object")
    centre = outline.mean(axis=0) * 1e3
    reach = float(np.max(np.linalg.norm(outline[:, :2] * 1e3 - centre[:2], axis=1)))
    sides: list[np.ndarray] = []
    for k, (chosen, seen) in enumerate(zip(plan.chosen, plan.seen_model, strict=False)):
        colour = colours(k % 10)
        p = transform_points(T_table_object, _subsample(seen, MAX_POINTS // 2, rng))
        top.scatter(p[:, 0] * 1e3, p[:, 1] * 1e3, s=1, color=colour, alpha=0.5)
        # Where the laser looks from: against its view, from beside the object.
        view = plan.passes[k].T_table_start[:3, 2]
        flat = -view[:2] / max(float(np.linalg.norm(view[:2])), 1e-9)
        if np.linalg.norm(view[:2]) < 0.2:  # from above: a mark over the centre
            top.plot(*centre[:2], marker="o", ms=14, mfc="none", mec=colour, mew=2)
        else:
            # Steeper views start farther out, so that passes from one side stay apart.
            out = 1.1 + 0.8 * (1.0 - float(np.linalg.norm(view[:2])))
            # Passes from the same side side by side.
            same = sum(1 for d in sides if float(d @ flat) > 0.95)
            sides.append(flat)
            aside = np.array([-flat[1], flat[0]]) * 0.18 * reach * same
            head = centre[:2] + flat * reach * out + aside
            tail = head + flat * reach * 0.6
            top.annotate(
                str(k + 1), xy=head, xytext=tail, color=colour, ha="center", va="center",
                arrowprops={"arrowstyle": "->", "color": colour, "lw": 2},
            )  # fmt: skip
        top.plot([], [], color=colour, lw=2, label=f"{k + 1}: {chosen.name.split(' ', 2)[2]}")
    top.set_xlim(centre[0] - 2.2 * reach, centre[0] + 2.2 * reach)
    top.set_ylim(centre[1] - 2.2 * reach, centre[1] + 2.2 * reach)
    top.set_aspect("equal")
    top.set_xlabel("table x [mm]")
    top.set_ylabel("table y [mm]")
    top.set_title("seen from above: what each pass sees; arrows: where it looks from", fontsize=9)
    top.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2)
    fig.suptitle(
        f"{plan.mode} scan plan: {len(plan.passes)} passes, about {plan.predicted_time_s:.0f} s"
        f" of cell time, worst predicted TRE {plan.predicted_tre_max_m * 1e3:.3f} mm"
    )
    share = fig.add_subplot(grid[0, 1])
    x = np.arange(1, len(plan.chosen) + 1)
    share.bar(x, [c.information_share for c in plan.chosen], color=[colours(k % 10) for k in x - 1])
    share.set_ylabel("share of the information")
    share.set_xticks(x)
    twin = share.twinx()
    twin.plot(x, [c.seconds for c in plan.chosen], "k.", label="cell time [s]")
    twin.set_ylabel("pass' cell time [s]")
    worst = fig.add_subplot(grid[1, 1])
    steps = [c.predicted_tre_max_m for c in plan.chosen]
    if all(np.isfinite(steps)):
        worst.plot(x, np.array(steps) * 1e3, "o-", label="worst predicted TRE, passes so far")
    worst.axhline(plan.predicted_tre_max_m * 1e3, color="C2", lw=1, label="the plan's")
    if goal_m is not None:
        worst.axhline(goal_m * 1e3, color="r", ls="--", lw=1, label=f"goal {goal_m * 1e3:g} mm")
    worst.set_xlabel("pass")
    worst.set_ylabel("[mm]")
    worst.set_xticks(x)
    worst.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
