"""The recording as a user sees it: run.rrd opened in the real rerun viewer, headless,
screenshots at the scan, at the end of the run and on the ICP's timeline, and their pixels
checked.

    python bench/viewer_check.py RUN_FOLDER [--shots DIR]

Needs the system packages the viewer needs without a display: Xvfb, Mesa's software Vulkan
driver, xdotool and ImageMagick (Debian: xvfb mesa-vulkan-drivers libvulkan1 libegl1 libgl1
libxkbcommon-x11-0 xdotool imagemagick). Not part of the test command for that reason.

The screen is 1600 x 1000; the default layout puts the object's close-up at the top left.
Each check counts pixels of a colour the run must show there (the scan's yellow, the rays'
red, the targets' magenta, the residual scale's colours, the search's starts) and fails
with the counts if one is missing. Exit status 0: every check passed.
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

DISPLAY = ":99"
SIZE = (1600, 1000)
#: The close-up view's pixels (x0, y0, x1, y1) in the default layout.
CLOSE_UP = (0, 60, 958, 462)
#: The time ruler: x of the first and the last time, y of a click on it.
RULER = (204, 1581, 985)
TIMELINE_MENU = (180, 764)
ICP_ITEM = (175, 791)


def phases(rrd: Path) -> tuple[dict[str, float], float]:
    """The phases' start times and the recording's last time on sim_time [s]."""
    starts: dict[str, float] = {}
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
    return starts, end


def count(image: np.ndarray, box: tuple[int, int, int, int], test: str) -> int:
    """Pixels in `box` of a colour class: yellow, red, magenta, rainbow, viridis."""
    x0, y0, x1, y1 = box
    px = image[y0:y1, x0:x1, :3].astype(int)
    r, g, b = px[..., 0], px[..., 1], px[..., 2]
    masks = {
        "yellow": (r > 200) & (g > 150) & (b < 110),
        "red": (r > 200) & (g < 110) & (b < 90),
        "magenta": (r > 180) & (g < 80) & (b > 180),
        "rainbow": (np.max(px, axis=-1) - np.min(px, axis=-1) > 120) & ~((r > 200) & (g > 150)),
        "viridis": (g > 90) & (b > 90) & (r < 90),
    }
    return int(masks[test].sum())


class Viewer:
    """rerun's viewer on a virtual display."""

    def __init__(self, rrd: Path) -> None:
        self.env = {**os.environ, "DISPLAY": DISPLAY, "WGPU_BACKEND": "vulkan"}
        self.xvfb = subprocess.Popen(
            ["Xvfb", DISPLAY, "-screen", "0", f"{SIZE[0]}x{SIZE[1]}x24", "-nolisten", "tcp",
             "-extension", "Composite"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        time.sleep(1.0)
        rerun = Path(sys.executable).with_name("rerun")
        self.viewer = subprocess.Popen(
            [str(rerun), str(rrd)], env=self.env, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )  # fmt: skip
        time.sleep(35.0)  # the software renderer takes its time to come up
        self.click(28, 763)  # pause the playback

    def click(self, x: int, y: int) -> None:
        subprocess.run(["xdotool", "mousemove", str(x), str(y), "mousedown", "1"], env=self.env,
                       check=True)  # fmt: skip
        time.sleep(0.3)
        subprocess.run(["xdotool", "mouseup", "1"], env=self.env, check=True)
        time.sleep(1.0)

    def at(self, fraction: float) -> None:
        x0, x1, y = RULER
        self.click(round(x0 + fraction * (x1 - x0)), y)

    def shot(self, path: Path) -> np.ndarray:
        time.sleep(5.0)
        subprocess.run(["import", "-window", "root", str(path)], env=self.env, check=True)
        return np.asarray(Image.open(path).convert("RGB"))

    def close(self) -> None:
        self.viewer.terminate()
        self.xvfb.terminate()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_folder", type=Path)
    parser.add_argument("--shots", type=Path, default=None, help="keep the screenshots here")
    args = parser.parse_args()
    rrd = args.run_folder / "run.rrd"
    missing = [t for t in ("Xvfb", "xdotool", "import") if shutil.which(t) is None]
    if missing or not rrd.is_file():
        print(f"cannot check: missing {missing or [str(rrd)]}")
        return 2
    starts, end = phases(rrd)
    scan = starts["scan"] + 0.6 * (starts["register"] - starts["scan"])
    shots = args.shots or Path(tempfile.mkdtemp(prefix="viewer-"))
    shots.mkdir(parents=True, exist_ok=True)
    checks: list[tuple[str, str, int, int]] = []
    viewer = Viewer(rrd)
    try:
        viewer.at(scan / end)
        image = viewer.shot(shots / "scan.png")
        checks += [("scan", "yellow", count(image, CLOSE_UP, "yellow"), 2000),
                   ("scan", "red", count(image, CLOSE_UP, "red"), 200)]  # fmt: skip
        viewer.at(1.0)
        image = viewer.shot(shots / "end.png")
        bars = (960, 60, 1600, 230)
        checks += [("end", "rainbow", count(image, CLOSE_UP, "rainbow"), 5000),
                   ("end", "magenta", count(image, CLOSE_UP, "magenta"), 100),
                   ("end", "bars", count(image, bars, "magenta"), 2000)]  # fmt: skip
        viewer.click(*TIMELINE_MENU)
        viewer.click(*ICP_ITEM)
        viewer.at(0.0)
        image = viewer.shot(shots / "icp_start.png")
        checks.append(("icp start", "viridis", count(image, CLOSE_UP, "viridis"), 500))
    finally:
        viewer.close()
    failed = 0
    for shot, what, n, least in checks:
        ok = n >= least
        failed += not ok
        print(f"{shot:10s} {what:8s} {n:8d} px (at least {least}) {'ok' if ok else 'MISSING'}")
    print(f"screenshots in {shots}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
