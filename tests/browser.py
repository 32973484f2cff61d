"""The viewer (viewer/) rendered by headless Chromium: the baked camera's view as linear floats
and object IDs, read back from the page's measurement mode (index.html?measure=1)."""
import base64
from dataclasses import dataclass
import html
import json
from pathlib import Path
import re
import subprocess
import tempfile

import numpy as np

from native.viewer import serve

CHROMIUM = Path("/usr/bin/chromium")
# WebGL on the CPU through SwiftShader (no GPU in CI), and nothing that reaches the network.
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-dev-shm-usage",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-quic",
    "--no-first-run",
    "--no-default-browser-check",
)
MEASURE = re.compile(r'<pre id="measure">(.*?)</pre>', re.S)


@dataclass(frozen=True)
class Measurement:
    """rgb: (H, W, 3) float32 linear radiance, top row first; ids: (H, W) int32 indices into
    names (the glTF node names), -1 for the background."""
    rgb: np.ndarray
    ids: np.ndarray
    names: list


def render_viewer(folder, width, height, timeout=60.0):
    """The baked camera's view of the viewer in ``folder`` (written by write_viewer)."""
    if not CHROMIUM.exists():
        raise RuntimeError(f"{CHROMIUM} is missing: run `make chromium` (Debian's chromium)")
    server = serve(folder)
    try:
        url = f"{server.url}index.html?measure=1&width={width}&height={height}"
        with tempfile.TemporaryDirectory() as profile:
            command = [str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}",
                       f"--window-size={width},{height}", "--virtual-time-budget=30000",
                       "--dump-dom", url]
            result = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    finally:
        server.shutdown()
        server.server_close()
    match = MEASURE.search(result.stdout)
    if result.returncode != 0 or match is None or not match.group(1).strip():
        log = "\n".join(line for line in result.stderr.splitlines() if "dbus" not in line)
        raise RuntimeError(
            f"Chromium gave no measurement (exit {result.returncode}):\n{log[-3000:]}")
    measured = json.loads(html.unescape(match.group(1)))
    if "error" in measured:
        raise RuntimeError(f"the viewer failed: {measured['error']}")
    shape = (measured["height"], measured["width"])
    rgb = np.frombuffer(base64.b64decode(measured["rgb"]), dtype="<f4").reshape(shape + (3,))
    ids = np.frombuffer(base64.b64decode(measured["ids"]), dtype="<i4").reshape(shape)
    return Measurement(rgb=rgb, ids=ids, names=measured["names"])
