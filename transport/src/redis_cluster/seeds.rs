//! A `redis-cluster://` (or, for TLS, `rediss-cluster://`) URL taken apart: the credentials and settings every node link shares,
//! and the seed nodes.

use crate::error::OpenError;
use crate::redis::redact_url;

/// `url` taken apart: scheme and credentials for a node URL, the seeds, the settings.
pub(super) fn parse(url: &str) -> Result<(String, Vec<String>, String), OpenError> {
    let invalid = |reason: &str| OpenError::InvalidUrl {
        url: redact_url(url),
        reason: reason.to_owned(),
    };
    let (scheme, rest) = if let Some(rest) = url.strip_prefix("redis-cluster://") {
        ("redis", rest)
    } else if let Some(rest) = url.strip_prefix("rediss-cluster://") {
        ("rediss", rest)
    } else {
        return Err(invalid(
            "a Redis Cluster URL starts with redis-cluster:// (or rediss-cluster:// for TLS)",
        ));
    };
    let (authority, query) = match rest.split_once('?') {
        Some((authority, query)) => (authority, format!("?{query}")),
        None => (rest, String::new()),
    };
    let authority = authority.trim_end_matches('/');
    let (user, hosts) = match authority.rsplit_once('@') {
        Some((user, hosts)) => (format!("{user}@"), hosts),
        None => (String::new(), authority),
    };
    let seeds: Vec<String> = hosts
        .split(',')
        .filter(|h| !h.is_empty())
        .map(str::to_owned)
        .collect();
    if seeds.is_empty() {
        return Err(invalid(
            "name at least one seed node, HOST:PORT[,HOST:PORT...]",
        ));
    }
    if let Some(bad) = seeds.iter().find(|s| {
        s.contains('/')
            || s.rsplit_once(':')
                .is_none_or(|(host, port)| host.is_empty() || port.parse::<u16>().is_err())
    }) {
        return Err(invalid(&format!(
            "seed {bad:?} is not HOST:PORT (a Redis Cluster has no databases, so no /DB)"
        )));
    }
    Ok((format!("{scheme}://{user}"), seeds, query))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_credentials_and_settings_are_read_and_bad_ones_named() {
        let (node, seeds, query) =
            parse("redis-cluster://u:pw@127.0.0.1:7000,127.0.0.1:7001?timeout_ms=900")
                .expect("reads");
        assert_eq!(node, "redis://u:pw@");
        assert_eq!(seeds, ["127.0.0.1:7000", "127.0.0.1:7001"]);
        assert_eq!(query, "?timeout_ms=900");
        let (node, _, query) =
            parse("rediss-cluster://127.0.0.1:7000?tls_ca=/ca.pem").expect("reads TLS");
        assert_eq!(
            (node.as_str(), query.as_str()),
            ("rediss://", "?tls_ca=/ca.pem")
        );
        for bad in [
            "redis-cluster://",
            "redis-cluster://127.0.0.1",
            "redis-cluster://127.0.0.1:7000/0",
            "redis-cluster://127.0.0.1:port",
            "redis://127.0.0.1:7000",
        ] {
            let error = parse(bad).expect_err(bad).to_string();
            assert!(error.contains("invalid transport URL"), "{bad}: {error}");
        }
        let error = parse("redis-cluster://:secret@h:1/0")
            .expect_err("a database")
            .to_string();
        assert!(!error.contains("secret"), "{error}");
    }
}
