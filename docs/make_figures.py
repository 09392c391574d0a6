"""The pictures of the README and the documentation's home page, made again: `twincell run
skull --seed 0` into a temporary folder, its targets.png, and the end of its recording in the
real rerun viewer (bench/viewer_check.py, which also checks the screenshots' pixels; it needs
Xvfb and Mesa's Vulkan driver).

    python docs/make_figures.py

writes docs/assets/targets.png and docs/assets/recording.png (the viewer's window at the
run's end, 1200 pixels wide)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from PIL import Image

ROOT = Path(__file__).resolve().parent.parent
ASSETS = ROOT / "docs" / "assets"
#: The pictures this script writes, as the README names them.
FIGURES = ("targets.png", "recording.png")
WIDTH = 1200


def main() -> int:
    with tempfile.TemporaryDirectory(prefix="twincell-figures-") as tmp:
        work = Path(tmp)
        run = [sys.executable, "-m", "scenarios.cli", "run", "skull", "--seed", "0", "--quiet"]
        subprocess.run([*run, "--out", str(work / "runs")], check=True, cwd=ROOT)
        folder = (work / "runs" / "latest").resolve()
        check = [sys.executable, str(ROOT / "bench" / "viewer_check.py"), str(folder)]
        done = subprocess.run([*check, "--shots", str(work / "shots")], cwd=ROOT)
        if done.returncode != 0:
            print("the recording's screenshots did not pass their checks", file=sys.stderr)
            return done.returncode
        ASSETS.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(folder / "targets.png", ASSETS / "targets.png")
        window = Image.open(work / "shots" / "end_window.png").convert("RGB")
        height = round(window.height * WIDTH / window.width)
        window.resize((WIDTH, height), Image.Resampling.LANCZOS).save(ASSETS / "recording.png")
    print(f"wrote {', '.join(str(ASSETS / name) for name in FIGURES)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
