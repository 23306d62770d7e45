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

use crate::auth::identity::{self, derive, Identity};
use crate::error::{Error, Result};
use crate::wire::env::{SECRET as ENV_SECRET, SECRET_FILE as ENV_SECRET_FILE};

/// Metadata entry that carries a client's key (binary).
pub const CLIENT_KEY_METADATA: &str = "x-rem-client-key-bin";
/// Metadata entry that carries the user a client proves with its key.
pub const USER_METADATA: &str = "x-rem-user";
/// Metadata entry that carries the admin key (binary).
pub const ADMIN_KEY_METADATA: &str = "x-rem-admin-key-bin";
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

    /// True when this is a client-key file (`rem client-key`'s output), not the cluster
    /// secret: it lets one user use the daemons, not act as one.
    pub fn is_client_key(&self) -> bool {
        identity::parse_key_file(&self.0).is_some()
    }

    /// The user and key a client presents: a client-key file's own user (`user`, if given,
    /// must be that one), or for the cluster secret `user` (default [`identity::default_user`])
    /// with its key made from the secret (which itself never leaves a host).
    pub fn client_credential(&self, user: Option<&str>) -> Result<(String, [u8; 32])> {
        if let Some((own, key)) = identity::parse_key_file(&self.0) {
            return match user {
                Some(u) if u != own => Err(Error::Config(format!(
                    "the client-key file is user {own}'s; it cannot act as {}",
                    crate::wire::ids::shown(u)
                ))),
                _ => Ok((own, key)),
            };
        }
        let user = user.map_or_else(identity::default_user, str::to_string);
        identity::check_user(&user)?;
        let key = identity::user_key(&identity::user_root(&self.0), &user);
        Ok((user, key))
    }

    /// The root of every user's key (what a daemon checks client keys with); `None` for a
    /// client-key file.
    pub fn user_root(&self) -> Option<[u8; 32]> {
        (!self.is_client_key()).then(|| identity::user_root(&self.0))
    }

    /// The admin key; `None` for a client-key file.
    pub fn admin_key(&self) -> Option<[u8; 32]> {
        (!self.is_client_key()).then(|| identity::admin_key(&self.0))
    }

    /// The key daemons prove themselves with (HMAC, see `peer_auth`); `None` for a client key.
    pub fn daemon_key(&self) -> Option<[u8; 32]> {
        (!self.is_client_key()).then(|| derive(&self.0, b"rem daemon key v1"))
    }

    /// The line `rem client-key --user USER` prints: one user's whole credential, which
    /// cannot be turned back into the cluster secret, another user's key, the admin key or a
    /// daemon's key.
    pub fn client_key_line(&self, user: &str) -> Result<String> {
        let root = self.user_root().ok_or_else(|| {
            Error::Config("making a client key needs the cluster secret, not a client key".into())
        })?;
        identity::key_file_line(&root, user)
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

/// Who made a call to the `Rem` service, as the interceptor established it.
#[derive(Clone, Debug)]
pub enum Caller {
    /// A client that proved a user's key (and perhaps the admin key).
    Client(Identity),
    /// A process started by REM, presenting its token (checked against the process by
    /// whatever it asks for: only attaching as itself is allowed).
    Process(String),
}

/// Server-side interceptor of the `Rem` service: a user's key, or a process token; anything
/// else is `UNAUTHENTICATED`. It puts the [`Caller`] in the request's extensions.
#[derive(Clone, Debug)]
pub struct RequireSecret {
    root: [u8; 32],
    admin: [u8; 32],
}

impl RequireSecret {
    /// Checks against the keys made from `secret`; a client-key file cannot check anything.
    pub fn new(secret: &Secret) -> Result<Self> {
        match (secret.user_root(), secret.admin_key()) {
            (Some(root), Some(admin)) => Ok(RequireSecret { root, admin }),
            _ => Err(Error::Config(
                "a daemon needs the cluster secret, not a client key".into(),
            )),
        }
    }

    fn client(&self, request: &Request<()>) -> Result<Identity, Status> {
        let md = request.metadata();
        let user = md
            .get(USER_METADATA)
            .ok_or_else(|| Status::unauthenticated("missing user name (x-rem-user)"))?
            .to_str()
            .ok()
            .filter(|u| identity::is_valid_user(u))
            .ok_or_else(|| Status::unauthenticated("malformed user name"))?;
        let given = md
            .get_bin(CLIENT_KEY_METADATA)
            .and_then(|k| k.to_bytes().ok())
            .ok_or_else(|| Status::unauthenticated("malformed client key"))?;
        let want = identity::user_key(&self.root, user);
        if !bool::from(want.as_slice().ct_eq(&given)) {
            return Err(Status::unauthenticated(format!(
                "wrong key for user {user} (not made from this cluster's secret)"
            )));
        }
        let admin = match md.get_bin(ADMIN_KEY_METADATA) {
            None => false,
            Some(k) => {
                let k = k
                    .to_bytes()
                    .map_err(|_| Status::unauthenticated("malformed admin key"))?;
                if !bool::from(self.admin.as_slice().ct_eq(&k)) {
                    return Err(Status::unauthenticated("wrong admin key"));
                }
                true
            }
        };
        Ok(Identity {
            user: user.to_string(),
            admin,
        })
    }
}

impl Interceptor for RequireSecret {
    fn call(&mut self, mut request: Request<()>) -> Result<Request<()>, Status> {
        let caller = if request.metadata().get_bin(CLIENT_KEY_METADATA).is_some() {
            Caller::Client(self.client(&request)?)
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

/// The client making a call that only clients may make.
pub fn require_client<T>(request: &Request<T>) -> Result<Identity, Status> {
    match caller(request)? {
        Caller::Client(who) => Ok(who),
        Caller::Process(_) => Err(Status::permission_denied(
            "a process token only lets a process attach as itself",
        )),
    }
}

/// Client-side interceptor: adds the credential to every call.
#[derive(Clone, Debug)]
pub enum SendSecret {
    /// A user's name and key, and the admin key when the client acts as admin.
    Client {
        /// The user name.
        user: AsciiMetadataValue,
        /// That user's key.
        key: BinaryMetadataValue,
        /// The admin key, when acting as admin.
        admin: Option<BinaryMetadataValue>,
    },
    /// A spawned process's token.
    Process(AsciiMetadataValue),
}

impl SendSecret {
    /// Presents `secret`'s credential as `user` (see [`Secret::client_credential`]), with the
    /// admin key when `admin` (which needs the cluster secret).
    pub fn new(secret: &Secret, user: Option<&str>, admin: bool) -> Result<Self> {
        let (user, key) = secret.client_credential(user)?;
        let admin = match (admin, secret.admin_key()) {
            (false, _) => None,
            (true, Some(k)) => Some(BinaryMetadataValue::from_bytes(&k)),
            (true, None) => {
                return Err(Error::Config(
                    "acting as admin needs the cluster secret, not a client key".into(),
                ))
            }
        };
        Ok(SendSecret::Client {
            user: AsciiMetadataValue::try_from(user.as_str())
                .map_err(|_| Error::Config("the user name is not printable ASCII".into()))?,
            key: BinaryMetadataValue::from_bytes(&key),
            admin,
        })
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
        let md = request.metadata_mut();
        match self {
            SendSecret::Client { user, key, admin } => {
                md.insert(USER_METADATA, user.clone());
                md.insert_bin(CLIENT_KEY_METADATA, key.clone());
                if let Some(a) = admin {
                    md.insert_bin(ADMIN_KEY_METADATA, a.clone());
                }
            }
            SendSecret::Process(v) => {
                md.insert(PROC_TOKEN_METADATA, v.clone());
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

    fn send(s: &Secret, user: &str, admin: bool) -> Request<()> {
        SendSecret::new(s, Some(user), admin)
            .unwrap()
            .call(Request::new(()))
            .unwrap()
    }

    #[test]
    fn interceptors_round_trip() {
        let s = Secret::new("k3y").unwrap();
        let mut check = RequireSecret::new(&s).unwrap();
        let req = send(&s, "alice", false);
        // What goes on the wire is not the secret.
        let sent = req.metadata().get_bin(CLIENT_KEY_METADATA).unwrap();
        assert_ne!(sent.to_bytes().unwrap().as_ref(), s.as_bytes());
        let req = check.call(req).unwrap();
        assert!(matches!(caller(&req), Ok(Caller::Client(who)) if who == Identity::user("alice")));
        let admin = check.call(send(&s, "alice", true)).unwrap();
        assert!(require_client(&admin).unwrap().admin);
        let bad = send(&Secret::new("other").unwrap(), "alice", false);
        let err = check.call(bad).unwrap_err();
        assert_eq!(err.code(), tonic::Code::Unauthenticated);
        let err = check.call(Request::new(())).unwrap_err();
        assert_eq!(err.code(), tonic::Code::Unauthenticated);
        let proc = SendSecret::process("abc")
            .unwrap()
            .call(Request::new(()))
            .unwrap();
        let proc = check.call(proc).unwrap();
        assert!(matches!(caller(&proc), Ok(Caller::Process(t)) if t == "abc"));
        assert!(require_client(&proc).is_err());
    }

    #[test]
    fn a_client_key_serves_its_user_and_cannot_make_a_daemon_an_admin_or_another_user() {
        let s = Secret::new("cluster").unwrap();
        let k = Secret::new(s.client_key_line("mallory").unwrap()).unwrap();
        assert!(k.is_client_key() && !s.is_client_key());
        assert!(k.daemon_key().is_none() && k.admin_key().is_none());
        assert!(k.client_key_line("alice").is_err());
        assert!(RequireSecret::new(&k).is_err());
        assert!(SendSecret::new(&k, None, true).is_err());
        assert!(SendSecret::new(&k, Some("alice"), false).is_err());
        let mut check = RequireSecret::new(&s).unwrap();
        let req = SendSecret::new(&k, None, false)
            .unwrap()
            .call(Request::new(()))
            .unwrap();
        let req = check.call(req).unwrap();
        assert_eq!(require_client(&req).unwrap(), Identity::user("mallory"));
        // Mallory's key under Alice's name is refused.
        let mut forged = send(&k, "mallory", false);
        forged
            .metadata_mut()
            .insert(USER_METADATA, AsciiMetadataValue::from_static("alice"));
        assert_eq!(
            check.call(forged).unwrap_err().code(),
            tonic::Code::Unauthenticated
        );
        // So is a made-up admin key.
        let mut forged = send(&k, "mallory", false);
        forged.metadata_mut().insert_bin(
            ADMIN_KEY_METADATA,
            BinaryMetadataValue::from_bytes(&[0; 32]),
        );
        assert_eq!(
            check.call(forged).unwrap_err().code(),
            tonic::Code::Unauthenticated
        );
    }
}
