#!/usr/bin/env python3
"""CasADi + IPOPT peer of the puzzlebot-mpc robot solve.

Reads the problem instances exported by the Rust crate
(`cargo run --release -p puzzlebot-mpc --example export_instances -- bench/mpc/instances.json`)
and solves the *same* nonlinear program with IPOPT, as THESIS 5.4.4 did (CasADi + IPOPT):
Euler unicycle rollout (THESIS 5.2), point/heading costs with tan^2(dtheta/2) (4.5, 4.6, 5.25,
5.26, maintenance of 4.8), velocity fitting (4.7), smoothness (5.19) and effort, the butterfly
wing per step chosen by the Rust side, the velocity box, the acceleration box, and the
point-in-polygon (5.9/5.16) and cutting-plane (5.17/5.18) constraints on k = 1..H_c with the
same margin. Prints median wall and CPU time per solve, the optimal cost next to the Rust
costs, and the time ratio IPOPT / Clarabel-RTI.

usage: python3 bench/mpc/ipopt_peer.py [bench/mpc/instances.json] [repeats]
"""
import json
import math
import statistics
import sys
import time

import casadi as ca


def pose_yaw(pose):
    """A pose's heading (rad), stored as `yaw` or `theta`."""
    return pose["yaw"] if "yaw" in pose else pose["theta"]


def build(inst):
    h = inst["horizon"]
    hc = inst["constraint_horizon"]
    dt = inst["dt"]
    x0 = inst["x0"]
    lim = inst["limits"]
    g = inst["geometry"]
    U = ca.MX.sym("u", 2 * h)
    v = [U[2 * k] for k in range(h)]
    w = [U[2 * k + 1] for k in range(h)]
    xs = [(x0["x"], x0["y"], pose_yaw(x0))]
    for k in range(h):
        px, py, th = xs[-1]
        xs.append((px + dt * v[k] * ca.cos(th), py + dt * v[k] * ca.sin(th), th + dt * w[k]))

    def tr(pose, c):
        px, py, th = pose
        return (px + ca.cos(th) * c[0] - ca.sin(th) * c[1], py + ca.sin(th) * c[0] + ca.cos(th) * c[1])

    J = 0
    for t in inst["points"]:
        tg = t["targets"]
        for k in range(1, h + 1):
            wk = t["weights"][k] if k < len(t["weights"]) else 0.0
            if wk == 0.0:
                continue
            target = tg[min(k, len(tg) - 1)]
            p = tr(xs[k], t["point"])
            c = (p[0] - target["x"]) ** 2 + (p[1] - target["y"]) ** 2
            if t["heading"] > 0:
                c += t["heading"] * ca.tan(0.5 * (xs[k][2] + t["angle"] - pose_yaw(target))) ** 2
            J += wk * c
    for vt in inst["velocities"]:
        for k in range(h):
            J += vt["w"][0] * (v[k] - vt["target"]["v"]) ** 2 + vt["w"][1] * (w[k] - vt["target"]["omega"]) ** 2
    pv, pw = inst["u_prev"]["v"], inst["u_prev"]["omega"]
    ws, we = inst["w_smooth"], inst["w_effort"]
    for k in range(h):
        J += ws[0] * (v[k] - pv) ** 2 + ws[1] * (w[k] - pw) ** 2 + we[0] * v[k] ** 2 + we[1] * w[k] ** 2
        pv, pw = v[k], w[k]

    G, lbg, ubg = [], [], []

    def le(expr, ub):
        G.append(expr)
        lbg.append(-ca.inf)
        ubg.append(ub)

    av, aw, bv = lim["butterfly_a"][0], abs(lim["butterfly_a"][1]), lim["butterfly_b"][0]
    s1, s2 = aw / av, aw / (bv - av)
    acc = lim.get("accel_max")
    for k in range(h):
        sg = float(inst["wings"][k])
        for sw in (1.0, -1.0):
            le(sw * w[k] - s1 * sg * v[k], 0.0)
            le(sw * w[k] + s2 * sg * v[k], s2 * bv)
        if lim["v_max"] < bv:
            le(v[k], lim["v_max"]); le(-v[k], lim["v_max"])
        if lim["omega_max"] < aw:
            le(w[k], lim["omega_max"]); le(-w[k], lim["omega_max"])
        if acc is not None:
            prev_v = inst["u_prev"]["v"] if k == 0 else v[k - 1]
            prev_w = inst["u_prev"]["omega"] if k == 0 else w[k - 1]
            for s in (1.0, -1.0):
                le(s * (v[k] - prev_v), acc[0] * dt)
                le(s * (w[k] - prev_w), acc[1] * dt)

    m = inst["margin"]
    hl, hw = 0.5 * g["length"], 0.5 * g["width"]
    s_a = math.copysign(1.0, g["anchor_head"][0])
    s_o = math.copysign(1.0, g["anchor_opening"][0])
    poly = g["anchor_polygon"]

    def in_frame(a, c, b):
        p = tr(a, c)
        dx, dy = p[0] - b[0], p[1] - b[1]
        cb, sb = ca.cos(b[2]), ca.sin(b[2])
        return (cb * dx + sb * dy, -sb * dx + cb * dy)

    for cp in inst["couplings"]:
        nbs = cp["neighbour_poses"]
        for k in range(1, min(hc, h) + 1):
            nb = nbs[min(k, len(nbs) - 1)]
            nbp = (nb["x"], nb["y"], pose_yaw(nb))
            anchor, opening = (xs[k], nbp) if cp["role"] == "Anchor" else (nbp, xs[k])
            q = in_frame(anchor, g["anchor_head"], opening)
            for e in range(len(poly)):
                v0, v1 = poly[e], poly[(e + 1) % len(poly)]
                n = (v1[1] - v0[1], -(v1[0] - v0[0]))
                ln = math.hypot(*n)
                le((n[0] * (q[0] - v0[0]) + n[1] * (q[1] - v0[1])) / ln + m, 0.0)
            for sy in (-1.0, 1.0):
                c = in_frame(opening, (s_o * hl, sy * hw), anchor)
                le(-s_a * c[0] + hl + m, 0.0)
                c = in_frame(anchor, (s_a * hl, sy * hw), opening)
                le(-s_o * c[0] + hl + m, 0.0)

    nlp = {"x": U, "f": J, "g": ca.vertcat(*G)}
    opts = {"ipopt.print_level": 0, "print_time": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-8}
    solver = ca.nlpsol("mpc", "ipopt", nlp, opts)
    x_init = []
    for u in inst["guess"]:
        x_init += [u["v"], u["omega"]]
    return solver, x_init, lbg, ubg


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "bench/mpc/instances.json"
    reps = int(sys.argv[2]) if len(sys.argv) > 2 else 50
    entries = json.load(open(path))
    print(f"casadi {ca.__version__}; {reps} solves per instance")
    for e in entries:
        inst = e["instance"]
        solver, x_init, lbg, ubg = build(inst)
        walls, cpus, iters = [], [], 0
        sol = None
        for _ in range(reps):
            t0, c0 = time.perf_counter(), time.process_time()
            sol = solver(x0=x_init, lbg=lbg, ubg=ubg)
            walls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
        st = solver.stats()
        iters = st.get("iter_count", -1)
        wall = statistics.median(walls) * 1e6
        cpu = statistics.median(cpus) * 1e6
        print(
            f"couplings={e['couplings']}: IPOPT {st['return_status']}, {iters} iterations, "
            f"median wall {wall:.0f} us, CPU {cpu:.0f} us, cost {float(sol['f']):.5f} | "
            f"Clarabel RTI CPU {e['rti_cpu_median_us']:.1f} us (cost {e['rti_cost']:.5f}), "
            f"converged SQP {e['sqp_cpu_median_us']:.0f} us (cost {e['sqp_cost']:.5f}) | "
            f"ratio IPOPT/RTI {cpu / e['rti_cpu_median_us']:.0f}x, IPOPT/SQP {cpu / e['sqp_cpu_median_us']:.1f}x"
        )


if __name__ == "__main__":
    main()
