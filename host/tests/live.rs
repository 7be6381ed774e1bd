//! `--live`: the replay page served on a loopback port streams a real-time run while it goes.
//! A client connects over 127.0.0.1, reads the page and the event stream, and sees samples
//! arrive before the run ends, the robots moving in them, and the end of the run.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use puzzlebot_host::assemble::{parse_scenario, run_scenario, scattered_fleet};
use puzzlebot_host::live::Live;
use puzzlebot_host::record::RunInfo;
use serde_json::Value;

/// One HTTP/1.0 GET over loopback (the body ends when the server closes the connection).
fn request(addr: SocketAddr, path: &str) -> TcpStream {
    let mut s = TcpStream::connect(addr).expect("connect over loopback");
    s.set_read_timeout(Some(Duration::from_secs(60)))
        .expect("read timeout");
    write!(s, "GET {path} HTTP/1.0\r\nHost: {addr}\r\n\r\n").expect("send the request");
    s
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_live_page_streams_the_run_while_it_goes() {
    let runs = std::env::temp_dir().join(format!("pb-live-{}", std::process::id()));
    let sim = scattered_fleet(2, 0, 1);
    let live = Live::serve(&RunInfo::of_simulator(&sim), "a live run", 0)
        .await
        .expect("serve on loopback");
    let addr = live.addr();
    assert!(addr.ip().is_loopback(), "{addr}");
    assert_eq!(live.url(), format!("http://{addr}/"));

    // The page is the replay page with the stream's address and both robots' bodies.
    let page = tokio::task::spawn_blocking(move || {
        let mut page = String::new();
        request(addr, "/")
            .read_to_string(&mut page)
            .expect("read the page");
        page
    })
    .await
    .unwrap();
    assert!(
        page.starts_with("HTTP/1"),
        "{}",
        &page[..40.min(page.len())]
    );
    assert!(page.contains("PuzzleBot replay"), "the replay page");
    assert!(
        page.contains("\"live\":\"events\""),
        "the page knows its stream"
    );
    assert!(page.contains("new EventSource(D.live)"));
    assert_eq!(
        page.matches("\"kind\":\"NonPilot\"").count(),
        2,
        "two bodies"
    );

    // A page reads the stream while the run goes: each sample with whether the run was over.
    let done = Arc::new(AtomicBool::new(false));
    let seen = Arc::clone(&done);
    let reader = tokio::task::spawn_blocking(move || {
        let mut samples: Vec<(Value, bool)> = Vec::new();
        let mut ended = false;
        for line in BufReader::new(request(addr, "/events")).lines() {
            let line = line.expect("the stream stays open while the run goes");
            if let Some(data) = line.strip_prefix("data: ").filter(|d| !d.is_empty()) {
                let sample = serde_json::from_str(data).expect("a sample is JSON");
                samples.push((sample, seen.load(Ordering::SeqCst)));
            }
            if line == "event: end" {
                ended = true;
                break;
            }
        }
        (samples, ended)
    });
    let text = "name = \"drive\"\n[[step]]\nmove = { velocity = [0.05, 0.0], duration_s = 3 }\n";
    let scenario = parse_scenario("drive", text).expect("scenario");
    let report = run_scenario(scenario, sim, &runs, 20.0, None)
        .await
        .expect("the run");
    done.store(true, Ordering::SeqCst);
    live.finish().await;
    let (samples, ended) = tokio::time::timeout(Duration::from_secs(30), reader)
        .await
        .expect("the stream ends with the run")
        .unwrap();
    assert!(ended, "the page is told the run ended");
    let during = samples.iter().filter(|(_, after)| !after).count();
    assert!(
        during >= 20,
        "{during} samples arrived while the run went ({} in all)",
        samples.len()
    );
    let samples: Vec<Value> = samples.into_iter().map(|(s, _)| s).collect();

    // The samples are the run's: 10 Hz, in time order, both robots, driving.
    let t: Vec<f64> = samples.iter().map(|s| s["t"].as_f64().unwrap()).collect();
    assert!(t.windows(2).all(|w| w[1] > w[0]), "time order: {t:?}");
    assert!(
        t.windows(2).all(|w| w[1] - w[0] < 0.5),
        "about 10 Hz: {t:?}"
    );
    let x = |s: &Value, id: &str| s["poses"][id][0].as_f64();
    let first = samples.iter().find(|s| x(s, "1").is_some()).unwrap();
    let last = samples.iter().rev().find(|s| x(s, "1").is_some()).unwrap();
    for id in ["1", "2"] {
        let at = |s: &Value| (x(s, id).unwrap(), s["poses"][id][1].as_f64().unwrap());
        let (a, b) = (at(first), at(last));
        let moved = (b.0 - a.0).hypot(b.1 - a.1);
        assert!(moved > 0.05, "robot {id} drove {moved:.3} m");
    }
    assert!(samples[0]["progress"]
        .as_str()
        .unwrap()
        .starts_with("step 1/1"));
    assert!(report.folder.is_dir());
    let _ = std::fs::remove_dir_all(&runs);
}
