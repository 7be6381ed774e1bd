//! `--live`: the replay page served on a loopback port while a run goes, fed by server-sent
//! events. The page is the replay page ([`crate::replay::page`]) with no samples; it adds
//! every sample the server streams ([`feed`]) and follows the newest one.
//!
//! [`Live::serve`] binds 127.0.0.1 only and installs a tap the control loops call each
//! command period ([`observe`], a no-op without a live page); [`Live::finish`] sends the
//! page the end of the run and stops the server. One live page at a time per process.

pub mod feed;

use std::collections::BTreeMap;
use std::convert::Infallible;
use std::net::SocketAddr;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::Context;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::Html;
use axum::routing::get;
use puzzlebot_protocol::RobotId;
use tokio::sync::{broadcast, oneshot};

pub use feed::{Feed, LIVE_PERIOD};

use crate::config::Fleet;
use crate::record::RunInfo;
use crate::replay::{page, Progress, Timeline};

/// Path of the event stream, relative to the page.
const EVENTS: &str = "events";

/// Samples a slow client may fall behind by before it skips some.
const BACKLOG: usize = 4096;

/// Longest wait for open pages to receive the end of the run (s).
const CLOSE_WAIT_S: f64 = 1.0;

/// A message of the stream.
#[derive(Debug, Clone)]
enum Msg {
    /// One sample, as JSON text.
    Sample(Arc<str>),
    /// The run ended.
    End,
}

/// What every connection reads: the samples so far and the live ones.
struct Stream {
    /// Every sample so far (a page opened late draws the run from its start).
    history: Vec<Arc<str>>,
    /// Whether the run ended.
    ended: bool,
    /// New samples and the end.
    tx: broadcast::Sender<Msg>,
}

/// The installed tap: the feed and the stream it publishes to.
struct Tap {
    feed: Feed,
    stream: Arc<Mutex<Stream>>,
}

static SERVING: AtomicBool = AtomicBool::new(false);
static TAP: Mutex<Option<Tap>> = Mutex::new(None);

/// Called by the control loops every command period at run time `t` (s): when a live page is
/// served and a sample is due, publishes `poses()` (robot → [x, y, yaw]) and `progress()`.
pub fn observe(
    t: f64,
    poses: impl FnOnce() -> BTreeMap<RobotId, [f64; 3]>,
    progress: impl FnOnce() -> Option<Progress>,
) {
    if !SERVING.load(Ordering::Relaxed) {
        return;
    }
    let Ok(mut tap) = TAP.lock() else {
        return;
    };
    let Some(tap) = tap.as_mut() else {
        return;
    };
    if !tap.feed.due(t) {
        return;
    }
    let Some(sample) = tap.feed.sample(t, &poses(), progress().as_ref()) else {
        return;
    };
    let text: Arc<str> = sample.to_string().into();
    if let Ok(mut s) = tap.stream.lock() {
        s.history.push(Arc::clone(&text));
        // No receiver (no page open yet) is not an error: the history keeps the sample.
        let _ = s.tx.send(Msg::Sample(text));
    };
}

/// A live page being served; [`Live::finish`] ends it.
pub struct Live {
    addr: SocketAddr,
    stream: Arc<Mutex<Stream>>,
    stop: Option<oneshot::Sender<()>>,
    server: Option<tokio::task::JoinHandle<()>>,
}

impl Live {
    /// Serve the live page of a run of `info` titled `title` on 127.0.0.1:`port` (0: any free
    /// port) and start publishing what the control loops [`observe`].
    pub async fn serve(info: &RunInfo, title: &str, port: u16) -> anyhow::Result<Live> {
        let listener = tokio::net::TcpListener::bind(("127.0.0.1", port))
            .await
            .with_context(|| format!("--live: cannot listen on 127.0.0.1:{port}"))?;
        let addr = listener.local_addr()?;
        let (tx, _) = broadcast::channel(BACKLOG);
        let stream = Arc::new(Mutex::new(Stream {
            history: Vec::new(),
            ended: false,
            tx,
        }));
        {
            let mut tap = TAP
                .lock()
                .map_err(|_| anyhow::anyhow!("--live: the live tap is poisoned"))?;
            if tap.is_some() {
                anyhow::bail!("--live: this process already serves a live page");
            }
            *tap = Some(Tap {
                feed: Feed::new(),
                stream: Arc::clone(&stream),
            });
            SERVING.store(true, Ordering::Relaxed);
        }
        let html: Arc<str> = page::live_html(&Timeline::of_info(info), title, EVENTS).into();
        let events_stream = Arc::clone(&stream);
        let app = axum::Router::new()
            .route("/", get(move || async move { Html(html.to_string()) }))
            .route(
                &format!("/{EVENTS}"),
                get(move || async move { events(&events_stream) }),
            );
        let (stop, stopped) = oneshot::channel::<()>();
        let server = tokio::spawn(async move {
            let served = axum::serve(listener, app)
                .with_graceful_shutdown(async {
                    let _ = stopped.await;
                })
                .await;
            if let Err(e) = served {
                tracing::warn!("live page server: {e}");
            }
        });
        Ok(Live {
            addr,
            stream,
            stop: Some(stop),
            server: Some(server),
        })
    }

    /// The page's address, `http://127.0.0.1:PORT/`.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// The address the page is served on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Samples published so far.
    pub fn samples(&self) -> usize {
        self.stream.lock().map_or(0, |s| s.history.len())
    }

    /// End the run: stop publishing, send open pages the end (they keep what they drew) and
    /// stop the server.
    pub async fn finish(mut self) {
        uninstall();
        if let Ok(mut s) = self.stream.lock() {
            s.ended = true;
            let _ = s.tx.send(Msg::End);
        }
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(server) = self.server.take() {
            let abort = server.abort_handle();
            if tokio::time::timeout(Duration::from_secs_f64(CLOSE_WAIT_S), server)
                .await
                .is_err()
            {
                abort.abort();
            }
        }
    }
}

impl Drop for Live {
    fn drop(&mut self) {
        uninstall();
        if let Some(server) = self.server.take() {
            server.abort();
        }
    }
}

/// Stop publishing.
fn uninstall() {
    SERVING.store(false, Ordering::Relaxed);
    if let Ok(mut tap) = TAP.lock() {
        tap.take();
    }
}

/// The event stream of one page: the samples so far, then each new one, then `end`.
fn events(
    stream: &Mutex<Stream>,
) -> Sse<impl futures_util::Stream<Item = Result<Event, Infallible>>> {
    // Subscribing and copying the history under one lock: no sample is missed or doubled.
    let (backlog, rx, ended) = match stream.lock() {
        Ok(s) => (s.history.clone(), Some(s.tx.subscribe()), s.ended),
        Err(_) => (Vec::new(), None, true),
    };
    struct State {
        backlog: std::vec::IntoIter<Arc<str>>,
        rx: Option<broadcast::Receiver<Msg>>,
        ended: bool,
    }
    let state = State {
        backlog: backlog.into_iter(),
        rx,
        ended,
    };
    let s = futures_util::stream::unfold(state, |mut st| async move {
        if let Some(text) = st.backlog.next() {
            return Some((Ok(Event::default().data(&*text)), st));
        }
        loop {
            let rx = match (&mut st.rx, st.ended) {
                (Some(rx), false) => rx,
                (Some(_), true) => {
                    st.rx = None;
                    return Some((Ok(Event::default().event("end").data("")), st));
                }
                (None, _) => return None,
            };
            match rx.recv().await {
                Ok(Msg::Sample(text)) => return Some((Ok(Event::default().data(&*text)), st)),
                Ok(Msg::End) | Err(broadcast::error::RecvError::Closed) => st.ended = true,
                Err(broadcast::error::RecvError::Lagged(n)) => {
                    tracing::warn!("live page fell {n} samples behind; they are skipped");
                }
            }
        }
    });
    Sse::new(s).keep_alive(KeepAlive::default())
}

/// What a live page of a run on `fleet` draws first: its listed robots, parameters and the
/// terrain of `terrain` (flat floor without one).
pub fn info_of_fleet(fleet: &Fleet, terrain: Option<&Path>) -> anyhow::Result<RunInfo> {
    Ok(RunInfo {
        robots: fleet.config.robots.iter().map(|r| (r.id, r.kind)).collect(),
        params: fleet.config.params.clone(),
        terrain: match terrain {
            Some(p) => crate::assemble::load_terrain(p)?,
            None => puzzlebot_params::terrain::Terrain::flat(),
        },
    })
}

/// `--live[=PORT]`: with a port (0: any free one) serve the live page of a run of `info()`
/// titled `title` and print its address on stderr; without one, nothing.
pub async fn serve_requested(
    port: Option<u16>,
    info: impl FnOnce() -> anyhow::Result<RunInfo>,
    title: &str,
) -> anyhow::Result<Option<Live>> {
    let Some(port) = port else {
        return Ok(None);
    };
    let live = Live::serve(&info()?, title, port).await?;
    eprintln!(
        "live page: {} (open it in a browser; it follows the run)",
        live.url()
    );
    Ok(Some(live))
}

/// End the live page of a run, if one is served.
pub async fn finish(live: Option<Live>) {
    if let Some(l) = live {
        l.finish().await;
    }
}
