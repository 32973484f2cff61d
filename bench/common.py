"""Shared by the benchmark scripts: import path and result files."""
import json
from pathlib import Path
import sys

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def save_results(path, payload):
    """Write one run's results as JSON (bench/plot.py reads them)."""
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(payload, indent=1))
