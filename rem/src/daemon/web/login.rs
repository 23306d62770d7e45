//! Who may open the web view: login tokens, the sessions they open, and the check every
//! request passes.
//!
//! A token is one line, checked against keys made from the cluster secret (the daemon never
//! stores a token):
//! - a user's client key (`rem client-key --user U`, `rem web-token`): the session is U's,
//!   and sees U's jobs only;
//! - the web admin token (`rem web-token --admin`, `rem-web-admin-v1:HEX`, HEX =
//!   HMAC(admin key, "rem web admin v1")): the session is the admin's, and sees every job.
//!
//! The login form trades a token for a session cookie (`rem_session`: 32 random bytes,
//! HttpOnly, SameSite=Strict, 12 hours). Scripts send the token itself instead, as
//! `Authorization: Bearer TOKEN`. A request that changes something (cancel, logout) made
//! with the cookie must also carry the session's CSRF token in `X-CSRF-Token`, which a
//! page of another origin cannot read or send.

use std::collections::HashMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use axum::http::{header, HeaderMap};
use subtle::ConstantTimeEq;

use crate::auth::identity::{self, Identity};
use crate::auth::secret::Secret;
use crate::auth::token::Token;
use crate::error::{Error, Result};

/// What the web admin token starts with.
pub const ADMIN_TOKEN_PREFIX: &str = "rem-web-admin-v1:";

/// The name of the session cookie.
pub const COOKIE: &str = "rem_session";

/// The header a cookie-authenticated request that changes something must carry.
pub const CSRF_HEADER: &str = "x-csrf-token";

/// How long a session lasts after its login.
pub const SESSION_TTL: Duration = Duration::from_secs(12 * 3600);

/// Most sessions kept at once (the oldest goes first).
pub const MAX_SESSIONS: usize = 1024;

/// Longest token accepted (a client-key line is about 150 bytes).
pub const MAX_TOKEN: usize = 512;

/// The web admin token of the cluster whose secret is `secret` (needs the secret itself).
pub fn admin_token(secret: &Secret) -> Result<String> {
    let key = secret.admin_key().ok_or_else(|| {
        Error::Config("the web admin token needs the cluster secret, not a client key".into())
    })?;
    Ok(format!(
        "{ADMIN_TOKEN_PREFIX}{}",
        hex::encode(identity::derive(&key, b"rem web admin v1"))
    ))
}

/// Checks login tokens against the keys made from the cluster secret.
#[derive(Clone)]
pub struct TokenCheck {
    root: [u8; 32],
    admin: [u8; 32],
}

impl TokenCheck {
    /// The check of a daemon holding `secret`.
    pub fn new(secret: &Secret) -> Result<Self> {
        let root = secret
            .user_root()
            .ok_or_else(|| Error::Config("the web view needs the cluster secret".into()))?;
        let admin_key = secret
            .admin_key()
            .ok_or_else(|| Error::Config("the web view needs the cluster secret".into()))?;
        Ok(TokenCheck {
            root,
            admin: identity::derive(&admin_key, b"rem web admin v1"),
        })
    }

    /// Who `token` proves; `None` for anything else.
    pub fn identify(&self, token: &str) -> Option<Identity> {
        let token = token.trim();
        if token.len() > MAX_TOKEN {
            return None;
        }
        if let Some(hex_key) = token.strip_prefix(ADMIN_TOKEN_PREFIX) {
            let given = hex::decode(hex_key).ok()?;
            return bool::from(self.admin.as_slice().ct_eq(&given)).then(|| Identity {
                user: "admin".into(),
                admin: true,
            });
        }
        let (user, key) = identity::parse_key_file(token.as_bytes())?;
        let want = identity::user_key(&self.root, &user);
        bool::from(want.as_slice().ct_eq(&key)).then(|| Identity::user(user))
    }
}

/// One logged-in browser.
#[derive(Clone, Debug)]
pub struct Session {
    /// Who logged in.
    pub who: Identity,
    /// What its changing requests must carry in `X-CSRF-Token`.
    pub csrf: String,
    expires: Instant,
}

/// The sessions of this daemon's web view (in memory: a restarted daemon asks for a new
/// login), at most [`MAX_SESSIONS`].
#[derive(Default)]
pub struct Sessions {
    map: Mutex<HashMap<String, Session>>,
}

impl Sessions {
    /// Opens a session for `who`: its cookie value and the session.
    pub fn open(&self, who: Identity) -> Result<(String, Session)> {
        let now = Instant::now();
        let id = Token::random()?.as_str().to_string();
        let session = Session {
            who,
            csrf: Token::random()?.as_str().to_string(),
            expires: now + SESSION_TTL,
        };
        let mut map = self.map.lock().unwrap_or_else(|e| e.into_inner());
        map.retain(|_, s| s.expires > now);
        if map.len() >= MAX_SESSIONS {
            if let Some(oldest) = map
                .iter()
                .min_by_key(|(_, s)| s.expires)
                .map(|(k, _)| k.clone())
            {
                map.remove(&oldest);
            }
        }
        map.insert(id.clone(), session.clone());
        Ok((id, session))
    }

    /// The live session whose cookie value is `id`.
    pub fn get(&self, id: &str) -> Option<Session> {
        let map = self.map.lock().unwrap_or_else(|e| e.into_inner());
        map.get(id).filter(|s| s.expires > Instant::now()).cloned()
    }

    /// Ends the session `id`.
    pub fn close(&self, id: &str) {
        self.map
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id);
    }
}

/// How a request proved itself.
#[derive(Clone, Debug)]
pub enum Proof {
    /// The session cookie (the session's CSRF token is what changing requests must carry).
    Cookie {
        /// The cookie's value.
        id: String,
        /// The session.
        session: Session,
    },
    /// `Authorization: Bearer TOKEN` (not sent by browsers on their own, so not forgeable
    /// by another site).
    Bearer(Identity),
}

impl Proof {
    /// Who made the request.
    pub fn who(&self) -> &Identity {
        match self {
            Proof::Cookie { session, .. } => &session.who,
            Proof::Bearer(who) => who,
        }
    }

    /// Whether a changing request may go on: a bearer token, or the cookie together with
    /// the session's CSRF token.
    pub fn may_change(&self, headers: &HeaderMap) -> bool {
        match self {
            Proof::Bearer(_) => true,
            Proof::Cookie { session, .. } => headers
                .get(CSRF_HEADER)
                .map(|v| bool::from(v.as_bytes().ct_eq(session.csrf.as_bytes())))
                .unwrap_or(false),
        }
    }
}

/// How `headers` prove their sender: a bearer token wins over a cookie; `None` when neither
/// proves anyone.
pub fn prove(headers: &HeaderMap, tokens: &TokenCheck, sessions: &Sessions) -> Option<Proof> {
    if let Some(auth) = headers.get(header::AUTHORIZATION) {
        let token = auth.to_str().ok()?.strip_prefix("Bearer ")?;
        return tokens.identify(token).map(Proof::Bearer);
    }
    let id = cookie(headers, COOKIE)?;
    let session = sessions.get(&id)?;
    Some(Proof::Cookie { id, session })
}

/// The value of cookie `name` in `headers`.
pub fn cookie(headers: &HeaderMap, name: &str) -> Option<String> {
    headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|pair| pair.trim().split_once('='))
        .find(|(k, _)| *k == name)
        .map(|(_, v)| v.to_string())
}

/// The `Set-Cookie` value that stores session `id` (empty `id`: the one that removes it).
pub fn set_cookie(id: &str) -> String {
    let max_age = if id.is_empty() {
        0
    } else {
        SESSION_TTL.as_secs()
    };
    format!("{COOKIE}={id}; Path=/; HttpOnly; SameSite=Strict; Max-Age={max_age}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check() -> (Secret, TokenCheck) {
        let secret = Secret::new("web-secret").unwrap();
        let check = TokenCheck::new(&secret).unwrap();
        (secret, check)
    }

    #[test]
    fn client_keys_prove_their_user_and_the_admin_token_the_admin() {
        let (secret, check) = check();
        let alice = secret.client_key_line("alice").unwrap();
        assert_eq!(check.identify(&alice), Some(Identity::user("alice")));
        assert_eq!(
            check.identify(&format!("  {alice}\n")),
            Some(Identity::user("alice"))
        );
        let admin = check.identify(&admin_token(&secret).unwrap()).unwrap();
        assert!(admin.admin);
        // Another cluster's key, a forged user, the secret itself, junk: nobody.
        let other = Secret::new("other").unwrap();
        assert_eq!(
            check.identify(&other.client_key_line("alice").unwrap()),
            None
        );
        assert_eq!(check.identify(&admin_token(&other).unwrap()), None);
        let forged = alice.replace(":alice:", ":bob:");
        assert_eq!(check.identify(&forged), None);
        assert_eq!(check.identify("web-secret"), None);
        assert_eq!(check.identify(""), None);
        assert_eq!(check.identify(&"x".repeat(10_000)), None);
        assert_eq!(check.identify(&format!("{ADMIN_TOKEN_PREFIX}zz")), None);
    }

    #[test]
    fn sessions_are_found_by_cookie_bounded_and_closed() {
        let sessions = Sessions::default();
        let (id, s) = sessions.open(Identity::user("alice")).unwrap();
        assert_eq!(id.len(), 64);
        assert_ne!(id, s.csrf);
        let mut headers = HeaderMap::new();
        headers.insert(
            header::COOKIE,
            format!("a=b; {COOKIE}={id}; c=d").parse().unwrap(),
        );
        let (_, tokens) = check();
        let proof = prove(&headers, &tokens, &sessions).unwrap();
        assert_eq!(proof.who().user, "alice");
        assert!(!proof.may_change(&headers), "no CSRF token");
        headers.insert(CSRF_HEADER, "wrong".parse().unwrap());
        assert!(!proof.may_change(&headers));
        headers.insert(CSRF_HEADER, s.csrf.parse().unwrap());
        assert!(proof.may_change(&headers));
        sessions.close(&id);
        assert!(prove(&headers, &tokens, &sessions).is_none());
        for i in 0..MAX_SESSIONS + 10 {
            sessions.open(Identity::user(format!("u{i}"))).unwrap();
        }
        assert_eq!(sessions.map.lock().unwrap().len(), MAX_SESSIONS);
    }

    #[test]
    fn a_bearer_token_proves_itself_and_may_change() {
        let (secret, tokens) = check();
        let mut headers = HeaderMap::new();
        let line = secret.client_key_line("bob").unwrap();
        headers.insert(
            header::AUTHORIZATION,
            format!("Bearer {line}").parse().unwrap(),
        );
        let proof = prove(&headers, &tokens, &Sessions::default()).unwrap();
        assert_eq!(proof.who().user, "bob");
        assert!(proof.may_change(&headers));
        headers.insert(header::AUTHORIZATION, "Bearer nope".parse().unwrap());
        assert!(prove(&headers, &tokens, &Sessions::default()).is_none());
    }
}
