//! Symbolic analysis: fill-reducing ordering, elimination tree, block column structures of L,
//! fundamental supernodes, panel layout and the relative positions of every update.

use super::{BlockCholesky, Segment, B, BB};

impl BlockCholesky {
    /// Symbolic analysis of the block graph with `n` nodes and off-diagonal blocks `edges`.
    pub fn new(n: usize, edges: &[(usize, usize)]) -> Self {
        // Graph (CSR, symmetric, sorted, deduplicated).
        let mut deg = vec![0usize; n + 1];
        for &(i, j) in edges {
            assert!(i < n && j < n && i != j, "bad edge ({i}, {j}) for n = {n}");
            deg[i] += 1;
            deg[j] += 1;
        }
        let mut ptr = vec![0usize; n + 1];
        for i in 0..n {
            ptr[i + 1] = ptr[i] + deg[i];
        }
        let mut fill = ptr.clone();
        let mut idx = vec![0usize; ptr[n]];
        for &(i, j) in edges {
            idx[fill[i]] = j;
            fill[i] += 1;
            idx[fill[j]] = i;
            fill[j] += 1;
        }
        let mut adj_ptr = vec![0usize; n + 1];
        let mut adj_idx = Vec::with_capacity(idx.len());
        for i in 0..n {
            let list = &mut idx[ptr[i]..ptr[i + 1]];
            list.sort_unstable();
            let mut last = usize::MAX;
            for &j in list.iter() {
                if j != last {
                    adj_idx.push(j);
                    last = j;
                }
            }
            adj_ptr[i + 1] = adj_idx.len();
        }
        let nbrs = |i: usize| &adj_idx[adj_ptr[i]..adj_ptr[i + 1]];

        // Fill-reducing ordering, then a postorder of its elimination tree.
        let amd_order: Vec<usize> = if n > 1 {
            // The pattern given to AMD includes the diagonal (its debug checks expect nz ≥ n).
            let mut ap = vec![0usize; n + 1];
            let mut ai = Vec::with_capacity(adj_idx.len() + n);
            for i in 0..n {
                let list = nbrs(i);
                let k = list.partition_point(|&j| j < i);
                ai.extend_from_slice(&list[..k]);
                ai.push(i);
                ai.extend_from_slice(&list[k..]);
                ap[i + 1] = ai.len();
            }
            match amd::order::<usize>(n, &ap, &ai, &amd::Control::default()) {
                Ok((p, _, _)) => p,
                Err(_) => (0..n).collect(),
            }
        } else {
            (0..n).collect()
        };
        let parent0 = etree(n, &amd_order, &invert(&amd_order), &nbrs);
        let post = postorder(&parent0);
        let perm: Vec<usize> = post.iter().map(|&k| amd_order[k]).collect();
        let iperm = invert(&perm);
        let parent = etree(n, &perm, &iperm, &nbrs);

        // Block column structures of L (rows below the diagonal, sorted).
        let mut head = vec![usize::MAX; n];
        let mut next = vec![usize::MAX; n];
        for j in (0..n).rev() {
            let p = parent[j];
            if p != usize::MAX {
                next[j] = head[p];
                head[p] = j;
            }
        }
        let mut mark = vec![usize::MAX; n];
        let mut cols: Vec<Vec<usize>> = Vec::with_capacity(n);
        for j in 0..n {
            let mut s = Vec::new();
            mark[j] = j;
            for &o in nbrs(perm[j]) {
                let i = iperm[o];
                if i > j && mark[i] != j {
                    mark[i] = j;
                    s.push(i);
                }
            }
            let mut c = head[j];
            while c != usize::MAX {
                for &i in &cols[c] {
                    if mark[i] != j {
                        mark[i] = j;
                        s.push(i);
                    }
                }
                c = next[c];
            }
            s.sort_unstable();
            cols.push(s);
        }

        // Fundamental supernodes.
        let mut sn_first = vec![0usize];
        for j in 1..n {
            if !(parent[j - 1] == j && cols[j - 1].len() == cols[j].len() + 1) {
                sn_first.push(j);
            }
        }
        if n == 0 {
            sn_first.clear();
        }
        sn_first.push(n);
        let ns = sn_first.len() - 1;
        let mut snode_of = vec![0usize; n];
        let mut rows_ptr = vec![0usize; ns + 1];
        let mut rows = Vec::new();
        let mut sn_off = vec![0usize; ns + 1];
        let mut flops = 0.0;
        let mut nnz_l = 0usize;
        for s in 0..ns {
            let (f, l) = (sn_first[s], sn_first[s + 1]);
            for c in snode_of.iter_mut().take(l).skip(f) {
                *c = s;
            }
            rows.extend_from_slice(&cols[l - 1]);
            rows_ptr[s + 1] = rows.len();
            let nc = l - f;
            let nr = nc + cols[l - 1].len();
            sn_off[s + 1] = sn_off[s] + BB * nr * nc;
            let (kk, rr) = (B * nc, B * (nr - nc));
            nnz_l += kk * (kk + 1) / 2 + kk * rr;
            for k in 0..kk {
                let c = (kk - k + rr) as f64;
                flops += c * c;
            }
        }
        drop(cols);

        // Relative positions of every supernode's update rows in its ancestors' panels.
        let mut seg_ptr = vec![0usize; ns + 1];
        let mut segs = Vec::new();
        let mut relmap = Vec::new();
        for s in 0..ns {
            let r = &rows[rows_ptr[s]..rows_ptr[s + 1]];
            let mut a = 0;
            while a < r.len() {
                let t = snode_of[r[a]];
                let (ft, lt) = (sn_first[t], sn_first[t + 1]);
                let mut end = a;
                while end < r.len() && r[end] < lt {
                    end += 1;
                }
                let map = relmap.len();
                for &i in &r[a..end] {
                    relmap.push((i - ft) as u32);
                }
                let rt = &rows[rows_ptr[t]..rows_ptr[t + 1]];
                let mut p = 0;
                for &i in &r[end..] {
                    while rt[p] < i {
                        p += 1;
                    }
                    debug_assert_eq!(rt[p], i);
                    relmap.push((lt - ft + p) as u32);
                }
                segs.push(Segment {
                    target: t,
                    start: a,
                    end,
                    map,
                });
                a = end;
            }
            seg_ptr[s + 1] = segs.len();
        }

        // Slots: diagonal i is slot i, edges get n, n + 1, ... (once per undirected edge).
        let mut adj_slot = vec![u32::MAX; adj_idx.len()];
        let mut dest: Vec<(usize, usize)> = Vec::with_capacity(n + adj_idx.len() / 2);
        let place = |row: usize, col: usize| -> (usize, usize) {
            let s = snode_of[col];
            let (f, l) = (sn_first[s], sn_first[s + 1]);
            let r = &rows[rows_ptr[s]..rows_ptr[s + 1]];
            let ld = B * (l - f + r.len());
            let pos = if row < l {
                row - f
            } else {
                l - f + r.binary_search(&row).expect("row in structure")
            };
            (sn_off[s] + B * (col - f) * ld + B * pos, ld)
        };
        for &pj in &iperm {
            dest.push(place(pj, pj));
        }
        for i in 0..n {
            for e in adj_ptr[i]..adj_ptr[i + 1] {
                let j = adj_idx[e];
                if i < j {
                    let id = dest.len() as u32;
                    adj_slot[e] = id;
                    let (pi, pj) = (iperm[i], iperm[j]);
                    dest.push(place(pi.max(pj), pi.min(pj)));
                    // Mirror entry in j's list.
                    let lj = &adj_idx[adj_ptr[j]..adj_ptr[j + 1]];
                    let k = lj.binary_search(&i).expect("symmetric graph");
                    adj_slot[adj_ptr[j] + k] = id;
                }
            }
        }
        let nslots = dest.len();
        BlockCholesky {
            n,
            perm,
            iperm,
            adj_ptr,
            adj_idx,
            adj_slot,
            vals: vec![0.0; BB * nslots],
            dest,
            sn_first,
            rows_ptr,
            rows,
            lx: vec![0.0; sn_off[ns]],
            sn_off,
            seg_ptr,
            segs,
            relmap,
            work: vec![0.0; B * n],
            flops,
            nnz_l,
        }
    }
}

fn invert(p: &[usize]) -> Vec<usize> {
    let mut ip = vec![0; p.len()];
    for (k, &i) in p.iter().enumerate() {
        ip[i] = k;
    }
    ip
}

/// Elimination tree of the graph in the order `perm` (Liu's algorithm, path compression).
fn etree<'a>(
    n: usize,
    perm: &[usize],
    iperm: &[usize],
    nbrs: &impl Fn(usize) -> &'a [usize],
) -> Vec<usize> {
    let mut parent = vec![usize::MAX; n];
    let mut ancestor = vec![usize::MAX; n];
    for (k, &pk) in perm.iter().enumerate() {
        for &o in nbrs(pk) {
            let mut j = iperm[o];
            if j >= k {
                continue;
            }
            while ancestor[j] != usize::MAX && ancestor[j] != k {
                let nx = ancestor[j];
                ancestor[j] = k;
                j = nx;
            }
            if ancestor[j] == usize::MAX {
                ancestor[j] = k;
                parent[j] = k;
            }
        }
    }
    parent
}

/// Postorder of a forest: `post[k]` is the k-th node visited.
fn postorder(parent: &[usize]) -> Vec<usize> {
    let n = parent.len();
    let mut head = vec![usize::MAX; n];
    let mut next = vec![usize::MAX; n];
    for j in (0..n).rev() {
        let p = parent[j];
        if p != usize::MAX {
            next[j] = head[p];
            head[p] = j;
        }
    }
    let mut post = Vec::with_capacity(n);
    let mut stack = Vec::new();
    for (root, &p) in parent.iter().enumerate() {
        if p != usize::MAX {
            continue;
        }
        stack.push(root);
        while let Some(&j) = stack.last() {
            let c = head[j];
            if c == usize::MAX {
                stack.pop();
                post.push(j);
            } else {
                head[j] = next[c];
                stack.push(c);
            }
        }
    }
    post
}
