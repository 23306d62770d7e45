//! Bounded keepers of a process's stdout and stderr: the newest bytes are kept, the oldest
//! dropped (and the drop remembered).

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use tokio::io::{AsyncRead, AsyncReadExt};

use crate::wire::proto::LogsReply;

/// The last `cap` bytes written to one stream.
#[derive(Debug)]
pub struct Ring {
    data: VecDeque<u8>,
    cap: usize,
    truncated: bool,
    /// Bytes dropped from the front so far: the offset of `data`'s first byte.
    dropped: u64,
}

impl Ring {
    pub fn new(cap: usize) -> Self {
        Ring {
            data: VecDeque::new(),
            cap,
            truncated: false,
            dropped: 0,
        }
    }

    pub fn push(&mut self, bytes: &[u8]) {
        self.data.extend(bytes);
        if self.data.len() > self.cap {
            let extra = self.data.len() - self.cap;
            self.data.drain(..extra);
            self.truncated = true;
            self.dropped += extra as u64;
        }
    }

    pub fn truncated(&self) -> bool {
        self.truncated
    }

    /// What is kept from offset `from` on (bytes written since the start), and the offset
    /// of its first byte (later than `from` when older bytes were dropped).
    pub fn since(&self, from: u64) -> (u64, Vec<u8>) {
        let start = from.max(self.dropped);
        let skip = usize::try_from(start - self.dropped).unwrap_or(usize::MAX);
        (start, self.data.iter().skip(skip).copied().collect())
    }
}

/// stdout and stderr of one process, shared with the tasks that read the pipes.
#[derive(Clone, Debug)]
pub struct Output {
    pub stdout: Arc<Mutex<Ring>>,
    pub stderr: Arc<Mutex<Ring>>,
}

impl Output {
    pub fn new(cap: usize) -> Self {
        Output {
            stdout: Arc::new(Mutex::new(Ring::new(cap))),
            stderr: Arc::new(Mutex::new(Ring::new(cap))),
        }
    }

    /// Bytes kept now, of both streams.
    pub fn len(&self) -> usize {
        let o = self
            .stdout
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .data
            .len();
        let e = self
            .stderr
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .data
            .len();
        o + e
    }

    /// The kept output from the offsets `from` (stdout, stderr) on.
    pub fn since(&self, from: (u64, u64)) -> LogsReply {
        let o = self.stdout.lock().unwrap_or_else(|e| e.into_inner());
        let e = self.stderr.lock().unwrap_or_else(|e| e.into_inner());
        let (stdout_start, stdout) = o.since(from.0);
        let (stderr_start, stderr) = e.since(from.1);
        LogsReply {
            stdout,
            stderr,
            truncated: o.truncated() || e.truncated(),
            stdout_start,
            stderr_start,
        }
    }
}

/// Copies a pipe into a ring until end of file.
pub async fn collect(mut pipe: impl AsyncRead + Unpin, ring: Arc<Mutex<Ring>>) {
    let mut buf = vec![0u8; 8192];
    loop {
        match pipe.read(&mut buf).await {
            Ok(0) | Err(_) => break,
            Ok(n) => ring
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(&buf[..n]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_newest_bytes() {
        let mut r = Ring::new(4);
        r.push(b"ab");
        assert_eq!(r.since(0), (0, b"ab".to_vec()));
        assert!(!r.truncated());
        r.push(b"cdef");
        assert_eq!(r.since(0), (2, b"cdef".to_vec()));
        assert!(r.truncated());
    }

    #[test]
    fn a_follower_reads_only_what_is_new_and_skips_what_was_dropped() {
        let mut r = Ring::new(8);
        r.push(b"abcd");
        assert_eq!(r.since(0), (0, b"abcd".to_vec()));
        assert_eq!(r.since(2), (2, b"cd".to_vec()));
        assert_eq!(r.since(9), (9, Vec::new()));
        r.push(b"efghij");
        // "ab" were dropped: reading from 1 starts at 2.
        assert_eq!(r.since(1), (2, b"cdefghij".to_vec()));
        assert_eq!(r.since(6), (6, b"ghij".to_vec()));
        assert!(r.truncated());
    }
}
