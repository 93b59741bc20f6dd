//! Owners and API keys (`spherefit serve --api-keys FILE`).
//!
//! The key file has one key a line, `OWNER:SHA256_HEX_OF_TOKEN` (blank lines and lines starting
//! with `#` are skipped), so no token is stored in clear; an owner may have several keys (to
//! rotate them). With a key file, every route except `/health` and the map page's static files
//! (`/page/…`) needs `Authorization: Bearer TOKEN`: without one the answer is 401 with
//! `WWW-Authenticate: Bearer`, with a token that matches no key it is 401 as well, and neither
//! says more. The SHA-256 digest of the token is compared with every key's, each comparison in
//! constant time, so the time taken says nothing of how close a guess was or which key it was
//! near. Tokens are never logged (the request trace logs method, path and status only).
//!
//! Each request carries its [`Owner`] (a request extension); the job store keeps each owner's
//! jobs apart. Without a key file every caller is the one owner [`Owner::anonymous`].

use crate::service::error::ApiError;
use crate::service::AppState;
use axum::extract::{Request, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use sha2::{Digest, Sha256};
use std::sync::Arc;

/// The owner of every job when the service runs without a key file.
pub const ANONYMOUS: &str = "anonymous";

/// Longest owner name in a key file, bytes.
pub const MAX_OWNER_LEN: usize = 64;

/// Longest bearer token read, bytes (a longer one is refused as wrong, unhashed).
pub const MAX_TOKEN_LEN: usize = 4096;

/// Who made a request: an owner named in the key file, or [`ANONYMOUS`].
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Owner(Arc<str>);

impl Owner {
    /// The owner of an open service (no key file).
    pub fn anonymous() -> Owner {
        Owner(Arc::from(ANONYMOUS))
    }

    /// The owner's name.
    pub fn name(&self) -> &str {
        &self.0
    }

    /// An owner named `name` (as the key file names it; not checked).
    pub(crate) fn named(name: &str) -> Owner {
        Owner(Arc::from(name))
    }
}

/// One key: an owner and the SHA-256 digest of its token.
#[derive(Clone, PartialEq, Eq)]
struct Key {
    owner: Owner,
    digest: [u8; 32],
}

/// The keys of a key file (module docs). `Debug` shows the owners only.
#[derive(Clone, PartialEq, Eq)]
pub struct ApiKeys {
    keys: Vec<Key>,
}

impl std::fmt::Debug for ApiKeys {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let owners: Vec<&str> = self.keys.iter().map(|k| k.owner.name()).collect();
        f.debug_struct("ApiKeys").field("owners", &owners).finish()
    }
}

/// Why a key file cannot be used: the line (1-based) and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: {why}")]
pub struct KeyFileError {
    /// 1-based line number (0: the file as a whole).
    pub line: usize,
    /// What is wrong.
    pub why: String,
}

fn hex_digest(s: &str) -> Option<[u8; 32]> {
    if s.len() != 64 {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, pair) in s.as_bytes().chunks(2).enumerate() {
        let hi = (pair[0] as char).to_digit(16)?;
        let lo = (pair[1] as char).to_digit(16)?;
        out[i] = (hi * 16 + lo) as u8;
    }
    Some(out)
}

/// Whether `a` and `b` are equal, looking at every byte whatever the first difference.
fn same_digest(a: &[u8; 32], b: &[u8; 32]) -> bool {
    let diff = a
        .iter()
        .zip(b)
        .fold(0u8, |acc, (x, y)| acc | std::hint::black_box(x ^ y));
    std::hint::black_box(diff) == 0
}

/// The SHA-256 digest of `token`.
fn digest_of(token: &str) -> [u8; 32] {
    Sha256::digest(token.as_bytes()).into()
}

impl ApiKeys {
    /// Reads a key file's text (module docs).
    ///
    /// # Errors
    /// A line that is not `OWNER:SHA256_HEX` (an owner of 1 to [`MAX_OWNER_LEN`] letters,
    /// digits, `.`, `_` or `-`, not [`ANONYMOUS`]; 64 hex digits), a digest given twice, or a
    /// file with no key at all.
    pub fn parse(text: &str) -> Result<ApiKeys, KeyFileError> {
        let mut keys: Vec<Key> = Vec::new();
        for (n, raw) in text.lines().enumerate() {
            let line = n + 1;
            let l = raw.trim();
            if l.is_empty() || l.starts_with('#') {
                continue;
            }
            let bad = |why: String| KeyFileError { line, why };
            let (owner, hex) = l.split_once(':').ok_or_else(|| {
                bad("not OWNER:SHA256_HEX (no colon); a key is the owner's name, a colon and the SHA-256 of the token in hex".into())
            })?;
            let (owner, hex) = (owner.trim(), hex.trim());
            if owner.is_empty()
                || owner.len() > MAX_OWNER_LEN
                || !owner
                    .bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b"._-".contains(&b))
            {
                return Err(bad(format!(
                    "the owner {owner:?} is not 1 to {MAX_OWNER_LEN} letters, digits, '.', '_' or '-'"
                )));
            }
            if owner == ANONYMOUS {
                return Err(bad(format!(
                    "the owner name {ANONYMOUS:?} is reserved for the jobs of the service without keys"
                )));
            }
            let digest = hex_digest(hex).ok_or_else(|| {
                bad(format!(
                    "after the colon give the SHA-256 of the token as 64 hex digits (e.g. `printf %s TOKEN | sha256sum`), not {} characters",
                    hex.len()
                ))
            })?;
            if keys.iter().any(|k| k.digest == digest) {
                return Err(bad(
                    "this digest is given twice: each token belongs to one owner".into(),
                ));
            }
            keys.push(Key {
                owner: Owner::named(owner),
                digest,
            });
        }
        if keys.is_empty() {
            return Err(KeyFileError {
                line: 0,
                why: "no key in the file: every request would be refused".into(),
            });
        }
        Ok(ApiKeys { keys })
    }

    /// Reads the key file at `path`.
    ///
    /// # Errors
    /// The file cannot be read, or [`ApiKeys::parse`]'s errors, each naming the path.
    pub fn read(path: &std::path::Path) -> Result<ApiKeys, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read the API key file {}: {e}", path.display()))?;
        ApiKeys::parse(&text).map_err(|e| format!("API key file {}: {e}", path.display()))
    }

    /// The owners named, in file order (each once).
    pub fn owners(&self) -> Vec<&str> {
        let mut v: Vec<&str> = Vec::new();
        for k in &self.keys {
            if !v.contains(&k.owner.name()) {
                v.push(k.owner.name());
            }
        }
        v
    }

    /// The owner of `token`, if a key matches it (every key is compared, module docs).
    pub fn owner_of(&self, token: &str) -> Option<Owner> {
        let d = digest_of(token);
        let mut found = None;
        for k in &self.keys {
            if same_digest(&d, &k.digest) && found.is_none() {
                found = Some(k.owner.clone());
            }
        }
        found
    }
}

/// What a request's `Authorization` header says.
#[derive(Debug, PartialEq)]
enum Credentials<'a> {
    Missing,
    /// Present but not a bearer token this service could accept.
    Malformed,
    Bearer(&'a str),
}

fn credentials(headers: &HeaderMap) -> Credentials<'_> {
    let mut values = headers.get_all(header::AUTHORIZATION).iter();
    let Some(v) = values.next() else {
        return Credentials::Missing;
    };
    if values.next().is_some() {
        return Credentials::Malformed;
    }
    let Ok(s) = v.to_str() else {
        return Credentials::Malformed;
    };
    let s = s.trim();
    let Some((scheme, token)) = s.split_once(' ') else {
        return Credentials::Malformed;
    };
    let token = token.trim();
    if !scheme.eq_ignore_ascii_case("bearer") || token.is_empty() || token.len() > MAX_TOKEN_LEN {
        return Credentials::Malformed;
    }
    Credentials::Bearer(token)
}

/// Whether `path` is open without a key: `/health` and the map page's static files.
fn is_open(path: &str) -> bool {
    path == "/health" || path.starts_with("/page/")
}

/// The 401 answer: `missing` says a key is needed, else that the credentials were refused
/// (never which part).
fn unauthorized(missing: bool) -> Response {
    let (detail, challenge) = if missing {
        (
            "this service needs an API key: send Authorization: Bearer TOKEN",
            "Bearer realm=\"spherefit\"",
        )
    } else {
        (
            "the credentials were not accepted",
            "Bearer realm=\"spherefit\", error=\"invalid_token\"",
        )
    };
    let mut res = ApiError::new(StatusCode::UNAUTHORIZED, "unauthorized", detail).into_response();
    res.headers_mut().insert(
        header::WWW_AUTHENTICATE,
        HeaderValue::from_static(challenge),
    );
    res
}

/// The owner of a request (module docs), put in its extensions for the handlers; 401 when a
/// key file is in use and the request has no matching token.
pub(super) async fn authenticate(
    State(state): State<AppState>,
    mut req: Request,
    next: Next,
) -> Response {
    let owner = match &state.config.api_keys {
        None => Some(Owner::anonymous()),
        Some(_) if is_open(req.uri().path()) => None,
        Some(keys) => match credentials(req.headers()) {
            Credentials::Missing => return unauthorized(true),
            Credentials::Malformed => return unauthorized(false),
            Credentials::Bearer(token) => match keys.owner_of(token) {
                Some(o) => Some(o),
                None => return unauthorized(false),
            },
        },
    };
    if let Some(o) = owner {
        req.extensions_mut().insert(o);
    }
    next.run(req).await
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SHA-256 of "alice-token" and "bob-token" (`printf %s alice-token | sha256sum`).
    fn file() -> String {
        format!(
            "# keys\n\nalice:{}\n  bob : {}  \nalice:{}\n",
            hex(&digest_of("alice-token")),
            hex(&digest_of("bob-token")).to_uppercase(),
            hex(&digest_of("alice-second")),
        )
    }

    fn hex(d: &[u8; 32]) -> String {
        d.iter().map(|b| format!("{b:02x}")).collect()
    }

    #[test]
    fn the_digest_is_sha256() {
        assert_eq!(
            hex(&digest_of("abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn a_key_file_is_read_and_tokens_find_their_owner() {
        let keys = ApiKeys::parse(&file()).unwrap();
        assert_eq!(keys.owners(), ["alice", "bob"]);
        assert_eq!(keys.owner_of("alice-token").unwrap().name(), "alice");
        assert_eq!(keys.owner_of("alice-second").unwrap().name(), "alice");
        assert_eq!(keys.owner_of("bob-token").unwrap().name(), "bob");
        assert_eq!(keys.owner_of("alice-token "), None);
        assert_eq!(keys.owner_of(""), None);
        assert_eq!(keys.owner_of(&hex(&digest_of("alice-token"))), None);
        let shown = format!("{keys:?}");
        assert!(shown.contains("alice") && !shown.contains(&hex(&digest_of("alice-token"))));
    }

    #[test]
    fn bad_key_files_name_the_line() {
        let d = hex(&digest_of("x"));
        for (text, line, part) in [
            ("alice".to_string(), 1, "no colon"),
            (format!("# c\nal ice:{d}"), 2, "owner"),
            (format!(":{d}"), 1, "owner"),
            (format!("{}:{d}", "a".repeat(65)), 1, "owner"),
            (format!("anonymous:{d}"), 1, "reserved"),
            ("alice:abc".to_string(), 1, "64 hex"),
            (format!("alice:{}", "g".repeat(64)), 1, "64 hex"),
            (format!("alice:{d}\nbob:{d}"), 2, "twice"),
            ("# only comments\n\n".to_string(), 0, "no key"),
        ] {
            let e = ApiKeys::parse(&text).unwrap_err();
            assert_eq!(e.line, line, "{text}: {e}");
            assert!(e.why.contains(part), "{text}: {e}");
        }
        let e = ApiKeys::read(std::path::Path::new("/nonexistent/keys")).unwrap_err();
        assert!(e.contains("/nonexistent/keys"), "{e}");
    }

    #[test]
    fn credentials_are_bearer_tokens() {
        let mut h = HeaderMap::new();
        assert_eq!(credentials(&h), Credentials::Missing);
        for (v, want) in [
            ("Bearer abc", Credentials::Bearer("abc")),
            ("bearer  abc ", Credentials::Bearer("abc")),
            ("Basic YWxhZGRpbjpvcGVuc2VzYW1l", Credentials::Malformed),
            ("Bearer", Credentials::Malformed),
            ("Bearer ", Credentials::Malformed),
        ] {
            h.insert(header::AUTHORIZATION, HeaderValue::from_static(v));
            assert_eq!(credentials(&h), want, "{v}");
        }
        h.append(header::AUTHORIZATION, HeaderValue::from_static("Bearer x"));
        assert_eq!(credentials(&h), Credentials::Malformed, "two headers");
        let long = format!("Bearer {}", "a".repeat(MAX_TOKEN_LEN + 1));
        h.insert(header::AUTHORIZATION, HeaderValue::from_str(&long).unwrap());
        assert_eq!(credentials(&h), Credentials::Malformed);
        assert!(is_open("/health") && is_open("/page/app.js"));
        assert!(!is_open("/") && !is_open("/jobs") && !is_open("/healthz"));
    }

    #[test]
    fn digests_compare_whole() {
        let a = digest_of("a");
        let mut b = a;
        assert!(same_digest(&a, &b));
        b[31] ^= 1;
        assert!(!same_digest(&a, &b));
        b = a;
        b[0] ^= 0x80;
        assert!(!same_digest(&a, &b));
    }
}
