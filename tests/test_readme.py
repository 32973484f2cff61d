"""README.md against the code it describes: the settings table is what tools/readme_settings.py
renders from native/settings.py today, and the files it links to exist. No Blender, no GL.
(The quote of what `make bake` prints is checked in test_blender_addon.py: it needs a bake.)"""
from pathlib import Path
import re
import sys

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))

import readme_settings  # noqa: E402
from native.settings import EXPOSED_SETTINGS  # noqa: E402

README = ROOT / "README.md"


def test_the_settings_table_is_the_one_the_declaration_renders():
    assert readme_settings.readme_table() == readme_settings.settings_table(), (
        "README.md's settings table differs from native/settings.py: run "
        "`python tools/readme_settings.py`")


def test_the_settings_table_has_a_row_with_a_trade_per_exposed_setting():
    rows = readme_settings.settings_table().splitlines()[2:]
    assert len(rows) == len(EXPOSED_SETTINGS)
    for row, setting in zip(rows, EXPOSED_SETTINGS):
        cells = [cell.strip() for cell in row.strip("|").split(" | ")]
        assert cells[0] == setting.exposed.label
        assert cells[-1] == setting.exposed.trades and setting.exposed.trades, setting.name


def test_the_files_the_readme_links_to_exist():
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", README.read_text())
    local = [target for target in targets if "://" not in target]
    assert local, "no local links found"
    missing = [target for target in local if not (ROOT / target).exists()]
    assert not missing, f"README.md links to files that do not exist: {missing}"
