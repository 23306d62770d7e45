//! Random bearer tokens (256 bits from the OS, written as 64 hex digits): the token a spawned
//! process attaches with. A token is compared in constant time and never printed by `Debug`.

use subtle::ConstantTimeEq;

use crate::error::{Error, Result};

/// A random token.
#[derive(Clone, PartialEq, Eq)]
pub struct Token(String);

impl std::fmt::Debug for Token {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Token(..)")
    }
}

impl Token {
    /// A fresh token from the OS's random source.
    pub fn random() -> Result<Self> {
        let mut bytes = [0u8; 32];
        getrandom::getrandom(&mut bytes)
            .map_err(|e| Error::Io(std::io::Error::other(format!("no random bytes: {e}"))))?;
        Ok(Token(hex::encode(bytes)))
    }

    /// The token as sent (hex).
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// True when `candidate` is this token (constant time).
    pub fn matches(&self, candidate: &str) -> bool {
        self.0.len() == candidate.len() && bool::from(self.0.as_bytes().ct_eq(candidate.as_bytes()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_are_fresh_and_compared_whole() {
        let a = Token::random().unwrap();
        let b = Token::random().unwrap();
        assert_ne!(a, b);
        assert_eq!(a.as_str().len(), 64);
        assert!(a.matches(a.as_str()));
        assert!(!a.matches(b.as_str()));
        assert!(!a.matches(&a.as_str()[..63]));
        assert_eq!(format!("{a:?}"), "Token(..)");
    }
}
