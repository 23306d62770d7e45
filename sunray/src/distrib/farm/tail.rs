//! Following a farm controller's output through REM (`Logs` from an offset): the lines it
//! wrote since the last read, across controller moves. `sunray submit` shows them as the
//! in-process controller would: its JSON events with `--events`, its warnings always.

use rem::{ProcId, RemClient};

/// The longest partial line kept while waiting for its end; a longer one is cut there.
pub const MAX_PARTIAL: usize = 64 << 10;

/// The read position in one controller process's stderr.
#[derive(Debug, Default)]
pub struct ControllerTail {
    proc: Option<ProcId>,
    offset: u64,
    partial: Vec<u8>,
}

impl ControllerTail {
    /// The complete lines `controller` (a REM process id) wrote since the last read. A new
    /// controller is read from its start; the one before it is read to its end first (when
    /// its host still answers). A process that cannot be read gives nothing.
    pub async fn read(&mut self, client: &RemClient, controller: &str) -> Vec<String> {
        let Some(now) = ProcId::parse(controller) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        if self.proc.as_ref() != Some(&now) {
            if self.proc.is_some() {
                out = self.read_current(client).await;
                out.extend(self.flush());
            }
            *self = ControllerTail {
                proc: Some(now),
                ..ControllerTail::default()
            };
        }
        out.extend(self.read_current(client).await);
        out
    }

    /// Whatever is left of a last line without its end.
    pub fn flush(&mut self) -> Vec<String> {
        if self.partial.is_empty() {
            return Vec::new();
        }
        let line = String::from_utf8_lossy(&self.partial).into_owned();
        self.partial.clear();
        vec![line]
    }

    async fn read_current(&mut self, client: &RemClient) -> Vec<String> {
        let Some(proc) = &self.proc else {
            return Vec::new();
        };
        match client.logs_since(proc, (u64::MAX, self.offset)).await {
            Ok(logs) => self.take(logs.stderr_start, &logs.stderr),
            Err(_) => Vec::new(),
        }
    }

    /// Takes `bytes`, which start at offset `start`, and returns the lines they complete.
    fn take(&mut self, start: u64, bytes: &[u8]) -> Vec<String> {
        if start > self.offset {
            // Older output was dropped by REM before it was read: the partial line is lost.
            self.partial.clear();
        }
        self.offset = start + bytes.len() as u64;
        self.partial.extend_from_slice(bytes);
        let mut out = Vec::new();
        while let Some(end) = self.partial.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = self.partial.drain(..=end).collect();
            out.push(String::from_utf8_lossy(&line[..end]).into_owned());
        }
        if self.partial.len() > MAX_PARTIAL {
            out.extend(self.flush());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_given_once_whole_and_a_gap_drops_the_partial_line() {
        let mut t = ControllerTail::default();
        assert_eq!(t.take(0, b"a\nb"), ["a"]);
        assert_eq!(t.take(3, b"c\nd\n"), ["bc", "d"]);
        assert_eq!(t.offset, 7);
        assert!(t.take(7, b"").is_empty());
        assert_eq!(t.take(7, b"xy").len(), 0);
        // Bytes 9..12 were dropped before this read: "xy" began a line that is lost.
        assert_eq!(t.take(12, b"z\n"), ["z"]);
        assert_eq!(t.take(14, &vec![b'q'; MAX_PARTIAL + 1]).len(), 1);
        assert!(t.flush().is_empty());
    }
}
