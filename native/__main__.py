"""Bake the built-in Cornell box and write its lightmaps:

    python -m native --output out/cornell

writes lightmap_page<N>.exr (float32 RGBA), lightmap_page<N>.png (the atlas, tone-mapped) and
preview.png (a camera view lit by the lightmaps), and prints the bake's statistics."""
import argparse
from pathlib import Path
import sys

from . import Settings, Solver, tone_map, write_exr, write_png
from .errors import LuxelError
from .preview import render_preview
from .samples import cornell_box

CORNELL_CAMERA = dict(eye=(0.278, 0.273, -0.8), target=(0.278, 0.273, 0.28), fov=39.3)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m native", description=__doc__.split("\n")[0])
    parser.add_argument("--output", type=Path, default=Path("out/cornell"))
    parser.add_argument("--density", type=float, default=100.0, help="texels per metre")
    parser.add_argument("--threshold", type=float, default=0.02, help="unshot fraction to stop at")
    parser.add_argument("--shots", type=int, default=20000, help="maximum number of shots")
    parser.add_argument("--shoot-level", type=int, default=2)
    parser.add_argument("--hemicube", type=int, default=256, help="hemicube resolution")
    args = parser.parse_args(argv)

    try:
        args.output.mkdir(parents=True, exist_ok=True)
        settings = Settings(texel_density=args.density, threshold=args.threshold,
                            max_shots=args.shots, shoot_level=args.shoot_level,
                            hemicube_resolution=args.hemicube)
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
