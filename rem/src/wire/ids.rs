//! Names of hosts, jobs and processes, and their checks.
//!
//! A host is named by its daemon's `--name`; a job id is chosen by its owner or made by the
//! daemon; both are `[A-Za-z0-9._-]{1,128}`. A process id is `HOST/NUMBER`: the host part is
//! what the relay routes on.

use std::fmt;

/// True when `s` is a valid host name or job id: 1 to 128 of `[A-Za-z0-9._-]`.
pub fn is_valid_name(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= 128
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'-'))
}

/// `s` quoted for an error message, cut to its first 64 bytes (an error echoes what a
/// client sent; a status message travels in an HTTP/2 header, which must stay small).
pub fn shown(s: &str) -> String {
    const MAX: usize = 64;
    if s.len() <= MAX {
        return format!("{s:?}");
    }
    let mut end = MAX;
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    format!("{:?}... ({} bytes)", &s[..end], s.len())
}

/// A process id, `HOST/NUMBER`.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ProcId(String);

impl ProcId {
    /// The id of process `number` on `host`.
    pub fn new(host: &str, number: u64) -> Self {
        ProcId(format!("{host}/{number}"))
    }

    /// Parses `HOST/NUMBER` (the number fits in 64 bits); `None` when malformed.
    pub fn parse(s: &str) -> Option<Self> {
        let (host, number) = s.split_once('/')?;
        if !is_valid_name(host)
            || number.is_empty()
            || !number.bytes().all(|b| b.is_ascii_digit())
            || number.parse::<u64>().is_err()
        {
            return None;
        }
        Some(ProcId(s.to_string()))
    }

    /// The host that runs (or ran) this process.
    pub fn host(&self) -> &str {
        self.0.split_once('/').map(|(h, _)| h).unwrap_or(&self.0)
    }

    /// `HOST/NUMBER`.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for ProcId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::str::FromStr for ProcId {
    type Err = crate::Error;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ProcId::parse(s)
            .ok_or_else(|| crate::Error::Invalid(format!("bad process id {}", shown(s))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        assert!(is_valid_name("alpha-1.b_c"));
        assert!(!is_valid_name(""));
        assert!(!is_valid_name("a/b"));
        assert!(!is_valid_name("a b"));
        assert!(!is_valid_name(&"x".repeat(129)));
    }

    #[test]
    fn proc_ids() {
        let p = ProcId::new("alpha", 42);
        assert_eq!(p.as_str(), "alpha/42");
        assert_eq!(p.host(), "alpha");
        assert_eq!(ProcId::parse("alpha/42"), Some(p));
        assert_eq!(ProcId::parse("alpha/"), None);
        assert_eq!(ProcId::parse("alpha/4x"), None);
        assert_eq!(ProcId::parse("al pha/4"), None);
        assert_eq!(ProcId::parse("alpha"), None);
        assert_eq!(ProcId::parse(&format!("a/{}", "9".repeat(21))), None);
        assert!(ProcId::parse(&format!("a/{}", u64::MAX)).is_some());
        let long = "é".repeat(100);
        assert!(shown(&long).len() < 100 && shown(&long).ends_with("(200 bytes)"));
        assert_eq!(shown("ab"), "\"ab\"");
    }
}
