"""Headless Chromium screenshots for the browser tests (animation page, live viewer)."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np

CHROMIUM = shutil.which("chromium") or ("/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)
#: reason given by tests skipped for want of Chromium
MISSING = "headless Chromium not found (Debian: apt-get install chromium)"


def screenshot(url: str, out: Path, size: tuple[int, int] = (800, 600)) -> np.ndarray:
    """RGB image (height, width, 3) int of ``url`` in a ``size`` (width, height) window, after
    8 s of the page's virtual time (software WebGL); also written to ``out`` (PNG)."""
    from PIL import Image
    command = [CHROMIUM, "--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
               f"--window-size={size[0]},{size[1]}", "--virtual-time-budget=8000", f"--screenshot={out}", url]
    subprocess.run(command, capture_output=True, timeout=300, check=False)
    assert out.is_file(), f"chromium wrote no screenshot: {' '.join(command)}"
    return np.asarray(Image.open(out).convert("RGB"), dtype=int)
