//! endoloc's live view: while a stream is localized (`endoloc localize --live --video …
//! --serve`), one page and its event stream, served over HTTP on one thread of its own.
//!
//! - `GET /` — the page (the run viewer's, started without frames);
//! - `GET /events` — server-sent events: first `snapshot` (every frame so far, a JSON array, so
//!   that a viewer connecting mid-stream has the state so far), then one unnamed event per
//!   frame (its JSON), and `end` when the stream is over;
//! - anything else — `404`.
//!
//! The server binds to the address it is given (loopback unless the caller asks otherwise),
//! survives viewers connecting, leaving and reconnecting (a viewer too slow to keep up skips
//! frames, never holds the localizer up), and on Ctrl-C sets the caller's interrupt flag so
//! that the run can end cleanly. Its async runtime (tokio, one thread) stays in this crate.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use axum::Router;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use tokio::sync::broadcast;

/// What can go wrong starting the server.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The address is not `HOST:PORT`.
    #[error("cannot serve on {addr:?}: {message}; expected HOST:PORT, e.g. 127.0.0.1:8080")]
    Address {
        /// The address as given.
        addr: String,
        /// Why.
        message: String,
    },
    /// The address cannot be bound (in use, not this machine's).
    #[error("cannot serve on {addr}: {source}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// The system's reason.
        source: std::io::Error,
    },
    /// The server's thread or runtime could not start.
    #[error("cannot start the live view's server: {0}")]
    Start(std::io::Error),
}

/// One message of the event stream.
#[derive(Debug, Clone)]
enum Message {
    /// Frame number `seq` (0-based, in publishing order) and its JSON.
    Frame(usize, Arc<str>),
    /// The stream is over, with a line for the page.
    End(Arc<str>),
}

/// Every frame so far, for viewers that connect later.
#[derive(Debug, Default)]
struct History {
    /// Each frame's JSON without its thumbnail.
    light: Vec<Arc<str>>,
    /// The newest frame's JSON with its thumbnail.
    newest: Option<Arc<str>>,
    ended: Option<Arc<str>>,
}

#[derive(Debug)]
struct Shared {
    page: String,
    history: Mutex<History>,
    tx: broadcast::Sender<Message>,
}

impl Shared {
    fn history(&self) -> std::sync::MutexGuard<'_, History> {
        self.history
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// The running server (see the module docs); stopped when dropped.
#[derive(Debug)]
pub struct LiveServer {
    addr: SocketAddr,
    shared: Arc<Shared>,
    shutdown: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// Whether `addr` is on this machine only.
pub fn is_loopback(addr: &SocketAddr) -> bool {
    addr.ip().is_loopback()
}

impl LiveServer {
    /// Binds `addr` (`HOST:PORT`; port 0 picks a free one) and serves `page` and its event
    /// stream on a thread of its own; Ctrl-C sets `interrupt`.
    ///
    /// # Errors
    /// [`ServeError`] when the address is malformed or cannot be bound, or the thread cannot
    /// start.
    pub fn start(addr: &str, page: String, interrupt: Arc<AtomicBool>) -> Result<Self, ServeError> {
        let parsed: SocketAddr =
            addr.parse()
                .map_err(|e: std::net::AddrParseError| ServeError::Address {
                    addr: addr.to_string(),
                    message: e.to_string(),
                })?;
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_io()
            .enable_time()
            .build()
            .map_err(ServeError::Start)?;
        let listener = runtime
            .block_on(tokio::net::TcpListener::bind(parsed))
            .map_err(|source| ServeError::Bind {
                addr: parsed,
                source,
            })?;
        let bound = listener.local_addr().map_err(|source| ServeError::Bind {
            addr: parsed,
            source,
        })?;
        // Slow viewers skip frames (`Lagged`) rather than hold anything up.
        let (tx, _) = broadcast::channel(256);
        let shared = Arc::new(Shared {
            page,
            history: Mutex::new(History::default()),
            tx,
        });
        let app = Router::new()
            .route("/", get(page_handler))
            .route("/events", get(events_handler))
            .fallback(not_found)
            .with_state(shared.clone());
        let (shutdown, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::Builder::new()
            .name("endoloc-serve".into())
            .spawn(move || {
                runtime.block_on(async move {
                    tokio::spawn(async move {
                        if tokio::signal::ctrl_c().await.is_ok() {
                            interrupt.store(true, Ordering::SeqCst);
                        }
                    });
                    let _ = axum::serve(listener, app)
                        .with_graceful_shutdown(async {
                            let _ = stopped.await;
                        })
                        .await;
                });
            })
            .map_err(ServeError::Start)?;
        Ok(LiveServer {
            addr: bound,
            shared,
            shutdown: Some(shutdown),
            thread: Some(thread),
        })
    }

    /// The address served.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Sends a frame to every viewer: `full` (with its thumbnail) now, `light` (without) to
    /// viewers that connect later.
    pub fn publish(&self, full: String, light: String) {
        let mut h = self.shared.history();
        let seq = h.light.len();
        h.light.push(light.into());
        let full: Arc<str> = full.into();
        h.newest = Some(full.clone());
        // No viewer connected is not an error.
        let _ = self.shared.tx.send(Message::Frame(seq, full));
    }

    /// Tells every viewer, now and later, that the stream is over (`line`: why, for the page).
    pub fn end(&self, line: &str) {
        let line: Arc<str> = line.replace(['\n', '\r'], " ").into();
        self.shared.history().ended = Some(line.clone());
        let _ = self.shared.tx.send(Message::End(line));
    }

    /// Frames published so far.
    pub fn frames(&self) -> usize {
        self.shared.history().light.len()
    }

    /// Stops serving (open event streams are closed) and waits for the server's thread.
    pub fn stop(mut self) {
        self.stop_now();
    }

    fn stop_now(&mut self) {
        if let Some(s) = self.shutdown.take() {
            let _ = s.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        self.stop_now();
    }
}

async fn page_handler(State(shared): State<Arc<Shared>>) -> Response {
    (
        [(header::CACHE_CONTROL, "no-store")],
        Html(shared.page.clone()),
    )
        .into_response()
}

async fn not_found() -> Response {
    (
        StatusCode::NOT_FOUND,
        "not found: this server serves its page (/) and its event stream (/events) only\n",
    )
        .into_response()
}

/// Where a viewer's event stream is.
enum Phase {
    Snapshot,
    Live,
    Done,
}

async fn events_handler(State(shared): State<Arc<Shared>>) -> impl IntoResponse {
    // Subscribed before the snapshot is taken: no frame falls between the two (one in both
    // is skipped by its number).
    let rx = shared.tx.subscribe();
    let (snapshot, known, ended) = {
        let h = shared.history();
        let n = h.light.len();
        let mut json = String::from("[");
        for (i, f) in h.light.iter().enumerate() {
            if i > 0 {
                json.push(',');
            }
            // The newest frame with its thumbnail, the others without.
            match (&h.newest, i + 1 == n) {
                (Some(full), true) => json.push_str(full),
                _ => json.push_str(f),
            }
        }
        json.push(']');
        (json, n, h.ended.clone())
    };
    let stream = futures_util::stream::unfold(
        (Phase::Snapshot, rx, Some(snapshot), ended),
        move |(phase, mut rx, snapshot, ended)| async move {
            match phase {
                Phase::Snapshot => {
                    let event = Event::default()
                        .event("snapshot")
                        .data(snapshot.unwrap_or_default());
                    let next = if ended.is_some() {
                        Phase::Done
                    } else {
                        Phase::Live
                    };
                    Some((
                        Ok::<_, std::convert::Infallible>(event),
                        (next, rx, None, ended),
                    ))
                }
                Phase::Done => {
                    let line = ended?;
                    let event = Event::default().event("end").data(&*line);
                    Some((Ok(event), (Phase::Done, rx, None, None)))
                }
                Phase::Live => loop {
                    match rx.recv().await {
                        Ok(Message::Frame(seq, _)) if seq < known => continue,
                        Ok(Message::Frame(_, json)) => {
                            let event = Event::default().data(&*json);
                            break Some((Ok(event), (Phase::Live, rx, None, None)));
                        }
                        Ok(Message::End(line)) => {
                            let event = Event::default().event("end").data(&*line);
                            break Some((Ok(event), (Phase::Done, rx, None, None)));
                        }
                        Err(broadcast::error::RecvError::Lagged(_)) => continue,
                        Err(broadcast::error::RecvError::Closed) => break None,
                    }
                },
            }
        },
    );
    Sse::new(stream).keep_alive(KeepAlive::default())
}
