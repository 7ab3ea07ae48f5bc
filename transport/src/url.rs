//! The one reader of a transport URL's settings: every backend takes `base?key=value&…`.

/// One `key=value` setting of a URL's query, and the text it was written as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Setting<'a> {
    /// The setting as written (`key=value`, or `key` alone).
    pub(crate) text: &'a str,
    pub(crate) key: &'a str,
    /// Empty when the setting has no `=`.
    pub(crate) value: &'a str,
}

/// Why a backend refused one setting of its URL (the reason an [`crate::OpenError::InvalidUrl`]
/// gives).
#[derive(Debug, thiserror::Error)]
pub(crate) enum SettingError {
    #[error("`key` must not be empty")]
    EmptyKey,
    #[error("cannot read key_file {path:?}: {source}")]
    KeyFile {
        path: String,
        source: std::io::Error,
    },
    #[error("key_file {path:?} is empty")]
    EmptyKeyFile { path: String },
    #[error("`{key}` must be a positive whole number, got {value:?}")]
    NotPositive { key: String, value: String },
    #[error("`prefix` must be 1 to 64 of [A-Za-z0-9_.-], got {value:?}")]
    Prefix { value: String },
    #[error("cannot use sign_key {path:?}: {reason}")]
    SignKey { path: String, reason: String },
    #[error("cannot use keyring {path:?}: {reason}")]
    Keyring { path: String, reason: String },
    #[error("unknown setting `{key}` (known: {known})")]
    Unknown { key: String, known: &'static str },
}

/// `url` split at its first `?` into the part before it and the settings after it, empty
/// ones skipped.
pub(crate) fn split(url: &str) -> (&str, impl Iterator<Item = Setting<'_>>) {
    let (base, query) = url.split_once('?').unwrap_or((url, ""));
    let settings = query.split('&').filter(|p| !p.is_empty()).map(|text| {
        let (key, value) = text.split_once('=').unwrap_or((text, ""));
        Setting { text, key, value }
    });
    (base, settings)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_split_once_and_empty_ones_skipped() {
        let (base, settings) = split("redis://h:1/0?a=1&&b&c=x=y");
        assert_eq!(base, "redis://h:1/0");
        let settings: Vec<(&str, &str, &str)> =
            settings.map(|s| (s.text, s.key, s.value)).collect();
        assert_eq!(
            settings,
            vec![("a=1", "a", "1"), ("b", "b", ""), ("c=x=y", "c", "x=y")]
        );
        let (base, mut none) = split("shm");
        assert_eq!(base, "shm");
        assert!(none.next().is_none());
    }
}
