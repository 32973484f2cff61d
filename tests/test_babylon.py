"""Luxel's MOZ_lightmap extension for Babylon.js's glTF loader (viewer/babylon_moz_lightmap.js)
against the GLB that test_viewer builds, rendered by Babylon in headless Chromium through the
test page in tests/web/: the same truth (irradiance * baseColor / pi at each pixel) within the
same bounds as three.js's viewer, and nothing fetched from outside the local server. Needs
/usr/bin/chromium (make chromium) and Babylon's packages (make babylon)."""
from pathlib import Path
import shutil
from urllib.parse import urlsplit

import pytest

from browser import render_viewer
from test_viewer import HEIGHT, WIDTH, assert_shows_lightmap, scene_glb

ROOT = Path(__file__).resolve().parent.parent
WEB = ROOT / "tests" / "web"
PAGE = "babylon.html"
EXTENSION = "babylon_moz_lightmap.js"


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """The page, the extension, Babylon's packages and the GLB served from one folder."""
    node_modules = WEB / "node_modules"
    if not (node_modules / ".installed").is_file():
        pytest.fail(f"Babylon.js is not installed in {node_modules}: run `make babylon`")
    site = tmp_path_factory.mktemp("babylon")
    for name in (PAGE, "babylon_page.js"):
        shutil.copyfile(WEB / name, site / name)
    for name in (EXTENSION, "rgbd_lightmap.js", "measure.js"):
        shutil.copyfile(ROOT / "viewer" / name, site / name)
    (site / "node_modules").symlink_to(node_modules, target_is_directory=True)
    (site / "scene.glb").write_bytes(scene_glb())
    return render_viewer(site, WIDTH, HEIGHT, page=PAGE)


def test_babylon_shows_irradiance_times_albedo_over_pi(measured):
    assert_shows_lightmap(measured)


def test_babylon_page_fetches_from_the_local_server_only(measured):
    assert {urlsplit(url).hostname for url in measured.fetched} == {"127.0.0.1"}
    paths = {urlsplit(url).path for url in measured.fetched}
    assert {f"/{EXTENSION}", "/scene.glb", "/node_modules/@babylonjs/core/scene.js"} <= paths
