"""The cost of whole processes (issue 16, section 3): `pipetile mesh` against vdb_tool's
-ls2mesh on one file, and a sequence in one pipetile process against one vdb_tool process per
frame. Runs alternate (A, B, A, B, ...) so that both see the same machine load; the result is the
median of the per-pair ratios, pipetile's time over vdb_tool's.

    /usr/bin/python3 bench/process_cost.py build/pipetile [--pairs 15] [--frames 100] [--sample phantom]
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time


def seconds(command):
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def paired_ratio(ours, theirs, pairs):
    """Median over alternating pairs of ours / theirs, and both medians."""
    seconds(ours), seconds(theirs)  # warm the page cache and the dynamic loader's
    a, b = [], []
    for _ in range(pairs):
        a.append(seconds(ours))
        b.append(seconds(theirs))
    return statistics.median(x / y for x, y in zip(a, b)), statistics.median(a), statistics.median(b)


def vdb_tool_frames(folder, frames):
    """One vdb_tool process per frame, as a shell loop would run them."""
    script = "".join(f"vdb_tool -read {folder}/f.{f:04d}.vdb -ls2mesh adapt=0.5 -write {folder}/v.{f:04d}.ply\n"
                     for f in range(1, frames + 1))
    return ["sh", "-c", script]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("pipetile")
    parser.add_argument("--pairs", type=int, default=15)
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--sample", default="phantom", help="the volume: a pipetile sample name")
    parser.add_argument("--batch-sample", default=None, help="the sequence's frames (default: --sample)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        volume = os.path.join(folder, "volume.vdb")
        subprocess.run([args.pipetile, "sample", args.sample, "-o", volume], check=True, stdout=subprocess.DEVNULL)
        ratio, ours, theirs = paired_ratio(
            [args.pipetile, "mesh", volume, "-o", os.path.join(folder, "p.ply")],
            ["vdb_tool", "-read", volume, "-ls2mesh", "adapt=0.5", "-write", os.path.join(folder, "v.ply")],
            args.pairs)
        print(f"one file ({args.sample}, four PLYs vs vdb_tool -ls2mesh): pipetile / vdb_tool = {ratio:.3f} "
              f"(medians {ours * 1e3:.0f} ms, {theirs * 1e3:.0f} ms, {args.pairs} pairs)")

        frame = os.path.join(folder, "frame.vdb")
        subprocess.run([args.pipetile, "sample", args.batch_sample or args.sample, "-o", frame], check=True,
                       stdout=subprocess.DEVNULL)
        for f in range(1, args.frames + 1):
            os.link(frame, os.path.join(folder, f"f.{f:04d}.vdb"))
        pairs = max(3, args.pairs // 5)
        ratio, ours, theirs = paired_ratio(
            [args.pipetile, "mesh", os.path.join(folder, "f.####.vdb"), "-o", os.path.join(folder, "p.####.ply")],
            vdb_tool_frames(folder, args.frames), pairs)
        print(f"{args.frames} frames ({args.batch_sample or args.sample}): throughput of one pipetile process over "
              f"{args.frames} vdb_tool processes = {1 / ratio:.2f}x (medians {ours:.2f} s, {theirs:.2f} s, {pairs} pairs)")


if __name__ == "__main__":
    sys.exit(main())
