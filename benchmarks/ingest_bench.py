"""Median load_urdf time per shared robot: python -m benchmarks.ingest_bench [-n RUNS] [DIR]."""
import argparse
import statistics
import time
from pathlib import Path

from urdfkb.pipeline.reading.ingest import load_urdf

REPO = Path(__file__).resolve().parents[1]

def median_ms(path: Path, runs: int) -> float:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        load_urdf(path)
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1000


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("-n", "--runs", type=int, default=20, help="runs per file (default 20)")
    parser.add_argument("directory", nargs="?", type=Path, default=REPO.parent / "shared" / "urdf")
    args = parser.parse_args()
    files = sorted(args.directory.glob("*.urdf"))
    load_urdf(files[0])  # warm imports and caches outside the timing
    print(f"median of {args.runs} runs\n")
    print(f"| {'file':<27} | {'KiB':>6} | {'links':>5} | {'median ms':>9} |")
    print(f"|{'-' * 29}|{'-' * 7}:|{'-' * 6}:|{'-' * 10}:|")
    for path in files:
        links = len(load_urdf(path).links)
        ms = median_ms(path, args.runs)
        print(f"| {path.name:<27} | {path.stat().st_size / 1024:>6.1f} | {links:>5} | {ms:>9.2f} |")


if __name__ == "__main__":
    main()
