//! The cluster secret: loading it (file or environment, never the command line), attaching it
//! to outgoing calls, and checking it on incoming ones in constant time.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use subtle::ConstantTimeEq;
use tonic::metadata::{BinaryMetadataValue, MetadataMap};
use tonic::service::Interceptor;
use tonic::{Request, Status};

use crate::error::{Error, Result};
use crate::wire::env::{SECRET as ENV_SECRET, SECRET_FILE as ENV_SECRET_FILE};

/// Metadata entry that carries the secret (binary, so any bytes are allowed).
pub const SECRET_METADATA: &str = "x-rem-secret-bin";

/// The shared cluster secret. Its `Debug` does not print it.
#[derive(Clone, PartialEq, Eq)]
pub struct Secret(Arc<[u8]>);

impl std::fmt::Debug for Secret {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Secret(..)")
    }
}

impl Secret {
    /// A secret from bytes; surrounding white space is removed. Empty is an error.
    pub fn new(bytes: impl AsRef<[u8]>) -> Result<Self> {
        let b = bytes.as_ref();
        let start = b.iter().position(|c| !c.is_ascii_whitespace());
        let end = b.iter().rposition(|c| !c.is_ascii_whitespace());
        match (start, end) {
            (Some(s), Some(e)) => Ok(Secret(Arc::from(&b[s..=e]))),
            _ => Err(Error::Config("the cluster secret is empty".into())),
        }
    }

    /// Reads the secret from a file.
    pub fn from_file(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|e| {
            Error::Config(format!("cannot read secret file {}: {e}", path.display()))
        })?;
        Secret::new(bytes)
    }

    /// The secret named by the environment: `REM_SECRET_FILE` (a path), else `REM_SECRET`.
    /// `Ok(None)` when neither is set.
    pub fn from_env() -> Result<Option<(Self, Option<PathBuf>)>> {
        if let Some(path) = std::env::var_os(ENV_SECRET_FILE).filter(|p| !p.is_empty()) {
            let path = PathBuf::from(path);
            return Ok(Some((Secret::from_file(&path)?, Some(path))));
        }
        match std::env::var_os(ENV_SECRET).filter(|s| !s.is_empty()) {
            Some(s) => Ok(Some((Secret::new(s.as_encoded_bytes())?, None))),
            None => Ok(None),
        }
    }

    /// The secret from `file` if given, else from the environment; an error if none.
    pub fn resolve(file: Option<&Path>) -> Result<(Self, Option<PathBuf>)> {
        if let Some(path) = file {
            return Ok((Secret::from_file(path)?, Some(path.to_path_buf())));
        }
        Secret::from_env()?.ok_or_else(|| {
            Error::Config(
                "no cluster secret: give --secret-file, or set REM_SECRET_FILE or REM_SECRET"
                    .into(),
            )
        })
    }

    /// The secret's bytes (to compare or send; never to print).
    pub fn as_bytes(&self) -> &[u8] {
        &self.0
    }

    /// Constant-time comparison (the length is not secret).
    pub fn matches(&self, candidate: &[u8]) -> bool {
        self.0.len() == candidate.len() && bool::from(self.0.as_ref().ct_eq(candidate))
    }

    /// Checks the secret carried by a request's metadata.
    pub fn check(&self, metadata: &MetadataMap) -> Result<(), Status> {
        let given = metadata
            .get_bin(SECRET_METADATA)
            .ok_or_else(|| Status::unauthenticated("missing cluster secret"))?
            .to_bytes()
            .map_err(|_| Status::unauthenticated("malformed cluster secret"))?;
        if self.matches(&given) {
            Ok(())
        } else {
            Err(Status::unauthenticated("wrong cluster secret"))
        }
    }
}

/// Server-side interceptor: refuses any call without the right secret.
#[derive(Clone, Debug)]
pub struct RequireSecret(pub Secret);

impl Interceptor for RequireSecret {
    fn call(&mut self, request: Request<()>) -> Result<Request<()>, Status> {
        self.0.check(request.metadata())?;
        Ok(request)
    }
}

/// Client-side interceptor: adds the secret to every call.
#[derive(Clone, Debug)]
pub struct SendSecret(BinaryMetadataValue);

impl SendSecret {
    /// An interceptor that sends `secret` with every call.
    pub fn new(secret: &Secret) -> Self {
        SendSecret(BinaryMetadataValue::from_bytes(secret.as_bytes()))
    }
}

impl Interceptor for SendSecret {
    fn call(&mut self, mut request: Request<()>) -> Result<Request<()>, Status> {
        request
            .metadata_mut()
            .insert_bin(SECRET_METADATA, self.0.clone());
        Ok(request)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trims_and_compares() {
        let s = Secret::new(b"  hunter2\n").unwrap();
        assert!(s.matches(b"hunter2"));
        assert!(!s.matches(b"hunter3"));
        assert!(!s.matches(b"hunter"));
        assert!(Secret::new(b" \n").is_err());
        assert_eq!(format!("{s:?}"), "Secret(..)");
    }

    #[test]
    fn interceptors_round_trip() {
        let s = Secret::new("k3y").unwrap();
        let req = SendSecret::new(&s).call(Request::new(())).unwrap();
        assert!(RequireSecret(s.clone()).call(req).is_ok());
        let bad = SendSecret::new(&Secret::new("other").unwrap())
            .call(Request::new(()))
            .unwrap();
        let err = RequireSecret(s.clone()).call(bad).unwrap_err();
        assert_eq!(err.code(), tonic::Code::Unauthenticated);
        let err = RequireSecret(s).call(Request::new(())).unwrap_err();
        assert_eq!(err.code(), tonic::Code::Unauthenticated);
    }
}
