#!/usr/bin/env python3
"""Peer benchmark for the stability gate: the same problem (SOCP (41) without connector
limits, which is what the Rust gate solves for assemblies within their limits) built with
CVXPY and solved by Clarabel (PyPI), model construction included.

Usage:
    pip install cvxpy clarabel
    cargo run --release -p puzzlebot-stability --bin puzzlebot-gate -- export chain 100 /tmp/chain-100.json
    python3 bench/stability/peer_cvxpy.py /tmp/chain-100.json [--repeat 3]

Times: wall clock (best and median) and the process CPU time (median, all threads: the PyPI
Clarabel may factorise with multi-threaded faer), to compare with `puzzlebot-gate time`, which
prints the same figures for the Rust gate.

Supports the subset of the file format the benchmark families use: box connectors, modules
(rpy, com, fixed), environmental contacts (isotropic or anisotropic μ, μ = 0 frictionless),
gravity. Prints the time (construction + CVXPY compile + solve) and w_A^max for cross-checking.
"""

import argparse
import json
import time

import numpy as np
import scipy.sparse as sp
import cvxpy as cp


def rot_rpy(r, p, y):
    sr, cr = np.sin(r), np.cos(r)
    sp_, cp_ = np.sin(p), np.cos(p)
    sy, cy = np.sin(y), np.cos(y)
    return np.array([
        [cy * cp_, cy * sp_ * sr - sy * cr, cy * sp_ * cr + sy * sr],
        [sy * cp_, sy * sp_ * sr + cy * cr, sy * sp_ * cr - cy * sr],
        [-sp_, cp_ * sr, cp_ * cr],
    ])


def frame_from_z(z, hint=None):
    z = np.asarray(z, float)
    z = z / np.linalg.norm(z)
    for h in ([hint] if hint is not None else []) + [[0, 0, 1], [1, 0, 0], [0, 1, 0]]:
        h = np.asarray(h, float)
        x = h - z * (h @ z)
        if np.linalg.norm(x) > 1e-6:
            x /= np.linalg.norm(x)
            return np.column_stack([x, np.cross(z, x), z])
    raise ValueError("degenerate frame")


def build_and_solve(a):
    g = np.asarray(a.get("gravity", [0, 0, -9.81]), float)
    mods = a["modules"]
    idx = {m["id"]: i for i, m in enumerate(mods)}
    n = len(mods)
    com = np.zeros((n, 3))
    fixed = np.zeros(n, bool)
    mass = np.zeros(n)
    for i, m in enumerate(mods):
        R = rot_rpy(*m.get("rpy", [0, 0, 0]))
        com[i] = np.asarray(m["position"], float) + R @ np.asarray(m.get("com", [0, 0, 0]), float)
        fixed[i] = m.get("fixed", False)
        mass[i] = m["mass"]
    eq_row = -np.ones(n, int)
    free = np.flatnonzero(~fixed)
    eq_row[free] = 6 * np.arange(len(free))
    neq = 6 * len(free)

    rows, cols, vals = [], [], []

    def add_eq(module, col, axis, couple, point, s):
        r0 = eq_row[module]
        if r0 < 0:
            return
        if couple:
            for d in range(3):
                rows.append(r0 + 3 + d); cols.append(col); vals.append(s * axis[d])
        else:
            mo = np.cross(point - com[module], axis)
            for d in range(3):
                rows.append(r0 + d); cols.append(col); vals.append(s * axis[d])
                rows.append(r0 + 3 + d); cols.append(col); vals.append(s * mo[d])

    conns = a.get("connections", [])
    specs = a.get("connectors", {})
    nc = len(conns)
    # connection variables: fx fy fcon fs mx my mz per connection
    omega = np.ones((nc, 6))
    for k, c in enumerate(conns):
        ch, pa = idx[c["child"]], idx[c["parent"]]
        spec = specs[c["connector"]]
        if spec.get("kind") != "box":
            raise SystemExit("peer supports box connectors only")
        omega[k] = spec.get("omega_k", [1.0] * 6)
        p = np.asarray(c["point"], float)
        z = c.get("axis") or (com[ch] - p)
        F = frame_from_z(z, c.get("x_axis"))
        base = 7 * k
        slot_axis = [(F[:, 0], False), (F[:, 1], False), (F[:, 2], False), (F[:, 2], False),
                     (F[:, 0], True), (F[:, 1], True), (F[:, 2], True)]
        for s, (ax, cpl) in enumerate(slot_axis):
            add_eq(ch, base + s, ax, cpl, p, 1.0)
            add_eq(pa, base + s, ax, cpl, p, -1.0)
    cts = a.get("contacts", [])
    ncv = 7 * nc
    mu = np.zeros((len(cts), 2))
    for j, c in enumerate(cts):
        m = idx[c["module"]]
        p = np.asarray(c["point"], float)
        F = frame_from_z(c.get("normal") or [0, 0, 1], c.get("x_axis") or [1, 0, 0])
        mu[j] = c["mu"]
        for s, ax in enumerate([F[:, 2], F[:, 0], F[:, 1]]):
            add_eq(m, ncv + 3 * j + s, ax, False, p, 1.0)
    nx = ncv + 3 * len(cts)
    Z = sp.csc_matrix((vals, (rows, cols)), shape=(neq, nx))
    b = np.zeros(neq)
    for i in free:
        b[eq_row[i]:eq_row[i] + 3] = -mass[i] * g

    x = cp.Variable(nx)
    cons = [Z @ x == b]
    obj = 0
    if nc:
        C = x[:ncv]
        fx, fy, fcon, fs = C[0::7], C[1::7], C[2::7], C[3::7]
        mx, my, mz = C[4::7], C[5::7], C[6::7]
        wc = cp.Variable(nc)
        w = cp.Variable()
        wr = cp.vstack([cp.multiply(omega[:, 0], fx), cp.multiply(omega[:, 1], fy),
                        cp.multiply(omega[:, 2], fcon), cp.multiply(omega[:, 3], mx),
                        cp.multiply(omega[:, 4], my), cp.multiply(omega[:, 5], mz)])
        cons += [cp.SOC(wc, wr, axis=0), wc <= w, fs >= 0, fcon <= 0]
        lam = a.get("objective", {})
        obj += lam.get("lambda_max", 1e4) * w + lam.get("lambda_sum", 1.0) * cp.sum(wc)
    if len(cts):
        T = x[ncv:]
        fz, f1, f2 = T[0::3], T[1::3], T[2::3]
        fr = mu[:, 0] > 0
        nf = ~fr
        if fr.any():
            sel = np.flatnonzero(fr)
            cons.append(cp.SOC(fz[sel], cp.vstack([cp.multiply(1 / mu[sel, 0], f1[sel]),
                                                   cp.multiply(1 / mu[sel, 1], f2[sel])]), axis=0))
        if nf.any():
            sel = np.flatnonzero(nf)
            cons += [fz[sel] >= 0, f1[sel] == 0, f2[sel] == 0]
        obj += a.get("objective", {}).get("lambda_contacts", 1.0) * cp.sum(fz)
    prob = cp.Problem(cp.Minimize(obj), cons)
    prob.solve(solver=cp.CLARABEL)
    wmax = float(w.value) if nc else float("nan")
    return prob.status, wmax


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("files", nargs="+")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    for f in args.files:
        with open(f) as fh:
            a = json.load(fh)
        times = []
        cpu = []
        for _ in range(args.repeat):
            t = time.perf_counter()
            c = time.process_time()
            status, wmax = build_and_solve(a)
            times.append(time.perf_counter() - t)
            cpu.append(time.process_time() - c)
        n = len(a["modules"])
        best = min(times)
        print(f"{f}: n={n} status={status} w_max={wmax:.6g} best {best * 1e3:.3f} ms "
              f"median {sorted(times)[len(times) // 2] * 1e3:.3f} ms "
              f"cpu median {sorted(cpu)[len(cpu) // 2] * 1e3:.3f} ms "
              f"({best * 1e6 / n:.1f} µs/module)", flush=True)


if __name__ == "__main__":
    main()
