//! The cluster secret and the credentials made from it: loading it (file or environment, never
//! the command line), the client key clients present (derived from the secret, so the secret
//! itself is never sent anywhere), the key daemons prove themselves with (`peer_auth`), the
//! interceptors that send and check a client's key or a process's token, in constant time.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use subtle::ConstantTimeEq;
use tonic::metadata::{AsciiMetadataValue, BinaryMetadataValue};
use tonic::service::Interceptor;
use tonic::{Request, Status};

use crate::error::{Error, Result};
use crate::wire::env::{SECRET as ENV_SECRET, SECRET_FILE as ENV_SECRET_FILE};

/// Metadata entry that carries a client's key (binary).
pub const CLIENT_KEY_METADATA: &str = "x-rem-client-key-bin";
/// Metadata entry that carries a spawned process's token.
pub const PROC_TOKEN_METADATA: &str = "x-rem-proc-token";

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

    /// The secret's bytes (to derive keys from; never to print or send).
    pub fn as_bytes(&self) -> &[u8] {
        &self.0
    }

    /// Constant-time comparison (the length is not secret).
    pub fn matches(&self, candidate: &[u8]) -> bool {
        self.0.len() == candidate.len() && bool::from(self.0.as_ref().ct_eq(candidate))
    }

    /// True when this is a client key (`rem client-key`'s output), not the cluster secret:
    /// it lets a client use the daemons, not act as one.
    pub fn is_client_key(&self) -> bool {
        self.client_key_file().is_some()
    }

    fn client_key_file(&self) -> Option<[u8; 32]> {
        let text = std::str::from_utf8(&self.0).ok()?;
        let hex_key = text.strip_prefix(CLIENT_KEY_PREFIX)?;
        hex::decode(hex_key.trim()).ok()?.try_into().ok()
    }

    /// The key clients present to a daemon: the key itself for a client-key file, else
    /// derived from the cluster secret (so the secret itself never leaves a host).
    pub fn client_key(&self) -> [u8; 32] {
        self.client_key_file()
            .unwrap_or_else(|| derive(&self.0, b"rem client key v1"))
    }

    /// The key daemons prove themselves with (HMAC, see `peer_auth`); `None` for a client key.
    pub fn daemon_key(&self) -> Option<[u8; 32]> {
        (!self.is_client_key()).then(|| derive(&self.0, b"rem daemon key v1"))
    }

    /// The line `rem client-key` prints: a client's whole credential, which cannot be turned
    /// back into the cluster secret nor into a daemon's key.
    pub fn client_key_line(&self) -> String {
        format!("{CLIENT_KEY_PREFIX}{}", hex::encode(self.client_key()))
    }
}

/// Writes a secret file readable and writable by its owner only (mode 600), as remd wants
/// its `--secret-file`.
pub fn write_private(path: &Path, contents: impl AsRef<[u8]>) -> std::io::Result<()> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(path)?;
    std::fs::set_permissions(path, std::os::unix::fs::PermissionsExt::from_mode(0o600))?;
    f.write_all(contents.as_ref())
}

/// What a client-key file starts with.
pub const CLIENT_KEY_PREFIX: &str = "rem-client-key-v1:";

/// HMAC-SHA256 of `label` under `key`.
pub fn derive(key: &[u8], label: &[u8]) -> [u8; 32] {
    use hmac::{Mac, SimpleHmac};
    let mut mac = <SimpleHmac<sha2::Sha256> as Mac>::new_from_slice(key)
        .unwrap_or_else(|_| unreachable!("HMAC accepts keys of every length"));
    mac.update(label);
    mac.finalize().into_bytes().into()
}

/// Who made a call to the `Rem` service, as the interceptor established it.
#[derive(Clone, Debug)]
pub enum Caller {
    /// A client holding the client key (or the cluster secret).
    Client,
    /// A process started by REM, presenting its token (checked against the process by
    /// whatever it asks for: only attaching as itself is allowed).
    Process(String),
}

/// Server-side interceptor of the `Rem` service: a client key, or a process token; anything
/// else is `UNAUTHENTICATED`. It puts the [`Caller`] in the request's extensions.
#[derive(Clone, Debug)]
pub struct RequireSecret {
    client_key: [u8; 32],
}

impl RequireSecret {
    /// Checks against the client key of `secret`.
    pub fn new(secret: &Secret) -> Self {
        RequireSecret {
            client_key: secret.client_key(),
        }
    }
}

impl Interceptor for RequireSecret {
    fn call(&mut self, mut request: Request<()>) -> Result<Request<()>, Status> {
        let caller = if let Some(given) = request.metadata().get_bin(CLIENT_KEY_METADATA) {
            let given = given
                .to_bytes()
                .map_err(|_| Status::unauthenticated("malformed client key"))?;
            if !bool::from(self.client_key.as_slice().ct_eq(&given)) {
                return Err(Status::unauthenticated("wrong cluster secret"));
            }
            Caller::Client
        } else if let Some(token) = request.metadata().get(PROC_TOKEN_METADATA) {
            let token = token
                .to_str()
                .ok()
                .filter(|t| t.len() <= 128)
                .ok_or_else(|| Status::unauthenticated("malformed process token"))?;
            Caller::Process(token.to_string())
        } else {
            return Err(Status::unauthenticated("missing cluster secret"));
        };
        request.extensions_mut().insert(caller);
        Ok(request)
    }
}

/// The caller the interceptor found (a request that did not pass it is refused).
pub fn caller<T>(request: &Request<T>) -> Result<Caller, Status> {
    request
        .extensions()
        .get::<Caller>()
        .cloned()
        .ok_or_else(|| Status::unauthenticated("no credential"))
}

/// Refuses a call that only clients may make.
pub fn require_client<T>(request: &Request<T>) -> Result<(), Status> {
    match caller(request)? {
        Caller::Client => Ok(()),
        Caller::Process(_) => Err(Status::permission_denied(
            "a process token only lets a process attach as itself",
        )),
    }
}

/// Client-side interceptor: adds the credential to every call.
#[derive(Clone, Debug)]
pub enum SendSecret {
    /// The client key (derived from the secret, or the client-key file itself).
    Client(BinaryMetadataValue),
    /// A spawned process's token.
    Process(AsciiMetadataValue),
}

impl SendSecret {
    /// An interceptor that presents the client key of `secret` with every call.
    pub fn new(secret: &Secret) -> Self {
        SendSecret::Client(BinaryMetadataValue::from_bytes(&secret.client_key()))
    }

    /// An interceptor that presents a process token.
    pub fn process(token: &str) -> Result<Self> {
        let value = AsciiMetadataValue::try_from(token)
            .map_err(|_| Error::Config("the process token is not printable ASCII".into()))?;
        Ok(SendSecret::Process(value))
    }
}

impl Interceptor for SendSecret {
    fn call(&mut self, mut request: Request<()>) -> Result<Request<()>, Status> {
        match self {
            SendSecret::Client(v) => {
                request
                    .metadata_mut()
                    .insert_bin(CLIENT_KEY_METADATA, v.clone());
            }
            SendSecret::Process(v) => {
                request
                    .metadata_mut()
                    .insert(PROC_TOKEN_METADATA, v.clone());
            }
        }
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
        // What goes on the wire is not the secret.
        let sent = req.metadata().get_bin(CLIENT_KEY_METADATA).unwrap();
        assert_ne!(sent.to_bytes().unwrap().as_ref(), s.as_bytes());
        let req = RequireSecret::new(&s).call(req).unwrap();
        assert!(matches!(caller(&req), Ok(Caller::Client)));
        let bad = SendSecret::new(&Secret::new("other").unwrap())
            .call(Request::new(()))
            .unwrap();
        let err = RequireSecret::new(&s).call(bad).unwrap_err();
        assert_eq!(err.code(), tonic::Code::Unauthenticated);
        let err = RequireSecret::new(&s).call(Request::new(())).unwrap_err();
        assert_eq!(err.code(), tonic::Code::Unauthenticated);
        let proc = SendSecret::process("abc")
            .unwrap()
            .call(Request::new(()))
            .unwrap();
        let proc = RequireSecret::new(&s).call(proc).unwrap();
        assert!(matches!(caller(&proc), Ok(Caller::Process(t)) if t == "abc"));
        assert!(require_client(&proc).is_err());
    }

    #[test]
    fn a_client_key_serves_a_client_and_cannot_make_a_daemon() {
        let s = Secret::new("cluster").unwrap();
        let line = s.client_key_line();
        let k = Secret::new(&line).unwrap();
        assert!(k.is_client_key() && !s.is_client_key());
        assert_eq!(k.client_key(), s.client_key());
        assert!(k.daemon_key().is_none());
        assert_ne!(s.daemon_key().unwrap(), s.client_key());
        let req = SendSecret::new(&k).call(Request::new(())).unwrap();
        assert!(RequireSecret::new(&s).call(req).is_ok());
    }
}
