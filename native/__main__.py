"""Bake the built-in Cornell box and write its lightmaps:

    python -m native --output out/cornell

writes lightmap_page<N>.exr (float32 RGBA), lightmap_page<N>.png (the atlas, tone-mapped) and
preview.png (a camera view lit by the lightmaps), and prints the bake's statistics."""
import argparse
from dataclasses import replace
from pathlib import Path
import sys

from . import Settings, Solver, tone_map, write_exr, write_png
from .errors import LuxelError
from .preview import render_preview
from .samples import cornell_box
from .settings import add_options, given_settings

CORNELL_CAMERA = dict(eye=(0.278, 0.273, -0.8), target=(0.278, 0.273, 0.28), fov=39.3)
# Finer than a bake's defaults: the demo shows the solver at its best.
CORNELL_SETTINGS = Settings(texel_density=100.0, threshold=0.02, max_shots=20000,
                            hemicube_resolution=256)


def parser():
    """The demo's command line: --output and an option for every exposed setting."""
    options = argparse.ArgumentParser(prog="python -m native",
                                      description=__doc__.split("\n")[0])
    options.add_argument("--output", type=Path, default=Path("out/cornell"))
    add_options(options, defaults=CORNELL_SETTINGS)
    return options


def main(argv=None):
    args = parser().parse_args(argv)

    try:
        args.output.mkdir(parents=True, exist_ok=True)
        settings = replace(CORNELL_SETTINGS, **given_settings(args))
        with Solver(cornell_box(), settings) as solver:
            print(f"device: {solver.ctx.info['GL_RENDERER']}")
            width, height = solver.gpu_page_size
            print(f"texels: {solver.texel_count} on {solver.atlas.page_count} page(s) of "
                  f"{solver.atlas.width}x{solver.atlas.height} ({width}x{height} on the GPU), "
                  f"GPU memory {solver.gpu_memory_bytes / 2**20:.1f} MiB")

            def report(progress):
                if progress.shots % 500 == 0:
                    print(f"  shot {progress.shots}: unshot {progress.unshot_fraction:.2%}")
            progress = solver.run(report)
            pages = solver.result()
            for index, page in enumerate(pages):
                write_exr(args.output / f"lightmap_page{index}.exr", page)
                write_png(args.output / f"lightmap_page{index}.png", tone_map(page[::-1]))
            view = render_preview(solver, pages, **CORNELL_CAMERA)
            write_png(args.output / "preview.png", tone_map(view))
            print(f"shots: {progress.shots}")
            print(f"seconds: {progress.seconds:.2f}")
            print(f"unshot fraction: {progress.unshot_fraction:.4f}")
            print(f"ledger imbalance: {solver.ledger().imbalance():.2e}")
            print(f"wrote {len(pages)} EXR page(s) and previews to {args.output}")
    except LuxelError as error:
        print(f"luxel: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
