//! The coordinator's listener, guarded against clients that hold connections open: at most
//! [`ConnectionLimits::max_connections`] are open at once (past that, new ones wait in the
//! kernel's backlog until one closes), a connection from which nothing has been read for
//! [`ConnectionLimits::idle_timeout`] is closed (live HTTP/2 peers answer the server's
//! keep-alive pings, sent three times per idle timeout, so only silent ones are), a connection
//! that has carried no request with a valid token within [`ConnectionLimits::auth_timeout`] of
//! opening is closed however busily it trickles bytes (a peer without a token cannot hold a
//! slot; the services' interceptors call [`vouch`]), and an accept error (out of file
//! descriptors) backs off for 100 ms instead of spinning.
//!
//! A reserved share: connections not yet vouched for may hold at most three quarters of the
//! cap ([`ConnectionLimits::max_unvouched`]); past that, a new connection closes the oldest
//! of them. So a flood of held sockets cannot lock out a health probe (answered as soon as it
//! is accepted, long before it is the oldest) or a client with a token (vouched for by its
//! first request), and the connections of registered workers and clients are never closed to
//! make room.

use std::collections::VecDeque;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, Weak};
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{OwnedSemaphorePermit, Semaphore, mpsc};
use tokio::time::{Instant, Sleep};
use tokio_stream::wrappers::ReceiverStream;
use tonic::transport::server::{Connected, TcpConnectInfo, TlsConnectInfo};

/// Default cap on open connections: with a 1024-descriptor limit, leaves room for the store,
/// the models and the diagnoses.
pub const DEFAULT_MAX_CONNECTIONS: usize = 512;
/// Default time after which a connection nothing was read from is closed.
pub const DEFAULT_IDLE_TIMEOUT: Duration = Duration::from_secs(60);
/// Default time within which a connection must carry a request with a valid token: a client
/// sends its first request as soon as it has connected (the TLS handshake has 10 s too).
pub const DEFAULT_AUTH_TIMEOUT: Duration = Duration::from_secs(10);
/// Pause after an accept error.
const ACCEPT_BACKOFF: Duration = Duration::from_millis(100);

/// Limits on the coordinator's connections.
#[derive(Debug, Clone)]
pub struct ConnectionLimits {
    /// Default [`DEFAULT_MAX_CONNECTIONS`].
    pub max_connections: usize,
    /// Default [`DEFAULT_IDLE_TIMEOUT`].
    pub idle_timeout: Duration,
    /// Default [`DEFAULT_AUTH_TIMEOUT`].
    pub auth_timeout: Duration,
}

impl Default for ConnectionLimits {
    fn default() -> Self {
        ConnectionLimits {
            max_connections: DEFAULT_MAX_CONNECTIONS,
            idle_timeout: DEFAULT_IDLE_TIMEOUT,
            auth_timeout: DEFAULT_AUTH_TIMEOUT,
        }
    }
}

impl ConnectionLimits {
    /// How often the server pings its peers: three pings per idle timeout keep a live
    /// connection from looking idle.
    pub fn keepalive_interval(&self) -> Duration {
        self.idle_timeout / 3
    }

    /// How many connections not yet vouched for may be open at once: three quarters of
    /// [`Self::max_connections`] (at least 1); the rest is reserved for connections that
    /// carried a valid token.
    pub fn max_unvouched(&self) -> usize {
        let max = self.max_connections.max(1);
        (max - max / 4).max(1)
    }
}

/// What a connection and the listener share: whether a request vouched for it, and whether
/// the listener closed it to make room (waking its reader).
#[derive(Debug, Default)]
struct ConnState {
    vouched: AtomicBool,
    evicted: AtomicBool,
    reader: Mutex<Option<Waker>>,
}

impl ConnState {
    fn evict(&self) {
        self.evicted.store(true, Ordering::Relaxed);
        if let Some(w) = self.reader.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take() {
            w.wake();
        }
    }
}

/// The connections not yet vouched for, oldest first.
#[derive(Default)]
struct Probation {
    queue: VecDeque<Weak<ConnState>>,
}

impl Probation {
    /// Admits `conn`, closing the oldest connections still not vouched for past `max`.
    fn admit(&mut self, conn: &Arc<ConnState>, max: usize) {
        self.queue.retain(|c| c.upgrade().is_some_and(|c| !c.vouched.load(Ordering::Relaxed)));
        while self.queue.len() >= max {
            if let Some(oldest) = self.queue.pop_front().and_then(|c| c.upgrade()) {
                tracing::debug!("closing the oldest connection without a valid request to make room");
                oldest.evict();
            }
        }
        self.queue.push_back(Arc::downgrade(conn));
    }
}

/// The accepted connections of `listener`, for `serve_with_incoming`. The accepting task ends
/// when the stream is dropped, and the listening socket with it.
pub fn incoming(listener: TcpListener, limits: &ConnectionLimits) -> ReceiverStream<std::io::Result<GuardedStream>> {
    let (tx, rx) = mpsc::channel(1);
    let permits = Arc::new(Semaphore::new(limits.max_connections.max(1)));
    let (idle_timeout, auth_timeout) = (limits.idle_timeout, limits.auth_timeout);
    let max_unvouched = limits.max_unvouched();
    let probation = Mutex::new(Probation::default());
    tokio::spawn(async move {
        let mut failures: u64 = 0;
        loop {
            let permit = tokio::select! {
                p = permits.clone().acquire_owned() => p.expect("the semaphore is never closed"),
                () = tx.closed() => return,
            };
            let accepted = tokio::select! {
                a = listener.accept() => a,
                () = tx.closed() => return,
            };
            match accepted {
                Ok((stream, _)) => {
                    failures = 0;
                    let _ = stream.set_nodelay(true);
                    let guarded = GuardedStream::new(stream, permit, idle_timeout, auth_timeout);
                    probation
                        .lock()
                        .unwrap_or_else(std::sync::PoisonError::into_inner)
                        .admit(&guarded.state, max_unvouched);
                    if tx.send(Ok(guarded)).await.is_err() {
                        return;
                    }
                }
                Err(e) => {
                    failures += 1;
                    // Logged on the first failure of a run and every 100th after it.
                    if failures % 100 == 1 {
                        tracing::warn!(failures, "cannot accept a connection, backing off: {e}");
                    }
                    drop(permit);
                    tokio::time::sleep(ACCEPT_BACKOFF).await;
                }
            }
        }
    });
    ReceiverStream::new(rx)
}

/// What a request learns of its connection (in its extensions, inside a [`TlsConnectInfo`]
/// under TLS): the peer's address, and the flag [`vouch`] sets.
#[derive(Debug, Clone)]
pub struct PeerInfo {
    pub tcp: TcpConnectInfo,
    state: Arc<ConnState>,
}

/// Marks the connection `req` came on as having carried a request with a valid token, so the
/// auth timeout no longer closes it. Call it once the token has been checked.
pub fn vouch<T>(req: &tonic::Request<T>) {
    let ext = req.extensions();
    let peer = ext.get::<PeerInfo>().or_else(|| ext.get::<TlsConnectInfo<PeerInfo>>().map(TlsConnectInfo::get_ref));
    if let Some(peer) = peer {
        peer.state.vouched.store(true, Ordering::Relaxed);
    }
}

/// An accepted connection holding one of the listener's permits, closed with an error once
/// nothing has been read from it for the idle timeout, once the auth timeout has passed
/// without a request that [`vouch`]ed for it, or when the listener needs its place (it was
/// the oldest not vouched for).
pub struct GuardedStream {
    stream: TcpStream,
    _permit: OwnedSemaphorePermit,
    idle_timeout: Duration,
    idle: Pin<Box<Sleep>>,
    state: Arc<ConnState>,
    /// Until vouched for: when the connection is closed.
    auth_deadline: Option<(Duration, Pin<Box<Sleep>>)>,
}

impl GuardedStream {
    fn new(stream: TcpStream, permit: OwnedSemaphorePermit, idle_timeout: Duration, auth_timeout: Duration) -> Self {
        GuardedStream {
            stream,
            _permit: permit,
            idle_timeout,
            idle: Box::pin(tokio::time::sleep(idle_timeout)),
            state: Arc::new(ConnState::default()),
            auth_deadline: Some((auth_timeout, Box::pin(tokio::time::sleep(auth_timeout)))),
        }
    }

    /// An error once the auth timeout has passed with no request vouching for the connection
    /// (registering the waker until then).
    fn check_auth_deadline(&mut self, cx: &mut Context<'_>) -> std::io::Result<()> {
        if self.state.vouched.load(Ordering::Relaxed) {
            self.auth_deadline = None;
        } else {
            *self.state.reader.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(cx.waker().clone());
            if self.state.evicted.load(Ordering::Relaxed) {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::ConnectionAborted,
                    "closed to make room: no request with a valid token yet",
                ));
            }
        }
        let Some((timeout, deadline)) = &mut self.auth_deadline else { return Ok(()) };
        match deadline.as_mut().poll(cx) {
            Poll::Ready(()) => Err(std::io::Error::new(
                std::io::ErrorKind::TimedOut,
                format!("no request with a valid token within {:.0} s", timeout.as_secs_f64()),
            )),
            Poll::Pending => Ok(()),
        }
    }
}

impl Connected for GuardedStream {
    type ConnectInfo = PeerInfo;

    fn connect_info(&self) -> Self::ConnectInfo {
        PeerInfo { tcp: self.stream.connect_info(), state: self.state.clone() }
    }
}

impl AsyncRead for GuardedStream {
    fn poll_read(mut self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &mut ReadBuf<'_>) -> Poll<std::io::Result<()>> {
        self.check_auth_deadline(cx)?;
        let before = buf.filled().len();
        match Pin::new(&mut self.stream).poll_read(cx, buf) {
            Poll::Ready(Ok(())) => {
                if buf.filled().len() > before {
                    let next = Instant::now() + self.idle_timeout;
                    self.idle.as_mut().reset(next);
                }
                Poll::Ready(Ok(()))
            }
            Poll::Ready(Err(e)) => Poll::Ready(Err(e)),
            Poll::Pending => match self.idle.as_mut().poll(cx) {
                Poll::Ready(()) => Poll::Ready(Err(std::io::Error::new(
                    std::io::ErrorKind::TimedOut,
                    format!("nothing read for {:.0} s", self.idle_timeout.as_secs_f64()),
                ))),
                Poll::Pending => Poll::Pending,
            },
        }
    }
}

impl AsyncWrite for GuardedStream {
    fn poll_write(mut self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &[u8]) -> Poll<std::io::Result<usize>> {
        Pin::new(&mut self.stream).poll_write(cx, buf)
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.stream).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.stream).poll_shutdown(cx)
    }

    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[std::io::IoSlice<'_>],
    ) -> Poll<std::io::Result<usize>> {
        Pin::new(&mut self.stream).poll_write_vectored(cx, bufs)
    }

    fn is_write_vectored(&self) -> bool {
        self.stream.is_write_vectored()
    }
}
