//! The Redis backend's settings: the URL and what it carries, the server it names, and
//! passwords kept out of everything printed.

use std::time::Duration;

use crate::error::OpenError;

use super::socket::Socket;
use super::tls::Tls;

/// Settings of the Redis backend beyond what redis-rs reads from the URL.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RedisConfig {
    /// Largest payload, in bytes, a publish accepts and a receive takes.
    pub max_payload: usize,
    /// Time allowed to connect, and for the server to answer a command.
    pub timeout: Duration,
    /// Whether a lost connection is re-established (see the module docs) or is an error.
    pub reconnect: bool,
    /// Time a reconnect attempt may take.
    pub connect_timeout: Duration,
    /// The deployment's frame key (`key=` or `key_file=`; see [`crate::auth`]).
    pub key: Option<crate::auth::FrameKey>,
    /// This pod's signer and the keyring it checks with (`sign_key=`, `keyring=`; see
    /// [`crate::signing`]).
    pub signing: crate::signing::Signing,
    /// How long a claim's lease lasts without renewal (`lease_ms`; see
    /// [`Transport::claim`](crate::Transport::claim)).
    pub lease: Duration,
}

impl Default for RedisConfig {
    fn default() -> Self {
        Self {
            max_payload: 4 << 20,
            timeout: Duration::from_secs(5),
            reconnect: true,
            connect_timeout: Duration::from_millis(250),
            key: None,
            signing: crate::signing::Signing::default(),
            lease: Duration::from_secs(3),
        }
    }
}

/// The server, as the URL names it.
pub(super) struct Endpoint {
    pub(super) client: redis::Client,
    /// TLS to it, for a `rediss://` URL.
    tls: Option<Tls>,
    /// `host:port` or socket path, for messages (never the password).
    pub(super) addr: String,
    pub(super) username: Option<String>,
    pub(super) password: Option<String>,
}

impl Endpoint {
    /// The settings and the server `url` names (its query's own keys taken out; the rest left
    /// for redis-rs).
    pub(super) fn from_url(url: &str) -> Result<(RedisConfig, Endpoint), OpenError> {
        let shown = redact_url(url);
        let invalid = |reason: String| OpenError::InvalidUrl {
            url: shown.clone(),
            reason,
        };
        let (base, settings) = crate::url::split(url);
        let mut config = RedisConfig::default();
        let mut passed = Vec::new();
        let mut tls_ca = None;
        for setting in settings {
            let (key, value) = (setting.key, setting.value);
            let number = || {
                value
                    .parse::<u64>()
                    .ok()
                    .filter(|n| *n > 0)
                    .ok_or_else(|| invalid(format!("`{key}` must be a positive whole number")))
            };
            if let Some(frame_key) = crate::auth::FrameKey::from_setting(key, value) {
                config.key = Some(frame_key.map_err(|e| invalid(e.to_string()))?);
                continue;
            }
            if let Some(result) = config.signing.set(key, value) {
                result.map_err(|e| invalid(e.to_string()))?;
                continue;
            }
            match key {
                "tls_ca" => tls_ca = Some(value),
                "max_payload" => config.max_payload = number()? as usize,
                "timeout_ms" => config.timeout = Duration::from_millis(number()?),
                "connect_ms" => config.connect_timeout = Duration::from_millis(number()?),
                "lease_ms" => config.lease = Duration::from_millis(number()?),
                "reconnect" => {
                    config.reconnect = match value {
                        "1" | "true" => true,
                        "0" | "false" => false,
                        _ => return Err(invalid("`reconnect` must be 0 or 1".to_owned())),
                    }
                }
                // What redis-rs reads from a URL's query; anything else is a typo or a setting
                // of another backend, refused as `shm` refuses unknown settings.
                "protocol" | "db" | "user" | "pass" | "insecure" => passed.push(setting.text),
                _ => {
                    return Err(invalid(format!(
                        "unknown setting `{key}`: the Redis backend takes max_payload, \
                         timeout_ms, connect_ms, reconnect, lease_ms, key, key_file, sign_key, \
                         keyring and tls_ca, and \
                         passes protocol, db, user, pass and insecure to redis-rs"
                    )));
                }
            }
        }
        let redis_url = if passed.is_empty() {
            base.to_owned()
        } else {
            format!("{base}?{}", passed.join("&"))
        };
        let (client, tls) = client(&redis_url, tls_ca).map_err(invalid)?;
        let info = client.get_connection_info().clone();
        let endpoint = Endpoint {
            addr: info.addr().to_string(),
            username: info.redis_settings().username().map(str::to_owned),
            password: info.redis_settings().password().map(str::to_owned),
            client,
            tls,
        };
        Ok((config, endpoint))
    }

    /// `text` with the password replaced by `***`.
    pub(super) fn scrub(&self, text: String) -> String {
        match &self.password {
            Some(p) if !p.is_empty() => text.replace(p.as_str(), "***"),
            _ => text,
        }
    }

    /// The publishing connection and the subscriber's socket, each given `timeout` to connect.
    pub(super) fn connect(
        &self,
        timeout: Duration,
        command_timeout: Duration,
    ) -> Result<(redis::Connection, Socket), OpenError> {
        let publisher = self
            .client
            .get_connection_with_timeout(timeout)
            .map_err(|e| {
                let reason = self.scrub(e.to_string());
                if e.kind() == redis::ErrorKind::AuthenticationFailed
                    || reason.contains("WRONGPASS")
                    || reason.contains("NOAUTH")
                {
                    OpenError::AuthenticationFailed {
                        addr: self.addr.clone(),
                        reason,
                    }
                } else {
                    OpenError::Unreachable {
                        addr: self.addr.clone(),
                        reason,
                    }
                }
            })?;
        let unreachable = |reason: String| OpenError::Unreachable {
            addr: self.addr.clone(),
            reason,
        };
        publisher
            .set_read_timeout(Some(command_timeout))
            .and_then(|()| publisher.set_write_timeout(Some(command_timeout)))
            .map_err(|e| unreachable(e.to_string()))?;
        let info = self.client.get_connection_info();
        let socket = Socket::connect(info.addr(), timeout, self.tls.as_ref())
            .map_err(|e| unreachable(e.to_string()))?;
        Ok((publisher, socket))
    }
}

/// The redis-rs client of `url` and, for a `rediss://` one, the TLS that reaches it (trusting
/// the PEM file `tls_ca`, or the system's roots).
fn client(url: &str, tls_ca: Option<&str>) -> Result<(redis::Client, Option<Tls>), String> {
    if !url.starts_with("rediss://") {
        if tls_ca.is_some() {
            return Err("`tls_ca` needs a rediss:// URL".to_owned());
        }
        return redis::Client::open(url)
            .map(|c| (c, None))
            .map_err(|e| e.to_string());
    }
    let tls = Tls::new(tls_ca)?;
    let certificates = redis::TlsCertificates {
        client_tls: None,
        root_cert: tls.root_pem.clone(),
    };
    let client = redis::Client::build_with_tls(url, certificates).map_err(|e| e.to_string())?;
    Ok((client, Some(tls)))
}

/// Replaces the password of `url` (if any) with `***`.
pub fn redact_url(url: &str) -> String {
    hide_key(&redact_password(url))
}

/// `url` with the value of a `key=` setting replaced by `***`.
fn hide_key(url: &str) -> String {
    let Some((base, query)) = url.split_once('?') else {
        return url.to_owned();
    };
    let settings: Vec<String> = query
        .split('&')
        .map(|pair| match pair.split_once('=') {
            Some(("key", _)) => "key=***".to_owned(),
            _ => pair.to_owned(),
        })
        .collect();
    format!("{base}?{}", settings.join("&"))
}

/// `url` with the password of its authority replaced by `***`.
fn redact_password(url: &str) -> String {
    let Some(scheme_end) = url.find("://") else {
        return url.to_owned();
    };
    let rest = &url[scheme_end + 3..];
    let authority_end = rest.find('/').unwrap_or(rest.len());
    match rest[..authority_end].rfind('@') {
        Some(at) => match rest[..at].find(':') {
            Some(colon) => format!(
                "{}{}:***{}",
                &url[..scheme_end + 3],
                &rest[..colon],
                &rest[at..]
            ),
            None => format!("{}***{}", &url[..scheme_end + 3], &rest[at..]),
        },
        None => url.to_owned(),
    }
}
