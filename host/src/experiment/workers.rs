//! A fixed pool of worker threads over a list of jobs, for the experiments' independent runs.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// `f` of every item on `threads` workers (0: one per core), the results in the items' order;
/// `on_done` after each.
pub fn map_parallel<T: Sync, R: Send>(
    items: &[T],
    threads: usize,
    f: &(dyn Fn(&T) -> R + Sync),
    on_done: &(dyn Fn() + Sync),
) -> Vec<R> {
    let threads = match threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    }
    .min(items.len().max(1));
    let next = AtomicUsize::new(0);
    let out: Mutex<Vec<(usize, R)>> = Mutex::new(Vec::with_capacity(items.len()));
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(item) = items.get(i) else { break };
                let r = f(item);
                on_done();
                if let Ok(mut v) = out.lock() {
                    v.push((i, r));
                }
            });
        }
    });
    let mut out = out.into_inner().unwrap_or_default();
    out.sort_by_key(|(i, _)| *i);
    out.into_iter().map(|(_, r)| r).collect()
}

#[cfg(test)]
mod tests {
    use super::map_parallel;

    #[test]
    fn results_come_back_in_order() {
        let items: Vec<u32> = (0..50).collect();
        let out = map_parallel(&items, 3, &|&x| x * x, &|| {});
        assert_eq!(out, items.iter().map(|x| x * x).collect::<Vec<_>>());
    }
}
