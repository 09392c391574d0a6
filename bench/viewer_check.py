"""The recording as a user sees it: run.rrd opened in the real rerun viewer on a virtual
display, screenshots of its views during the scan's last pass, at the end of the run and on
the ICP's timeline, and their pixels checked.

    python bench/viewer_check.py RUN_FOLDER [--shots DIR]
    python bench/viewer_check.py --short [RUN_FOLDER] [--out DIR]

Needs what the viewer needs without a display: Xvfb and Mesa's software Vulkan driver
(Debian: xvfb mesa-vulkan-drivers libvulkan1 libegl1 libgl1 libxkbcommon-x11-0). Not part
of the default test command for that reason (the slow tier runs --short, skipped without
Xvfb).

--short: takes only the screenshots that are checked (five, not eight); without a RUN_FOLDER it
first runs `twincell run skull --seed 0` into DIR (default: a temporary folder) and checks
its recording (the screenshots kept in DIR/shots unless --shots).

The viewer is driven through rerun's ViewerClient (open the file, set the time, take a
screenshot of one view), so no click depends on where the panels are. Each check counts
pixels of a colour the run must show in a view: the scan's yellow and the rays' red during
the scan; the residual scale's colours and the targets' magenta at the end, and the error
bars; the worst-scored starts' purple at the first step of the `icp` timeline. Exit status
0: every check passed.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rerun.chunk as rc
from PIL import Image

CLOSE_UP = "object: scan, registered model, targets"
CELL = "cell"
BARS = "target error [mm]"


def phases(rrd: Path) -> dict[str, float]:
    """The phases' start times on sim_time [s], from the recording's log, its end, and the
    middle of the scan's last pass (where the close-up looks: the object where the table
    holds it at the scan's end)."""
    starts: dict[str, float] = {}
    passes: list[float] = []
    end = 0.0
    for chunk in rc.RrdReader(rrd).stream().to_chunks():
        batch = chunk.to_record_batch()
        if "sim_time" not in batch.schema.names:
            continue
        times = batch.column("sim_time").cast("int64").to_numpy() * 1e-9
        end = max(end, float(times.max()))
        if chunk.entity_path == "/log":
            for t, text in zip(times, batch.column("TextLog:text").to_pylist(), strict=True):
                if text[0].startswith("== "):
                    starts.setdefault(text[0].split("==")[1].strip(), float(t))
                if text[0].startswith("scan pass "):
                    passes.append(float(t))
    passes = sorted([starts.get("scan", 0.0), *passes])
    return {**starts, "last": end, "last pass": 0.5 * (passes[-2] + passes[-1])}


def count(path: Path, colour: str) -> int:
    """Pixels of a colour class in a screenshot."""
    px = np.asarray(Image.open(path).convert("RGB")).astype(int)
    r, g, b = px[..., 0], px[..., 1], px[..., 2]
    spread = np.max(px, axis=-1) - np.min(px, axis=-1)
    masks = {
        "yellow": (r > 200) & (g > 150) & (b < 110),
        "red": (r > 200) & (g < 110) & (b < 90),
        "magenta": (r > 180) & (g < 80) & (b > 180),
        "rainbow": (spread > 120) & ~((r > 200) & (g > 150) & (b < 110)),
        "purple": (r > 40) & (r < 110) & (g < 60) & (b > 70),
    }
    return int(masks[colour].sum())


def make_run(out: Path) -> Path:
    """The run folder of `twincell run skull --seed 0` into `out`."""
    twincell = Path(sys.executable).with_name("twincell")
    command = [str(twincell), "run", "skull", "--seed", "0", "--out", str(out), "--quiet"]
    subprocess.run(command, check=True, capture_output=True)
    return (out / "latest").resolve()


def start_xvfb() -> tuple[subprocess.Popen[bytes], str]:
    """A virtual display on a free display number (Xvfb picks it) and its name."""
    read, write = os.pipe()
    xvfb = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-screen", "0", "1600x1000x24", "-nolisten", "tcp",
         "-extension", "Composite"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, pass_fds=(write,),
    )  # fmt: skip
    os.close(write)
    with os.fdopen(read) as answer:
        number = answer.readline().strip()
    if not number:
        xvfb.kill()
        raise RuntimeError("Xvfb did not start")
    return xvfb, f":{number}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_folder", type=Path, nargs="?", default=None)
    parser.add_argument("--shots", type=Path, default=None, help="keep the screenshots here")
    parser.add_argument(
        "--short", action="store_true", help="checked shots only; no RUN_FOLDER: make a run"
    )
    parser.add_argument("--out", type=Path, default=None, help="--short's run goes here")
    args = parser.parse_args()
    if args.run_folder is None and not args.short:
        parser.error("give a RUN_FOLDER, or --short (which makes its own run without one)")
    if shutil.which("Xvfb") is None:
        print("cannot check: no Xvfb")
        return 2
    if args.run_folder is None:
        out = args.out or Path(tempfile.mkdtemp(prefix="viewer-run-"))
        args.run_folder = make_run(out)
        args.shots = args.shots or out / "shots"
    rrd = (args.run_folder / "run.rrd").resolve()
    if not rrd.is_file():
        print(f"cannot check: no {rrd}")
        return 2
    from rerun.experimental import ViewerClient

    times = phases(rrd)
    shots = args.shots or Path(tempfile.mkdtemp(prefix="viewer-"))
    shots.mkdir(parents=True, exist_ok=True)
    state = tempfile.TemporaryDirectory(prefix="rerun-state-")  # a fresh viewer each time
    xvfb, display = start_xvfb()
    os.environ.update(
        DISPLAY=display,
        WGPU_BACKEND="vulkan",
        XDG_DATA_HOME=f"{state.name}/data",
        XDG_CONFIG_HOME=f"{state.name}/config",
        XDG_CACHE_HOME=f"{state.name}/cache",
    )
    checks: list[tuple[str, str, str, int, int]] = []
    viewer = ViewerClient.spawn(port=9879, hide_welcome_screen=True)
    try:
        viewer.open(str(rrd))
        while viewer.get_state().loading:
            time.sleep(1.0)
        views = {v.name: v.view_id for v in viewer.get_state().views}

        def shot(name: str, view: str) -> Path:
            time.sleep(4.0)  # the software renderer's frame
            path = shots / f"{name}_{view.split(':')[0].replace(' ', '_')}.png"
            viewer.save_screenshot(str(path), views[view])
            return path

        viewer.set_time("sim_time", duration=times["last pass"], play_state="paused")
        close = shot("scan", CLOSE_UP)
        if not args.short:
            shot("scan", CELL)
        # The chosen passes lay their lines a registration voxel (3 mm) apart: a few
        # hundred yellow pixels a pass in the close-up.
        checks += [("scan", CLOSE_UP, "yellow", count(close, "yellow"), 500),
                   ("scan", CLOSE_UP, "red", count(close, "red"), 200)]  # fmt: skip
        viewer.set_time("sim_time", duration=times["last"], play_state="paused")
        close, bars = shot("end", CLOSE_UP), shot("end", BARS)
        if not args.short:
            shot("end", CELL)
            viewer.save_screenshot(str(shots / "end_window.png"))
        checks += [("end", CLOSE_UP, "rainbow", count(close, "rainbow"), 5000),
                   ("end", CLOSE_UP, "magenta", count(close, "magenta"), 100),
                   ("end", BARS, "magenta", count(bars, "magenta"), 2000)]  # fmt: skip
        viewer.set_time("icp", sequence=0, play_state="paused")
        close = shot("icp_start", CLOSE_UP)
        checks.append(("icp 0", CLOSE_UP, "purple", count(close, "purple"), 200))
    finally:
        viewer.quit()
        xvfb.terminate()
        xvfb.wait()
        state.cleanup()
    failed = 0
    print(f"{'moment':6s} {'view':24s} {'colour':8s} {'pixels':>10s} {'least':>9s} result")
    for moment, view, colour, n, least in checks:
        ok = n >= least
        failed += not ok
        print(f"{moment:6s} {view[:24]:24s} {colour:8s} {n:7d} px (>= {least}) "
              f"{'ok' if ok else 'MISSING'}")  # fmt: skip
    print(f"screenshots in {shots}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
