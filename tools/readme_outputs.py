"""Write what `make bake` prints into README.md, between its markers, so that the guide quotes
today's output: `python tools/readme_outputs.py` (after `make bake` has installed .venv).
tests/test_blender_addon.py bakes the same and checks the quote, seconds aside."""
from datetime import date
from pathlib import Path
import re
import subprocess
import sys

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
# The bake `make bake` runs (Makefile), from the repository's root.
BAKE_ARGUMENTS = ["bake", "--density", "50", "--threshold", "0.01", "--output", "out/cornell",
                  "--preview", "out/cornell/preview.png", "--save-as", "out/cornell/cornell.blend"]
BEGIN, END = "<!-- make bake prints: begin -->", "<!-- make bake prints: end -->"
# Lines a bake prints every second while it shoots: left out of the quote.
PROGRESS = re.compile(r"^luxel: [\d,]+ of [\d,]+ shots, ")
# Seconds, which differ from run to run and machine to machine.
SECONDS = re.compile(r"\d+(\.\d+)? s\b")


def quoted_lines(output):
    """The lines of a bake's stdout that the README quotes: Luxel's, but the shots' progress."""
    return [line for line in output.splitlines()
            if line.startswith("luxel: ") and not PROGRESS.match(line)]


def comparable(lines):
    """The lines with their seconds, the preview's and the saved file's paths and the set-up's
    share done left out, a stage once (a slower machine prints a stage's line again as its
    pieces go by)."""
    found = []
    for line in lines:
        line = re.sub(r"^luxel: (preview|saved) .*", r"luxel: \1",
                      SECONDS.sub("<seconds> s", line))
        line = re.sub(r", set-up \d+ % done$", "", line)
        if line not in found:
            found.append(line)
    return found


def readme_quote(text=None):
    """The quoted lines between the README's markers."""
    text = README.read_text() if text is None else text
    block = text[text.index(BEGIN) + len(BEGIN):text.index(END)]
    return [line for line in block.splitlines()
            if line.startswith("luxel: ")]


def main():
    result = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "blender.py"), "-b",
         "sample_blends/cornell_box.blend", "--command", "luxel", *BAKE_ARGUMENTS],
        cwd=ROOT, capture_output=True, text=True, check=True)
    lines = [line.replace(f"{ROOT}/", "") for line in quoted_lines(result.stdout)]
    text = README.read_text()
    block = (f"{BEGIN}\n```text\n" + "\n".join(lines)
             + f"\n```\n(Mesa llvmpipe, 2 cores, {date.today().isoformat()})\n{END}\n")
    after = text[text.index(END) + len(END):].lstrip()
    README.write_text(text[:text.index(BEGIN)] + block + "\n" + after)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
