"""Headless Chromium screenshots for the browser tests (animation page, live viewer)."""
from __future__ import annotations

import base64
import io
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path

import numpy as np

CHROMIUM = shutil.which("chromium") or ("/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)
#: reason given by tests skipped for want of Chromium
MISSING = "headless Chromium not found (Debian: apt-get install chromium)"
#: virtual time [ms] a self-contained page is given before its screenshot
VIRTUAL_BUDGET_MS = 8000
#: real time [s] a live page is given to become ``ready`` (seconds at no load; a loaded machine's
#: software WebGL and websocket took minutes)
READY_DEADLINE_S = 240.0


def screenshot(url: str, out: Path, size: tuple[int, int] = (800, 600),
               ready: Callable[[np.ndarray], bool] | None = None,
               deadline_s: float = READY_DEADLINE_S) -> np.ndarray:
    """RGB image (height, width, 3) int of ``url`` in a ``size`` (width, height) window, also
    written to ``out`` (PNG).

    Without ``ready``: one shot after 8 s of the page's virtual time (software WebGL), for a
    page that needs nothing but its own file. With ``ready``: the page loads over a live
    connection (the viewer's meshes come through a websocket in real time, which the page's
    virtual time does not wait for, so a loaded machine shot a blank page), so the browser is
    driven over the DevTools protocol and shot every second of real time until
    ``ready(image)`` holds on two shots alike or ``deadline_s`` [s] has passed; the last image is returned either
    way, for the caller's assertion to judge."""
    if ready is None:
        return _virtual_time_shot(url, out, size)
    return _shot_when_ready(url, out, size, ready, deadline_s)


def _virtual_time_shot(url: str, out: Path, size: tuple[int, int]) -> np.ndarray:
    out.unlink(missing_ok=True)
    command = [*_browser(size), f"--virtual-time-budget={VIRTUAL_BUDGET_MS}", f"--screenshot={out}", url]
    subprocess.run(command, capture_output=True, timeout=300, check=False)
    assert out.is_file(), f"chromium wrote no screenshot: {' '.join(command)}"
    return _rgb(out.read_bytes())


def _shot_when_ready(url: str, out: Path, size: tuple[int, int], ready: Callable[[np.ndarray], bool],
                     deadline_s: float) -> np.ndarray:
    from websockets.sync.client import connect   # a dependency of viser, which the live pages need
    # the profile's cleanup tolerates files the browser's last processes were still writing
    with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as profile, \
            open(Path(profile) / "stderr.txt", "w+") as stderr:
        # stderr to a file, not a pipe nobody reads while the browser runs (a full pipe blocks
        # it); a session of its own, so that its renderer and GPU processes end with it
        browser = subprocess.Popen([*_browser(size), "--remote-debugging-port=0", f"--user-data-dir={profile}", url],
                                   stdout=subprocess.DEVNULL, stderr=stderr, start_new_session=True)
        try:
            port = _devtools_port(browser, Path(stderr.name))
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=30) as reply:
                page = next(t for t in json.load(reply) if t["type"] == "page")
            with connect(page["webSocketDebuggerUrl"], max_size=None, open_timeout=30) as devtools:
                calls = itertools.count(1)
                _call(devtools, next(calls), "Emulation.setDeviceMetricsOverride",   # the window's chrome
                      {"width": size[0], "height": size[1], "deviceScaleFactor": 1, "mobile": False})
                end, last = time.monotonic() + deadline_s, None
                while True:
                    data = base64.b64decode(_call(devtools, next(calls), "Page.captureScreenshot", {"format": "png"})["data"])
                    image = _rgb(data)
                    if (ready(image) and _settled(last, image)) or time.monotonic() > end:
                        out.write_bytes(data)
                        return image
                    last = image
                    time.sleep(1.0)
        finally:
            os.killpg(browser.pid, signal.SIGKILL)
            browser.wait()


def _settled(last: np.ndarray | None, image: np.ndarray) -> bool:
    """The page drew the same picture a second ago (a mesh still arriving changes it)."""
    return last is not None and last.shape == image.shape and int((np.abs(image - last).max(axis=2) > 40).sum()) < 100


def _browser(size: tuple[int, int]) -> list[str]:
    return [CHROMIUM, "--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
            f"--window-size={size[0]},{size[1]}"]


def _devtools_port(browser: subprocess.Popen, stderr: Path, timeout_s: float = 120.0) -> int:
    """The port of ``browser``'s DevTools endpoint, from the line it writes on ``stderr``."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        found = re.search(r"DevTools listening on ws://[^:]+:(\d+)/", stderr.read_text())
        if found:
            return int(found.group(1))
        assert browser.poll() is None, f"chromium exited with {browser.returncode} before opening DevTools"
        time.sleep(0.2)
    raise AssertionError(f"chromium opened no DevTools endpoint in {timeout_s:.0f} s")


def _call(devtools, call_id: int, method: str, params: dict) -> dict:
    """Send one DevTools command; its result (the page's events in between are skipped)."""
    devtools.send(json.dumps({"id": call_id, "method": method, "params": params}))
    while True:
        message = json.loads(devtools.recv(timeout=120))
        if message.get("id") == call_id:
            assert "error" not in message, f"DevTools {method}: {message['error']}"
            return message["result"]


def _rgb(png: bytes) -> np.ndarray:
    from PIL import Image
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)
