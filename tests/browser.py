"""The viewer (viewer/) rendered by headless Chromium: the baked camera's view as linear floats
and object IDs, read back from the page's measurement mode (index.html?measure=1), and the URLs
the page requested."""
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
# WebGL on the CPU through SwiftShader (no GPU in CI); Chromium's own calls home find no host
# (the flags that turn its services off leave some), the page's server on 127.0.0.1 does.
FLAGS = (
    "--headless",
    "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
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
    names (the glTF node names), -1 for the background; fetched: the URLs the page requested,
    sorted."""
    rgb: np.ndarray
    ids: np.ndarray
    names: list
    fetched: tuple


def page_requests(net_log):
    """The URLs of the requests that a page made, from Chromium's net log: those with an
    initiating origin (Chromium's own, to Google's update and account services, have none)."""
    log = json.loads(Path(net_log).read_text())
    start = log["constants"]["logEventTypes"]["URL_REQUEST_START_JOB"]
    return tuple(sorted({
        event["params"]["url"] for event in log["events"]
        if event["type"] == start
        and event.get("params", {}).get("initiator", "not an origin") != "not an origin"}))


def render_viewer(folder, width, height, timeout=60.0, page="index.html"):
    """The baked camera's view of the viewer in ``folder`` (written by write_viewer), or of
    another page there that measures the same way."""
    if not CHROMIUM.exists():
        raise RuntimeError(f"{CHROMIUM} is missing: run `make chromium` (Debian's chromium)")
    server = serve(folder)
    try:
        url = f"{server.url}{page}?measure=1&width={width}&height={height}"
        with tempfile.TemporaryDirectory() as profile:
            net_log = Path(profile) / "net-log.json"
            command = [str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}",
                       f"--window-size={width},{height}", "--virtual-time-budget=30000",
                       f"--log-net-log={net_log}", "--dump-dom", url]
            result = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
            fetched = page_requests(net_log) if result.returncode == 0 else ()
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
    return Measurement(rgb=rgb, ids=ids, names=measured["names"], fetched=fetched)
