"""Headless Chromium screenshots for the browser tests (animation page, live viewer)."""
from __future__ import annotations

import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import numpy as np

CHROMIUM = shutil.which("chromium") or ("/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)
#: reason given by tests skipped for want of Chromium
MISSING = "headless Chromium not found (Debian: apt-get install chromium)"
#: virtual-time budgets [ms] of the successive attempts of a screenshot that must be ``ready``
BUDGETS_MS = (8000, 16000, 32000)


def screenshot(url: str, out: Path, size: tuple[int, int] = (800, 600),
               ready: Callable[[np.ndarray], bool] | None = None) -> np.ndarray:
    """RGB image (height, width, 3) int of ``url`` in a ``size`` (width, height) window, after
    8 s of the page's virtual time (software WebGL); also written to ``out`` (PNG).

    A page that loads over a live connection (the viewer's meshes come through a websocket, in
    real time, not the page's virtual time) may not be drawn yet after the budget: with
    ``ready`` the page is shot again with a longer budget (``BUDGETS_MS``) until ``ready(image)``
    holds; the last image is returned either way, for the caller's assertion to judge."""
    from PIL import Image
    for budget in BUDGETS_MS if ready is not None else BUDGETS_MS[:1]:
        out.unlink(missing_ok=True)
        command = [CHROMIUM, "--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                   f"--window-size={size[0]},{size[1]}", f"--virtual-time-budget={budget}", f"--screenshot={out}", url]
        subprocess.run(command, capture_output=True, timeout=300, check=False)
        assert out.is_file(), f"chromium wrote no screenshot: {' '.join(command)}"
        image = np.asarray(Image.open(out).convert("RGB"), dtype=int)
        if ready is None or ready(image):
            break
    return image
