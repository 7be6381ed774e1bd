//! The program's structure: cone blocks, level rows and the block pattern of the normal
//! matrix, found once per program.

use super::{Block, Declined, Ipm, IpmInfo, Level, SocCone, NONE, STATIC_REG};
use crate::blockchol::{BlockCholesky, B};
use crate::socp::Program;
use clarabel::solver::SupportedConeT;

impl<'a> Ipm<'a> {
    pub(super) fn new(p: &'a Program) -> Result<Self, Declined> {
        let nx = p.a.m;
        let meq = p.a.n;
        let nlev = p.conns.len();
        if meq < nlev || !(meq - nlev).is_multiple_of(B) {
            return Err(Declined::Structure("row layout"));
        }
        let neq = meq - nlev;
        let nnode = neq / B;
        // Rows of A per unknown (A is given transposed: column j of p.a = row j of A).
        let mut cnt = vec![0usize; nx + 1];
        for (k, &v) in p.a.rowval.iter().enumerate() {
            if p.a.nzval[k] != 0.0 {
                cnt[v + 1] += 1;
            }
        }
        for v in 0..nx {
            cnt[v + 1] += cnt[v];
        }
        let mut fill = cnt.clone();
        let mut rows = vec![(0u32, 0.0f64); cnt[nx]];
        for j in 0..meq {
            for k in p.a.colptr[j]..p.a.colptr[j + 1] {
                let val = p.a.nzval[k];
                if val != 0.0 {
                    let v = p.a.rowval[k];
                    rows[fill[v]] = (j as u32, val);
                    fill[v] += 1;
                }
            }
        }
        // Cone blocks.
        let mut blocks = Vec::new();
        let mut nn_ranges = Vec::new();
        let mut start = 0;
        let mut wmax = None;
        for cone in &p.cones {
            if let SupportedConeT::NonnegativeConeT(n) = cone {
                nn_ranges.push(start..start + n);
            }
            let (dims, soc): (Vec<usize>, bool) = match cone {
                SupportedConeT::NonnegativeConeT(n) => (vec![1; *n], false),
                SupportedConeT::SecondOrderConeT(d) => (vec![*d], true),
                _ => return Err(Declined::Structure("cone type")),
            };
            for dim in dims {
                let mut nodes = [NONE; 2];
                let mut nn = 0;
                let mut level = None;
                let mut nlevels = 0;
                for v in start..start + dim {
                    for &(r, _) in &rows[cnt[v]..cnt[v + 1]] {
                        let r = r as usize;
                        if r >= neq {
                            if level != Some(r - neq) {
                                nlevels += 1;
                            }
                            level = Some(r - neq);
                        } else {
                            let node = r / B;
                            if !nodes[..nn].contains(&node) {
                                if nn == 2 {
                                    return Err(Declined::Structure("a cone on three modules"));
                                }
                                nodes[nn] = node;
                                nn += 1;
                            }
                        }
                    }
                }
                let on_every_level = nlevels == nlev
                    && nn == 0
                    && rows[cnt[start]..cnt[start + dim]].iter().all(|e| e.1 > 0.0);
                if nlevels > 1 || (on_every_level && !soc && wmax.is_none()) {
                    // w_A^max: one nonnegative unknown on every level row (coefficient +1).
                    if soc || nn > 0 || wmax.is_some() {
                        return Err(Declined::Structure("a cone on several level rows"));
                    }
                    let mut coef = vec![0.0; nlev];
                    for &(r, val) in &rows[cnt[start]..cnt[start + 1]] {
                        coef[r as usize - neq] += val;
                    }
                    wmax = Some((start, coef));
                    start += dim;
                    continue;
                }
                blocks.push(Block {
                    start,
                    dim,
                    soc,
                    nodes,
                    nnode: nn,
                    level,
                    level_pos: [0; 2],
                    a_off: 0,
                    p_off: 0,
                    diag: [None; 2],
                    off: None,
                });
                start += dim;
            }
        }
        if start != nx {
            return Err(Declined::Structure("cones do not cover the unknowns"));
        }
        // Levels: the modules of their blocks.
        let mut levels: Vec<Level> = (0..nlev)
            .map(|_| Level {
                t: NONE,
                head: NONE,
                nodes: [NONE; 2],
                nnode: 0,
                diag: [None; 2],
                off: None,
            })
            .collect();
        for blk in &blocks {
            if let Some(l) = blk.level {
                let lev = &mut levels[l];
                for &node in &blk.nodes[..blk.nnode] {
                    if !lev.nodes[..lev.nnode].contains(&node) {
                        if lev.nnode == 2 {
                            return Err(Declined::Structure("a level row on three modules"));
                        }
                        lev.nodes[lev.nnode] = node;
                        lev.nnode += 1;
                    }
                }
            }
        }
        let mut edges = Vec::new();
        for blk in &blocks {
            if blk.nnode == 2 {
                edges.push((blk.nodes[0], blk.nodes[1]));
            }
        }
        for lev in &levels {
            if lev.nnode == 2 {
                edges.push((lev.nodes[0], lev.nodes[1]));
            }
        }
        let chol = BlockCholesky::new(nnode, &edges);
        // Local dense A of every block, its level positions and slots.
        let mut local_a = Vec::with_capacity(blocks.iter().map(|b| b.rows() * b.dim).sum());
        for blk in &mut blocks {
            blk.a_off = local_a.len();
            let nr = blk.rows();
            local_a.resize(local_a.len() + nr * blk.dim, 0.0);
            for c in 0..blk.dim {
                let v = blk.start + c;
                for &(r, val) in &rows[cnt[v]..cnt[v + 1]] {
                    let r = r as usize;
                    let lr = if r >= neq {
                        B * blk.nnode
                    } else {
                        let a = blk.nodes[..blk.nnode].iter().position(|&n| n == r / B);
                        B * a.unwrap_or(0) + r % B
                    };
                    local_a[blk.a_off + c * nr + lr] += val;
                }
            }
            for a in 0..blk.nnode {
                blk.diag[a] = chol.slot(blk.nodes[a], blk.nodes[a]);
            }
            if blk.nnode == 2 {
                blk.off = chol.slot(blk.nodes[0], blk.nodes[1]);
            }
            if let Some(l) = blk.level {
                let lev = &levels[l];
                for a in 0..blk.nnode {
                    blk.level_pos[a] = lev.nodes[..lev.nnode]
                        .iter()
                        .position(|&n| n == blk.nodes[a])
                        .unwrap_or(0);
                }
            }
        }
        for lev in &mut levels {
            for a in 0..lev.nnode {
                lev.diag[a] = chol.slot(lev.nodes[a], lev.nodes[a]);
            }
            if lev.nnode == 2 {
                lev.off = chol.slot(lev.nodes[0], lev.nodes[1]);
            }
        }
        // Each level row: exactly one slack t (nonnegative, on no module) and one head.
        for (bi, blk) in blocks.iter().enumerate() {
            let Some(l) = blk.level else { continue };
            let lev = &mut levels[l];
            let nr = blk.rows();
            let la = &local_a[blk.a_off..blk.a_off + nr * blk.dim];
            if !blk.soc && blk.nnode == 0 && lev.t == NONE {
                lev.t = bi;
            } else if lev.head == NONE {
                if blk.soc {
                    // Level coefficient on the first entry only, which is on no module row.
                    let lr = nr - 1;
                    let level_only_head = (0..nr - 1).all(|r| la[r] == 0.0)
                        && (1..blk.dim).all(|c| la[c * nr + lr] == 0.0)
                        && la[lr] != 0.0;
                    if !level_only_head {
                        return Err(Declined::Structure("a strength cone's level row"));
                    }
                }
                lev.head = bi;
            } else {
                return Err(Declined::Structure("a level row with several heads"));
            }
        }
        if levels.iter().any(|l| l.t == NONE || l.head == NONE) {
            return Err(Declined::Structure("a level row without its slack or head"));
        }
        // Constant parts of every block's contribution (module rows only).
        let mut pre = Vec::with_capacity(
            blocks
                .iter()
                .filter(|b| b.soc)
                .map(|b| (B * b.nnode).pow(2))
                .sum(),
        );
        for blk in &mut blocks {
            let nm = B * blk.nnode;
            blk.p_off = pre.len();
            if nm == 0 || !blk.soc {
                continue; // a nonnegative unknown's a aᵀ is rank one: built from a directly
            }
            let nr = blk.rows();
            let la = &local_a[blk.a_off..blk.a_off + nr * blk.dim];
            // Column signs: F Fᵀ for a strength cone head (its column 0 is on the level row
            // only), A J Aᵀ for any other cone.
            let head = blk.level.is_some();
            let mut sign = [if head { 1.0 } else { -1.0 }; 8];
            sign[0] = if head { 0.0 } else { 1.0 };
            let base = pre.len();
            pre.resize(base + nm * nm, 0.0);
            let pm = &mut pre[base..];
            for c in 0..blk.dim {
                if sign[c] == 0.0 {
                    continue;
                }
                let col = &la[c * nr..c * nr + nm];
                for r in 0..nm {
                    let f = sign[c] * col[r];
                    if f != 0.0 {
                        for q in 0..nm {
                            pm[r * nm + q] += f * col[q];
                        }
                    }
                }
            }
        }
        let nblk = blocks.len();
        let soc_blocks = (0..nblk)
            .filter(|&b| blocks[b].soc)
            .map(|b| SocCone {
                start: blocks[b].start,
                dim: blocks[b].dim,
                block: b,
            })
            .collect();
        Ok(Ipm {
            p,
            nx,
            neq,
            nlev,
            blocks,
            nn_ranges,
            soc_blocks,
            local_a,
            pre,
            levels,
            wmax,
            chol,
            b: p.q.iter().map(|v| -v).collect(),
            c: p.b.clone(),
            w: vec![1.0; nx],
            eta: vec![1.0; nblk],
            lambda: vec![0.0; nx],
            g: vec![0.0; nlev],
            h: vec![0.0; nlev * 2 * B],
            pf_p: vec![0.0; neq + nlev],
            pf_pp: 0.0,
            d_wmax: 0.0,
            reg: STATIC_REG,
            work: IpmInfo::default(),
            tmp_e: vec![0.0; neq],
            tmp_v: vec![0.0; neq + nlev],
            tmp_rhs: vec![0.0; neq + nlev],
            tmp_res: vec![0.0; neq + nlev],
            tmp_corr: vec![0.0; neq + nlev],
        })
    }
}
