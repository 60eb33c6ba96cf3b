"""CPU instructions per batch step of the training loop, counted by valgrind (a script, not a test).

    python benchmarks/count_instructions.py [--recipe paper] [--size 10] [--compare DIR]

Timings on a shared VM drift (the development VM's speed changed by 1.8x within one session),
so ``bench_train.py --compare`` cannot resolve a change of a few per cent there. An instruction
count does not depend on the machine's load: valgrind's cachegrind (``--cache-sim=no``) counts
every instruction of ``symrl.train.train_batch`` run twice, with few and with more trials; the
difference divided by the batch steps between the two runs is the loop's cost per batch step,
without the imports and the setup. Runs of the same code still differ by up to 1 % (the
allocator's and the garbage collector's timing): a difference of a few per cent needs two or
more runs of each side. It takes about two minutes a run (cachegrind runs the
process 30-50x slower); ``--compare DIR`` counts another checkout's code the same way.
Needs ``valgrind`` on the PATH.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

_CHILD = """
import sys, torch
torch.set_num_threads(1)
import symrl.train as T
from symrl.learner.config import load_config
config = load_config(sys.argv[1], [f"run.trials={sys.argv[3]}"])
results = T.train_batch(config, list(range(int(sys.argv[2]))), progress=False)
print("FRAMES", results[0].timings["frames"], T.__file__)
"""


def count(checkout: Path, recipe: str, size: int, trials: int) -> tuple[int, int]:
    """(instructions, robot-steps) of one ``train_batch`` run of ``checkout``'s code."""
    with tempfile.TemporaryDirectory() as tmp:
        out_file = Path(tmp) / "cachegrind.out"
        args = [
            "valgrind",
            "--tool=cachegrind",
            "--cache-sim=no",
            f"--cachegrind-out-file={out_file}",
            sys.executable,
            "-c",
            _CHILD,
            recipe,
            str(size),
            str(trials),
        ]
        # a fixed hash seed: string hashes decide dict and set layouts, and so a little of
        # the work, which would vary from run to run
        env = {**os.environ, "PYTHONPATH": str(checkout.resolve()), "PYTHONHASHSEED": "0"}
        # run in the empty folder: `python -c` puts the working folder first on sys.path,
        # where another checkout's symrl would shadow this one's
        run = subprocess.run(args, env=env, cwd=tmp, capture_output=True, text=True, check=True)
        found = re.search(r"^FRAMES (\d+) (.+)$", run.stdout, re.M)
        assert found is not None, f"no FRAMES line in the child's output: {run.stdout!r}"
        if not Path(found.group(2)).resolve().is_relative_to(checkout.resolve()):
            sys.exit(f"count_instructions: {checkout} ran the symrl of {found.group(2)}")
        frames = int(found.group(1))
        summary = re.search(r"^summary: (\d+)$", out_file.read_text(), re.M)
        assert summary is not None, f"no summary line in {out_file}"
        return int(summary.group(1)), frames


def per_batch_step(checkout: Path, recipe: str, size: int, few: int, more: int) -> float:
    """Instructions per batch step (a step of all ``size`` robots) of the loop alone."""
    i0, f0 = count(checkout, recipe, size, few)
    i1, f1 = count(checkout, recipe, size, more)
    return (i1 - i0) / ((f1 - f0) / size)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recipe", default="paper_map")
    parser.add_argument("--size", type=int, default=10, help="robots in the batch")
    parser.add_argument("--trials", default="4,16", help="the two runs' trials, few,more")
    parser.add_argument(
        "--compare",
        default=None,
        metavar="DIR",
        help="another checkout of the repository, counted the same way",
    )
    args = parser.parse_args()
    if shutil.which("valgrind") is None:
        sys.exit("count_instructions: valgrind is not on the PATH (e.g. apt install valgrind)")
    few, more = (int(t) for t in args.trials.split(","))
    if not 0 < few < more:
        sys.exit(f"count_instructions: --trials must be two counts, few < more, got {args.trials}")
    here = Path(__file__).resolve().parent.parent
    rows = [("this checkout", here)]
    if args.compare:
        rows.append((args.compare, Path(args.compare)))
    counts = {name: per_batch_step(path, args.recipe, args.size, few, more) for name, path in rows}
    print(
        f"recipe {args.recipe}, B = {args.size}: CPU instructions per batch step "
        f"(cachegrind; runs of {few} and {more} trials)"
    )
    print("| code | instructions per batch step |")
    print("| --- | ---: |")
    for name, value in counts.items():
        print(f"| {name} | {value / 1e6:.3f} M |")
    if args.compare:
        base = counts[args.compare]
        print(f"this checkout / {args.compare}: {counts['this checkout'] / base:.4f}")


if __name__ == "__main__":
    main()
