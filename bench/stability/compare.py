#!/usr/bin/env python3
"""Stability gate vs DESIGN.md §9 targets and vs CVXPY + Clarabel (PyPI), side by side.

For every family and size it exports the benchmark problem with `puzzlebot-gate export`, times
the Rust gate (`puzzlebot-gate time`, model construction included) and the CVXPY peer
(`peer_cvxpy.py`: construction + CVXPY compile + Clarabel solve) one after the other, so both
see the same machine load, and prints one table: medians of wall-clock and CPU time, time per
module, the §9 target and the ratio to CVXPY (goal ≥ 5×).

Usage (from the repository root):
    cargo build --release -p puzzlebot-stability --bin puzzlebot-gate
    pip install cvxpy clarabel
    python3 bench/stability/compare.py                       # 10, 100, 1000 modules
    python3 bench/stability/compare.py --sizes 10 100 1000 10000 --families chain --no-peer

The gate binary is looked up in $CARGO_TARGET_DIR/release, then target/release (or --gate).
"""

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

# DESIGN.md §9: 100 modules ≤ 5 ms, 1,000 modules ≤ 50 ms, time per module flat.
TARGET_MS = {100: 5.0, 1000: 50.0}
PEER_GOAL = 5.0

LINE = re.compile(
    r"n=(?P<n>\d+) verdict=(?P<verdict>[a-z -]+?) w_max=(?P<w>\S+) best (?P<best>\S+) ms "
    r"median (?P<median>\S+) ms cpu median (?P<cpu>\S+) ms .* path=(?P<path>\S+) "
    r"iters=(?P<iters>\d+)"
)


def find_gate(explicit):
    if explicit:
        return explicit
    for d in [os.environ.get("CARGO_TARGET_DIR"), "target"]:
        if d:
            p = os.path.join(d, "release", "puzzlebot-gate")
            if os.path.exists(p):
                return p
    sys.exit("puzzlebot-gate not found: cargo build --release -p puzzlebot-stability "
             "--bin puzzlebot-gate (or pass --gate)")


def time_gate(gate, path, repeat):
    out = subprocess.run([gate, "time", path, "--repeat", str(repeat)],
                         check=True, capture_output=True, text=True).stdout
    m = LINE.search(out)
    if not m:
        sys.exit(f"unexpected output of puzzlebot-gate time: {out!r}")
    return m


def time_peer(path, repeat):
    try:
        import peer_cvxpy  # imported lazily: --no-peer works without cvxpy
    except ImportError as e:
        sys.exit(f"the CVXPY peer needs `pip install cvxpy clarabel` ({e}); or pass --no-peer")

    with open(path) as fh:
        a = json.load(fh)
    wall, cpu = [], []
    status, w = None, float("nan")
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        status, w = peer_cvxpy.build_and_solve(a)
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    med = lambda v: sorted(v)[len(v) // 2] * 1e3
    return status, w, med(wall), med(cpu)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--families", nargs="+", default=["chain", "mesh", "tree-ground", "tree-hanging"])
    ap.add_argument("--sizes", nargs="+", type=int, default=[10, 100, 1000])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--peer-repeat", type=int, default=3)
    ap.add_argument("--no-peer", action="store_true")
    ap.add_argument("--gate")
    args = ap.parse_args()
    gate = find_gate(args.gate)
    tmp = tempfile.mkdtemp(prefix="gate-bench-")
    print(f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())} "
          f"({os.cpu_count()} cores)")
    head = (f"{'family':<13}{'n':>6} {'path':<16}{'it':>3} {'wall ms':>9} {'cpu ms':>9} "
            f"{'µs/mod':>7} {'§9 target':<15}")
    if not args.no_peer:
        head += f" {'cvxpy wall':>10} {'cvxpy cpu':>10} {'× cpu':>6} {'× wall':>6}  ≥5×"
    print(head)
    for fam in args.families:
        for n in args.sizes:
            path = os.path.join(tmp, f"{fam}-{n}.json")
            subprocess.run([gate, "export", fam, str(n), path], check=True)
            m = time_gate(gate, path, args.repeat)
            wall, cpu = float(m["median"]), float(m["cpu"])
            target = TARGET_MS.get(n)
            tgt = (f"≤{target:g} ms {'met' if cpu <= target else 'MISSED'}" if target else "-")
            row = (f"{fam:<13}{n:>6} {m['path']:<16}{m['iters']:>3} {wall:>9.3f} {cpu:>9.3f} "
                   f"{cpu * 1e3 / n:>7.1f} {tgt:<15}")
            if not args.no_peer:
                status, w, pw, pc = time_peer(path, args.peer_repeat)
                wg = float(m["w"])
                agree = abs(w - wg) <= 1e-4 * (1 + abs(wg)) or m["verdict"] != "stable"
                row += (f" {pw:>10.1f} {pc:>10.1f} {pc / cpu:>6.1f} {pw / wall:>6.1f}  "
                        f"{'yes' if pc / cpu >= PEER_GOAL else 'NO'}"
                        f"{'' if agree else f'  (w_max differs: {wg} vs {w}, {status})'}")
            print(row, flush=True)
    print(f"load average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
