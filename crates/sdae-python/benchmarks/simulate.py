"""What `sdae.simulate` costs from Python, against the same runs through the Rust API
(`cargo bench -p sdae-bench --bench simulate`): 10 000 paths of the `pendulum` scene, 1 024 steps
of the half-explicit scheme (practical C_eta), the end state recorded or every step, one thread.
Prints the best of `--repeat` runs (seconds) and writes them as JSON to `--out`.

    python crates/sdae-python/benchmarks/simulate.py --out target/bench/python-simulate.json
"""

import argparse
import json
import pathlib
import time

import sdae

PATHS, STEPS = 10_000, 1024


def best_of(repeat, every):
    """The shortest of `repeat` runs (the numpy arrays are made within the run)."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        sdae.simulate("pendulum", "half-explicit-practical", paths=PATHS, steps=STEPS, seed=1, every=every)
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--out", type=pathlib.Path)
    args = parser.parse_args()
    results = {
        "end_state": best_of(args.repeat, STEPS),
        "every_step": best_of(args.repeat, 1),
    }
    for name, seconds in results.items():
        print(f"{name}: {seconds * 1e3:.1f} ms")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps({"paths": PATHS, "steps": STEPS, "seconds": results}, indent=2))


if __name__ == "__main__":
    main()
