//! Bounded keepers of a process's stdout and stderr: the newest bytes are kept, the oldest
//! dropped (and the drop remembered).

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use tokio::io::{AsyncRead, AsyncReadExt};

/// The last `cap` bytes written to one stream.
#[derive(Debug)]
pub struct Ring {
    data: VecDeque<u8>,
    cap: usize,
    truncated: bool,
}

impl Ring {
    pub fn new(cap: usize) -> Self {
        Ring {
            data: VecDeque::new(),
            cap,
            truncated: false,
        }
    }

    pub fn push(&mut self, bytes: &[u8]) {
        self.data.extend(bytes);
        if self.data.len() > self.cap {
            let extra = self.data.len() - self.cap;
            self.data.drain(..extra);
            self.truncated = true;
        }
    }

    pub fn contents(&self) -> Vec<u8> {
        self.data.iter().copied().collect()
    }

    pub fn truncated(&self) -> bool {
        self.truncated
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

    /// (stdout, stderr, truncated)
    pub fn snapshot(&self) -> (Vec<u8>, Vec<u8>, bool) {
        let o = self.stdout.lock().unwrap_or_else(|e| e.into_inner());
        let e = self.stderr.lock().unwrap_or_else(|e| e.into_inner());
        (o.contents(), e.contents(), o.truncated() || e.truncated())
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
        assert_eq!(r.contents(), b"ab");
        assert!(!r.truncated());
        r.push(b"cdef");
        assert_eq!(r.contents(), b"cdef");
        assert!(r.truncated());
    }
}
