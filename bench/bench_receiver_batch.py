"""The receiver pass over a batch of shooters against one pass per shooter: nanoseconds per
receiving texel per shot and whole-bake seconds, on the Cornell box at 160 texels per metre
and the realistic interior at the defaults, the variants alternated in one run:

    python bench/bench_receiver_batch.py [--runs 2] [--before DIR] \
        --json bench/results/receiver-batch-llvmpipe.json

Variants: "one by one" (Settings.batched_receivers off: a pass per shooter) and "batched"
(the default); with ``--before``, a checkout of the code before the batching (say `git
archive <commit> | tar -x -C DIR`) as "before". Each bake runs in a process of its own that
imports the code under test, to the threshold (or the automatic shot limit), with
Settings.profile on (the GPU waited for after each phase, so the phases add up); its seconds
are the whole bake's: set-up, shots and result(). A receiving texel is one of the tiles the
pass draws for a shooter (receivers.receiving_tiles), so both variants count the same
texels: ns per texel per shot is the receivers phase over the sum, over the shots, of their
receiving tiles' texels. Scenes from bench/scenes (bench/export_scenes.py interior). The machine is shared: beside the wall seconds each bake records
its process's CPU seconds (llvmpipe's threads included), of the bake and of the receiver
passes (each waited for), which other jobs move less."""
import argparse
import json
from pathlib import Path
import resource
import subprocess
import sys
import time

ROOT = Path(__file__).resolve().parent.parent
SCENES = {"cornell_box": {"texel_density": 160.0}, "interior": {}}
VARIANTS = {"one by one": {"batched_receivers": False}, "batched": {"batched_receivers": True}}


def bake(source, scene_name, variant):
    """One bake in this process, with the native package of ``source``."""
    sys.path.insert(0, str(source))
    from native import Scene, Settings, Solver, create_context, receivers
    from native.gpu import using

    receiving = [0]
    original = receivers.receiving_tiles

    def counted(tiles, shooter, epsilon):
        chosen = original(tiles, shooter, epsilon)
        boxes = tiles.boxes[chosen]
        receiving[0] += int(((boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])).sum())
        return chosen
    receivers.receiving_tiles = counted
    receiver_cpu = [0.0]
    update = receivers.update

    def timed_update(state, *args, **kwargs):
        started = time.process_time()
        try:
            return update(state, *args, **kwargs)
        finally:
            state.ctx.finish()
            receiver_cpu[0] += time.process_time() - started
    receivers.update = timed_update

    scene = Scene.load(ROOT / "bench" / "scenes" / f"{scene_name}.npz")
    settings = Settings(profile=True, **SCENES[scene_name], **VARIANTS.get(variant, {}))
    ctx = create_context()
    start, start_cpu = time.perf_counter(), cpu_seconds()
    solver = Solver(scene, settings, ctx=ctx)
    try:
        solver.run()
        solver.result()
        with using(ctx):
            ctx.finish()
            error = ctx.error
        seconds, bake_cpu = time.perf_counter() - start, cpu_seconds() - start_cpu
        receiver_seconds = solver.timings["receivers"]
        return {
            "scene": scene_name, "variant": variant, "texels": solver.texel_count,
            "shots": solver.shots, "unshot_fraction": solver.progress.unshot_fraction,
            "receiver_batch": getattr(solver._state, "receiver_batch", 1),
            "gpu_memory_mib": solver.gpu_memory_bytes / 2**20,
            "receiving_texels": receiving[0],
            "ns_per_texel_per_shot": 1e9 * receiver_seconds / max(receiving[0], 1),
            "receiver_pass_cpu_seconds": receiver_cpu[0],
            "cpu_ns_per_texel_per_shot": 1e9 * receiver_cpu[0] / max(receiving[0], 1),
            "seconds": seconds, "cpu_seconds": bake_cpu, "phases": dict(solver.timings),
            "gl_error": error,
        }
    finally:
        solver.release()
        ctx.release()


def cpu_seconds():
    """This process's CPU seconds, all its threads."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=2, help="bakes of each variant per scene")
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    parser.add_argument("--before", type=Path, help="a checkout of the code before")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--worker", nargs=3, metavar=("SOURCE", "SCENE", "VARIANT"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        source, scene, variant = args.worker
        print(json.dumps(bake(Path(source), scene, variant)))
        return

    sources = {variant: ROOT for variant in VARIANTS}
    if args.before:
        sources = {"before": args.before.resolve(), **sources}
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                            capture_output=True, text=True).stdout.strip()
    results = {"commit": commit, "date": time.strftime("%Y-%m-%d"), "bakes": []}
    for scene in args.scenes:
        for run in range(args.runs):
            for variant, source in sources.items():
                done = subprocess.run([sys.executable, __file__, "--worker", str(source), scene,
                                       variant], capture_output=True, text=True, check=True)
                row = json.loads(done.stdout.strip().splitlines()[-1])
                row["run"] = run
                results["bakes"].append(row)
                print(f"{scene} run {run} {variant}: {row['texels']} texels, "
                      f"{row['shots']} shots, {row['seconds']:.1f} s, receivers "
                      f"{row['phases']['receivers']:.1f} s, "
                      f"{row['ns_per_texel_per_shot']:.0f} ns/texel/shot; CPU "
                      f"{row['cpu_seconds']:.1f} s, receiver passes "
                      f"{row['cpu_ns_per_texel_per_shot']:.0f} ns/texel/shot, "
                      f"{row['gl_error']}", flush=True)
                if args.json:
                    args.json.parent.mkdir(parents=True, exist_ok=True)
                    args.json.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
