"""Every study of bench/ (or the ones named), each in a process of its own, then nothing else:
bench/report.py makes the tables and plots (make benchmarks runs both).

    python bench/run.py [STUDY ...] [--device {cpu,gpu}] [--quick] [--out DIR] [--dry-run]

A study that fails is reported and the others still run; the exit status is 1 if any failed.
A process per study keeps OpenGL out of the processes that run Blender before it starts
(see the Makefile's test target) and gives each its own peak memory."""
import subprocess
import sys
import time

import accuracy
import common
import levels
import paper
import scaling

# The order make benchmarks runs them in: the solver alone first, Blender after.
SCRIPTS = (paper, scaling, accuracy, levels)


def main():
    parser = common.arguments(__doc__.split("\n\n")[0])
    studies = {study.name: (module, study) for module in SCRIPTS for study in module.STUDIES}
    parser.add_argument("studies", nargs="*", metavar="STUDY",
                        help=f"any of {', '.join(studies)} (default: all)")
    args = parser.parse_args()
    unknown = [name for name in args.studies if name not in studies]
    if unknown:
        parser.error(f"no study {', '.join(unknown)}; the studies: {', '.join(studies)}")
    names = args.studies or list(studies)
    failed, started = [], time.perf_counter()
    for name in names:
        module, study = studies[name]
        if args.dry_run:
            size = study.size(args.device, quick=args.quick)
            print(f"{common.plan_line(study, args.device, size)}  "
                  f"[python bench/{module.__name__}.py {name}]")
            continue
        command = [sys.executable, module.__file__, name, "--device", args.device,
                   "--out", str(args.out)] + (["--quick"] if args.quick else [])
        study_started = time.perf_counter()
        if subprocess.run(command).returncode != 0:
            failed.append(name)
        print(f"run: {name} {'failed' if name in failed else 'done'} in "
              f"{(time.perf_counter() - study_started) / 60:.1f} min", flush=True)
    if not args.dry_run:
        print(f"run: {len(names) - len(failed)} of {len(names)} studies in "
              f"{(time.perf_counter() - started) / 60:.1f} min"
              + (f"; failed: {', '.join(failed)}" if failed else ""))
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
