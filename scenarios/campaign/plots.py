"""Figures of a campaign (PNG), drawn from the results table: target error distribution,
registration error against noise and scan size, acceptance, predicted TRE calibration, run
time."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from models.atomic import write_atomic
from scenarios.campaign.rows import CALIBRATION_GOAL, group_rows, per_target

if TYPE_CHECKING:
    from matplotlib.figure import Figure

Rows = list[dict[str, str]]
#: Labelled groups of rows (scenarios.campaign.rows.group_rows).
Groups = list[tuple[str, Rows]]


def save_png(fig: Figure, path: Path) -> Path:
    """Save a figure through a temporary file and close it."""
    import matplotlib.pyplot as plt

    try:
        write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110, bbox_inches="tight", format="png"))
    finally:
        plt.close(fig)
    return path


def _column(rows: Rows, name: str) -> np.ndarray:
    return np.array([float(r[name]) if r.get(name, "") != "" else math.nan for r in rows])


def _accepted(r: dict[str, str]) -> bool:
    return r.get("accepted", "") not in ("", "0")


def write_plots(folder: Path, rows: Rows, keys: list[str]) -> list[Path]:
    """Write the campaign's figures into `folder`; returns their paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r.get("status") == "ok"]
    groups = group_rows(ok, keys) if keys else [("all", ok)]
    labels = [label.replace(", ", "\n") for label, _ in groups]
    figures = (_target_error, _registration_error, _acceptance, _tre_calibration, _run_time)
    return [figure(plt, folder, keys, ok, groups, labels) for figure in figures]


def _target_error(
    plt: Any, folder: Path, keys: list[str], ok: Rows, groups: Groups, labels: list[str]
) -> Path:
    """Box plots of the accepted registrations' target errors, per group."""
    fig, ax = plt.subplots(figsize=(max(5.0, 1.3 * len(groups)), 4))
    data = [per_target([r for r in g if _accepted(r)], "err_t", "_m") * 1e3 for _, g in groups]
    ax.boxplot([d if len(d) else [math.nan] for d in data], whis=(5, 95))
    ax.set_xticks(range(1, len(groups) + 1), labels, fontsize=8)
    ax.axhline(2.0, color="red", lw=1, ls="--", label="false accept above 2 mm")
    ax.set_yscale("log")
    ax.set_ylabel("target error of accepted registrations [mm]")
    ax.legend(fontsize=8)
    return save_png(fig, folder / "target_error.png")


def _registration_error(
    plt: Any, folder: Path, keys: list[str], ok: Rows, groups: Groups, labels: list[str]
) -> Path:
    """The largest target error against the noise (or residual) and the scanned share."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    sigma_key = next((k for k in keys if k.endswith("sigma")), None)
    for i, (label, g) in enumerate(groups):
        err = _column(g, "target_error_max_m") * 1e3
        noise = _column(g, f"vary.{sigma_key}") * 1e3 if sigma_key else _column(g, "rms_m") * 1e3
        size = _column(g, "surface_fraction") * 100
        yes = np.array([_accepted(r) for r in g], dtype=bool)
        color = f"C{i % 10}"
        axes[0].scatter(noise[yes], err[yes], s=9, color=color, label=label)
        axes[0].scatter(noise[~yes], err[~yes], s=12, color=color, marker="x", alpha=0.5)
        axes[1].scatter(size[yes], err[yes], s=9, color=color)
        axes[1].scatter(size[~yes], err[~yes], s=12, color=color, marker="x", alpha=0.5)
    axes[1].set_title("dots: accepted, crosses: not accepted", fontsize=8)
    axes[0].set_xlabel(f"{sigma_key} [mm]" if sigma_key else "registration residual RMS [mm]")
    axes[1].set_xlabel("scanned surface [% of the object]")
    axes[0].set_ylabel("largest target error [mm]")
    for ax in axes:
        ax.set_yscale("log")
        ax.axhline(2.0, color="red", lw=1, ls="--")
    axes[0].legend(fontsize=7)
    return save_png(fig, folder / "registration_error.png")


def _acceptance(
    plt: Any, folder: Path, keys: list[str], ok: Rows, groups: Groups, labels: list[str]
) -> Path:
    """Each group's share of accepted, ambiguous and rejected trials, and its false accepts."""
    fig, ax = plt.subplots(figsize=(max(5.0, 1.3 * len(groups)), 4))
    bottom = np.zeros(len(groups))
    for verdict, color in (
        ("accepted", "tab:green"),
        ("ambiguous", "tab:orange"),
        ("rejected", "tab:red"),
    ):
        share = np.array(
            [sum(r.get("verdict") == verdict for r in g) / max(len(g), 1) for _, g in groups]
        )
        ax.bar(range(len(groups)), share, bottom=bottom, color=color, label=verdict)
        bottom += share
    for i, (_, g) in enumerate(groups):
        false = sum(r.get("false_accept", "") not in ("", "0") for r in g)
        ax.text(i, 1.02, f"{false} false", ha="center", fontsize=8)
    ax.set_xticks(range(len(groups)), labels, fontsize=8)
    ax.set_ylim(0, 1.1)
    ax.set_ylabel("fraction of trials")
    ax.legend(fontsize=8, loc="lower right")
    return save_png(fig, folder / "acceptance.png")


def _tre_calibration(
    plt: Any, folder: Path, keys: list[str], ok: Rows, groups: Groups, labels: list[str]
) -> Path:
    """The measured over predicted TRE of the accepted registrations of the right object."""
    fig, ax = plt.subplots(figsize=(6, 4))
    right = [r for r in ok if _accepted(r) and r.get("right_object", "") not in ("", "0")]
    ratio = per_target(right, "ratio_t", "")
    ratio = ratio[np.isfinite(ratio) & (ratio > 0)]
    if len(ratio):
        ax.hist(np.log10(ratio), bins=40, color="tab:blue")
        ax.axvline(np.log10(np.median(ratio)), color="k", label=f"median {np.median(ratio):.2f}")
    lo, hi = CALIBRATION_GOAL
    ax.axvspan(np.log10(lo), np.log10(hi), color="tab:green", alpha=0.2, label="goal of the median")
    ax.set_xlabel("log10 measured / predicted TRE (per target, accepted)")
    ax.set_ylabel("targets")
    ax.legend(fontsize=8)
    return save_png(fig, folder / "tre_calibration.png")


def _run_time(
    plt: Any, folder: Path, keys: list[str], ok: Rows, groups: Groups, labels: list[str]
) -> Path:
    """The trials' run times, per group."""
    fig, ax = plt.subplots(figsize=(6, 4))
    for label, g in groups:
        t = _column(g, "trial_seconds")
        ax.hist(t[np.isfinite(t)], bins=30, alpha=0.6, label=label)
    ax.set_xlabel("trial run time [s]")
    ax.set_ylabel("trials")
    ax.legend(fontsize=7)
    return save_png(fig, folder / "run_time.png")
