//! The files a cluster's daemons share, made once (`rem credentials DIR`): the cluster secret
//! (`secret`, random, mode 600), and one TLS certificate for every daemon (`cluster.pem`,
//! self-signed for [`TLS_DOMAIN`] and `localhost`, mode 644) with its key (`cluster.key`,
//! mode 600). Daemons serve the certificate, trust it as their CA and verify peers against
//! [`TLS_DOMAIN`]; clients verify remd the same way (`REM_TLS_CA`, `REM_TLS_DOMAIN`).
//!
//! Files that exist are kept (a second run changes nothing but their owner), so a cluster's
//! secret is never replaced by accident.

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// The name every daemon's certificate carries and every peer and client verifies.
pub const TLS_DOMAIN: &str = "rem.cluster";
/// The secret's file name in the folder.
pub const SECRET: &str = "secret";
/// The certificate's file name.
pub const CERT: &str = "cluster.pem";
/// The private key's file name.
pub const KEY: &str = "cluster.key";

/// What [`write`] did with each file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Written {
    /// The file.
    pub path: PathBuf,
    /// False when it existed and was kept.
    pub created: bool,
}

/// Makes the cluster's files in `dir` (created if missing) unless they exist; with `owner`
/// (uid, gid) they are given to that user (needs root), e.g. the unprivileged user remd
/// runs as. `extra_names` are added to the certificate's names.
pub fn write(
    dir: &Path,
    owner: Option<(u32, u32)>,
    extra_names: &[String],
) -> Result<Vec<Written>> {
    std::fs::create_dir_all(dir)?;
    let mut out = Vec::new();
    let secret = dir.join(SECRET);
    let made = !secret.exists();
    if made {
        let mut bytes = [0u8; 32];
        getrandom::getrandom(&mut bytes)
            .map_err(|e| Error::Config(format!("no randomness for the secret: {e}")))?;
        crate::auth::secret::write_private(&secret, format!("{}\n", hex::encode(bytes)))?;
    }
    out.push(Written {
        path: secret,
        created: made,
    });
    let (cert, key) = (dir.join(CERT), dir.join(KEY));
    let made = !(cert.exists() && key.exists());
    if made {
        let mut names = vec![TLS_DOMAIN.to_string(), "localhost".to_string()];
        names.extend(extra_names.iter().cloned());
        let made = rcgen::generate_simple_self_signed(names)
            .map_err(|e| Error::Config(format!("cannot make a certificate: {e}")))?;
        crate::auth::secret::write_private(&key, made.signing_key.serialize_pem())?;
        std::fs::write(&cert, made.cert.pem())?;
        std::fs::set_permissions(&cert, std::fs::Permissions::from_mode(0o644))?;
    }
    out.push(Written {
        path: cert,
        created: made,
    });
    out.push(Written {
        path: key,
        created: made,
    });
    if let Some((uid, gid)) = owner {
        for w in &out {
            std::os::unix::fs::chown(&w.path, Some(uid), Some(gid)).map_err(|e| {
                Error::Config(format!(
                    "cannot give {} to {uid}:{gid} (run as root): {e}",
                    w.path.display()
                ))
            })?;
        }
    }
    Ok(out)
}

/// `UID:GID` (numbers), or a clear error.
pub fn parse_owner(s: &str) -> Result<(u32, u32)> {
    let bad = || {
        Error::Config(format!(
            "bad owner {} (want UID:GID, numbers)",
            crate::wire::ids::shown(s)
        ))
    };
    let (u, g) = s.split_once(':').ok_or_else(bad)?;
    Ok((u.parse().map_err(|_| bad())?, g.parse().map_err(|_| bad())?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn makes_private_files_once_and_keeps_them() {
        let dir = tempfile::tempdir().unwrap();
        let first = write(dir.path(), None, &[]).unwrap();
        assert!(first.iter().all(|w| w.created));
        let mode = |name: &str| {
            std::fs::metadata(dir.path().join(name))
                .unwrap()
                .permissions()
                .mode()
                & 0o777
        };
        assert_eq!((mode(SECRET), mode(KEY), mode(CERT)), (0o600, 0o600, 0o644));
        let secret = std::fs::read(dir.path().join(SECRET)).unwrap();
        assert_eq!(secret.len(), 65);
        let again = write(dir.path(), None, &[]).unwrap();
        assert!(again.iter().all(|w| !w.created));
        assert_eq!(std::fs::read(dir.path().join(SECRET)).unwrap(), secret);
        assert_eq!(parse_owner("65534:65534").unwrap(), (65534, 65534));
        assert!(parse_owner("nobody").is_err());
    }
}
