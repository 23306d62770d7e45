//! Who a client is: a user name proven by a key only the cluster secret can make, and whether
//! it acts as an admin. Processes, relay owners and checkpoints belong to the user who made
//! them; only that user, or an admin, may act on them.
//!
//! Keys: the *user root* is HMAC(secret, "rem client key v1"), held by daemons and by holders
//! of the secret; user U's key is HMAC(root, "user\0" U). A client-key file
//! (`rem client-key --user U`) holds U and U's key: it proves U and nobody else, and cannot be
//! turned into the root, another user's key, the admin key or a daemon's key. A holder of the
//! secret may be any user (by default its login name, or `REM_USER`) and, when it asks, an
//! admin (the admin key is HMAC(secret, "rem admin key v1")).

use crate::error::{Error, Result};
use crate::wire::proto::Acting;

/// HMAC-SHA256 of `label` under `key`.
pub fn derive(key: &[u8], label: &[u8]) -> [u8; 32] {
    use hmac::{Mac, SimpleHmac};
    let mut mac = <SimpleHmac<sha2::Sha256> as Mac>::new_from_slice(key)
        .unwrap_or_else(|_| unreachable!("HMAC accepts keys of every length"));
    mac.update(label);
    mac.finalize().into_bytes().into()
}

/// What a client-key file starts with: `rem-client-key-v2:USER:HEX`.
pub const CLIENT_KEY_PREFIX: &str = "rem-client-key-v2:";

/// Longest user name.
pub const MAX_USER: usize = 64;

/// An authenticated client: the user it proved, and whether it proved the admin key.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Identity {
    /// The user name the client proved.
    pub user: String,
    /// True when it also proved the admin key.
    pub admin: bool,
}

impl Identity {
    /// A user acting for itself.
    pub fn user(user: impl Into<String>) -> Self {
        Identity {
            user: user.into(),
            admin: false,
        }
    }

    /// Refuses acting on `what` (a process, say) that belongs to `owner`, unless this is that
    /// user or an admin.
    pub fn may_act_on(&self, owner: &str, what: &str) -> Result<()> {
        if self.admin || self.user == owner {
            Ok(())
        } else {
            Err(Error::Refused(format!(
                "{what} belongs to another user (you are {})",
                self.user
            )))
        }
    }

    /// As sent from one daemon to another (which trusts the sender's authentication).
    pub fn acting(&self) -> Acting {
        Acting {
            user: self.user.clone(),
            admin: self.admin,
        }
    }

    /// From a peer's request; a missing or malformed one is an error.
    pub fn from_acting(acting: Option<&Acting>) -> Result<Self> {
        let a = acting.ok_or_else(|| Error::Invalid("no acting user".into()))?;
        if !is_valid_user(&a.user) {
            return Err(Error::Invalid(format!(
                "bad user name {}",
                crate::wire::ids::shown(&a.user)
            )));
        }
        Ok(Identity {
            user: a.user.clone(),
            admin: a.admin,
        })
    }
}

/// A user name: 1 to 64 of `[A-Za-z0-9._-]`.
pub fn is_valid_user(s: &str) -> bool {
    s.len() <= MAX_USER && crate::wire::ids::is_valid_name(s)
}

/// The root every user's key is made from (needs the cluster secret).
pub fn user_root(secret: &[u8]) -> [u8; 32] {
    derive(secret, b"rem client key v1")
}

/// User `user`'s client key under `root`.
pub fn user_key(root: &[u8; 32], user: &str) -> [u8; 32] {
    let mut label = b"user\0".to_vec();
    label.extend_from_slice(user.as_bytes());
    derive(root, &label)
}

/// The admin key (needs the cluster secret).
pub fn admin_key(secret: &[u8]) -> [u8; 32] {
    derive(secret, b"rem admin key v1")
}

/// The line of a client-key file for `user`.
pub fn key_file_line(root: &[u8; 32], user: &str) -> Result<String> {
    check_user(user)?;
    Ok(format!(
        "{CLIENT_KEY_PREFIX}{user}:{}",
        hex::encode(user_key(root, user))
    ))
}

/// The user and key a client-key file holds; `None` when `text` is not one.
pub fn parse_key_file(text: &[u8]) -> Option<(String, [u8; 32])> {
    let text = std::str::from_utf8(text).ok()?;
    let (user, key) = text.strip_prefix(CLIENT_KEY_PREFIX)?.split_once(':')?;
    let key = hex::decode(key.trim()).ok()?.try_into().ok()?;
    is_valid_user(user).then(|| (user.to_string(), key))
}

/// A user name, or a clear error.
pub fn check_user(user: &str) -> Result<()> {
    if is_valid_user(user) {
        Ok(())
    } else {
        Err(Error::Config(format!(
            "bad user name {} (1 to {MAX_USER} of A-Z a-z 0-9 . _ -)",
            crate::wire::ids::shown(user)
        )))
    }
}

/// Who a holder of the secret is by default: `REM_USER`, else the login name (`USER`,
/// `LOGNAME`, else the password database's name of this uid), else `uid-N`.
pub fn default_user() -> String {
    [crate::wire::env::USER, "USER", "LOGNAME"]
        .iter()
        .filter_map(|v| std::env::var(v).ok())
        .chain(account_name())
        .find(|u| is_valid_user(u))
        .unwrap_or_else(|| format!("uid-{}", unsafe { libc::getuid() }))
}

/// The password database's name of this process's uid, if it has one.
fn account_name() -> Option<String> {
    let mut pw: libc::passwd = unsafe { std::mem::zeroed() };
    let mut buf = vec![0 as libc::c_char; 4096];
    let mut found: *mut libc::passwd = std::ptr::null_mut();
    // SAFETY: getpwuid_r writes into `pw` and `buf` (whose length it is given) only, and
    // sets `found` to `&pw` or null; the name is read before `buf` goes.
    let rc = unsafe {
        libc::getpwuid_r(
            libc::getuid(),
            &mut pw,
            buf.as_mut_ptr(),
            buf.len(),
            &mut found,
        )
    };
    if rc != 0 || found.is_null() || pw.pw_name.is_null() {
        return None;
    }
    // SAFETY: pw_name points into `buf`, NUL-terminated by getpwuid_r.
    let name = unsafe { std::ffi::CStr::from_ptr(pw.pw_name) };
    name.to_str().ok().map(str::to_string)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_file_proves_its_user_only() {
        let root = user_root(b"cluster");
        let line = key_file_line(&root, "alice").unwrap();
        let (user, key) = parse_key_file(line.as_bytes()).unwrap();
        assert_eq!(user, "alice");
        assert_eq!(key, user_key(&root, "alice"));
        assert_ne!(key, user_key(&root, "bob"));
        assert_ne!(key, root);
        assert!(key_file_line(&root, "a/b").is_err());
        assert!(parse_key_file(b"rem-client-key-v2:a b:00").is_none());
        assert!(parse_key_file(b"hunter2").is_none());
    }

    #[test]
    fn only_the_owner_or_an_admin_may_act() {
        let alice = Identity::user("alice");
        assert!(alice.may_act_on("alice", "x").is_ok());
        let err = alice.may_act_on("bob", "process h/1").unwrap_err();
        assert_eq!(err.code(), tonic::Code::PermissionDenied);
        let admin = Identity {
            admin: true,
            ..alice.clone()
        };
        assert!(admin.may_act_on("bob", "x").is_ok());
        let back = Identity::from_acting(Some(&admin.acting())).unwrap();
        assert_eq!(back, admin);
        assert!(Identity::from_acting(None).is_err());
    }
}
