"""The browser viewer of a baked GLB (viewer/ in the repository): a self-contained folder with
the page, the three.js modules it imports and the GLB, and a local HTTP server for it, since
browsers load ES modules over HTTP only, not from a file:// page. Nothing is fetched from the
internet."""
from functools import partial
import json
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
import shutil
import sys
import threading

from .errors import LuxelError

VIEWER = Path(__file__).resolve().parent.parent / "viewer"
THREE = VIEWER / "node_modules" / "three"
# The page and what its import map reaches, listed in package.json (the extension ships them).
_FILES = json.loads((VIEWER / "package.json").read_text())
PAGE_FILES = tuple(_FILES["pageFiles"])
THREE_FILES = tuple(_FILES["threeFiles"])
THREE_FOLDER = "three"
GLB_NAME = "scene.glb"


class ViewerNotInstalledError(LuxelError, FileNotFoundError):
    """three.js, which the viewer runs on, is not in viewer/node_modules."""


def write_viewer(glb_path, folder):
    """Writes the viewer of ``glb_path`` into ``folder`` (made if missing): index.html,
    viewer.js, moz_lightmap.js, the GLB as scene.glb and three.js under three/. Returns the
    page's path; serve(folder) shows it to a browser."""
    missing = [name for name in THREE_FILES if not (THREE / name).is_file()]
    if missing:
        raise ViewerNotInstalledError(
            f"The viewer's three.js is not installed ({THREE / missing[0]} is missing): run "
            f"`make viewer` in Luxel's folder (it needs npm).")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name in PAGE_FILES:
        shutil.copyfile(VIEWER / name, folder / name)
    for name in THREE_FILES:
        target = folder / THREE_FOLDER / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(THREE / name, target)
    glb_target = folder / GLB_NAME
    if not glb_target.exists() or not glb_target.samefile(glb_path):
        shutil.copyfile(glb_path, glb_target)
    return folder / PAGE_FILES[0]


class _QuietHandler(SimpleHTTPRequestHandler):
    """Serves files without a log line per request, and module scripts with a type browsers
    accept whatever the system's MIME table says."""
    extensions_map = {**SimpleHTTPRequestHandler.extensions_map,
                      ".js": "text/javascript", ".glb": "model/gltf-binary"}

    def log_message(self, format, *args):
        pass


class _QuietServer(ThreadingHTTPServer):
    daemon_threads = True

    def handle_error(self, request, client_address):
        """A browser that drops a connection mid-file (closing, reloading) is no error."""
        if not isinstance(sys.exc_info()[1], ConnectionError):
            super().handle_error(request, client_address)


def serve(folder, port=0, host="127.0.0.1"):
    """Serves ``folder`` over HTTP from a daemon thread; port 0 takes a free one. Returns the
    running ThreadingHTTPServer, its address as ``.url``; stop it with shutdown() and
    server_close()."""
    server = _QuietServer((host, port), partial(_QuietHandler, directory=str(folder)))
    server.url = f"http://{host}:{server.server_address[1]}/"
    threading.Thread(target=server.serve_forever, name="luxel-viewer", daemon=True).start()
    return server
