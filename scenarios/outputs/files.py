"""Files of a run folder besides results.json: scan.ply, program.mod and the PNG plots.
Every file is written to a temporary name and renamed into place (complete or absent)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cell import nominal_kinematics
from models import ObjectModel
from models.atomic import write_atomic
from scenarios.offline.program import OfflineProgram
from scenarios.offline.rapid import program_module
from scenarios.realcell.evaluation import TargetEvaluation

if TYPE_CHECKING:
    from scenarios.offline.localization import Localization


def write_ply(path: Path, points: np.ndarray) -> Path:
    """Points (N, 3) [m] as a binary little-endian PLY point cloud (float64 x, y, z)."""
    p = np.ascontiguousarray(np.asarray(points, dtype="<f8").reshape(-1, 3))
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment units m, nominal table frame\n"
        f"element vertex {len(p)}\nproperty double x\nproperty double y\nproperty double z\n"
        "end_header\n"
    ).encode()

    def write(tmp: Path) -> None:
        tmp.write_bytes(header + p.tobytes())

    return write_atomic(path, write)


def read_ply(path: Path) -> np.ndarray:
    """Points (N, 3) of a PLY written by `write_ply`."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    return np.frombuffer(data[end:], dtype="<f8").reshape(-1, 3)


def write_program(path: Path, program: OfflineProgram, T_table_nominal: np.ndarray) -> Path:
    """The RAPID module of `program` (see scenarios.offline.rapid)."""
    text = program_module(program, nominal_kinematics(), T_table_nominal)
    return write_atomic(path, lambda tmp: tmp.write_text(text))


def write_plots(
    folder: Path,
    located: Localization | None,
    targets: tuple[TargetEvaluation, ...],
    predicted_tre: np.ndarray | None,
    virtual: ObjectModel,
) -> list[Path]:
    """registration.png (ICP rms per iteration; scan points seen from above) and
    targets.png (achieved error against predicted TRE per target)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    if located is not None:
        fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
        history = np.asarray(located.result.history) * 1e3
        a.semilogy(np.arange(1, len(history) + 1), history, "o-")
        a.set_xlabel("ICP iteration")
        a.set_ylabel("inlier rms [mm]")
        a.set_title(f"final ICP ({located.result.verdict})")
        p = located.points_used * 1e3
        b.scatter(p[:, 0], p[:, 1], s=0.5, c=p[:, 2], cmap="viridis")
        b.set_aspect("equal")
        b.set_xlabel("x table [mm]")
        b.set_ylabel("y table [mm]")
        b.set_title(f"{len(p)} scan points used (height colour)")
        fig.tight_layout()
        written.append(_save(fig, folder / "registration.png"))
        plt.close(fig)
    if targets:
        names = [t.name for t in targets]
        by_name = {h.name: i for i, h in enumerate(virtual.burr_holes)}
        fig, ax = plt.subplots(figsize=(7, 4))
        x = np.arange(len(names))
        ax.bar(x - 0.2, [t.error_m * 1e3 for t in targets], 0.4, label="achieved error")
        if predicted_tre is not None:
            ax.bar(
                x + 0.2,
                [predicted_tre[by_name[n]] * 1e3 for n in names],
                0.4,
                label="predicted TRE",
            )
        ax.axhline(1.0, color="r", ls="--", lw=1, label="goal max 1 mm")
        ax.axhline(0.5, color="orange", ls=":", lw=1, label="goal rms 0.5 mm")
        ax.set_xticks(x, names, rotation=20)
        ax.set_ylabel("[mm]")
        ax.legend()
        ax.set_title("target errors")
        fig.tight_layout()
        written.append(_save(fig, folder / "targets.png"))
        plt.close(fig)
    return written


def write_assembly_plot(folder: Path, results: dict[str, Any]) -> Path | None:
    """assembly.png: the two methods side by side (pose error in rotation and translation,
    error of each screw tip) from the assembly job's results; None if nothing was driven."""
    methods = results.get("methods", {})
    if not any(m.get("targets") for m in methods.values()):
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = {"laser_3d": "3D surface matching", "ir_2d": "2D IR edge probing"}
    names = list(methods)
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(12, 4), width_ratios=(1, 1, 2))
    colours = ("tab:blue", "tab:orange")
    for ax, key, scale, unit in (
        (a, "rotation_error_deg", 1.0, "deg"),
        (b, "translation_error_m", 1e3, "mm"),
    ):
        values = [methods[n][key] * scale for n in names]
        ax.bar(range(len(names)), values, color=colours[: len(names)])
        ax.set_xticks(range(len(names)), [labels.get(n, n) for n in names], rotation=10)
        ax.set_ylabel(f"[{unit}]")
        ax.set_title(f"pose error, {key.split('_')[0]}")
    screws = [t["name"] for t in methods[names[0]]["targets"]]
    x = np.arange(len(screws))
    width = 0.8 / len(names)
    for k, n in enumerate(names):
        errors = {t["name"]: t["error_m"] * 1e3 for t in methods[n]["targets"]}
        c.bar(
            x + (k - (len(names) - 1) / 2) * width,
            [errors.get(s, np.nan) for s in screws],
            width,
            color=colours[k % 2],
            label=labels.get(n, n),
        )
    c.set_xticks(x, screws)
    c.set_ylabel("[mm]")
    c.set_title("screw tip against the true screw frame")
    c.legend()
    pick = results.get("pick")
    if pick:
        fig.suptitle(
            f"assembly, seed {results.get('seed')}: lifted {pick['lifted_m'] * 1e3:.1f} mm, "
            f"slip {pick['slip_m'] * 1e3:.2f} mm, "
            f"put down {pick['placed_displacement_m'] * 1e3:.2f} mm from where it was"
        )
    fig.tight_layout()
    path = _save(fig, folder / "assembly.png")
    plt.close(fig)
    return path


def _save(fig: object, path: Path) -> Path:
    return write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))  # type: ignore[attr-defined]
