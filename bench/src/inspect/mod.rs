//! `seam inspect`: a recording (see [`crate::record`]) drawn as a page to scrub through, or as
//! a still.
//!
//! The page is one self-contained HTML file (its script and styles are in it, nothing is
//! fetched from elsewhere): cluster regions and their spread from above, bodies filled in their
//! owner's colour, the proxies of the world chosen outlined in their owners' colours, hand-offs
//! as rings, routed ops as arrows from the issuer's region to the target, contacts sent back as
//! crosses, a per-cluster tick-time strip, and a timeline to play, pause, step and scrub.
//! Clicking a body shows its owners over the run and, for a `seam compare` recording, its
//! distance from its single-world copy.
//!
//! The page exposes its state as `window.seam` (`ready`, `errors`, `ticks`, `handoffs`,
//! `seek(tick)`, `ownerOf(name, tick)`, `select(name)`, `loadMs`, `measureScrub(frames)`), which
//! the browser test and `seam inspect --measure` read.

pub mod browser;
mod live;
mod serve;
mod still;

pub use live::LiveRecording;
pub use serve::{Served, Server};
pub use still::{StillOptions, render_still};

/// The page's source: markup, styles and script.
const PAGE: &str = include_str!("page.html");

/// How the page gets its recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PageMode<'a> {
    /// In the page itself (a file to open anywhere).
    Embedded(&'a [u8]),
    /// Fetched once from `/recording` on the server that served the page.
    Fetch,
    /// Fetched from `/recording?from=N` a few times a second while a run goes on.
    Live,
}

/// The inspector page for `mode`.
pub fn page(mode: PageMode<'_>) -> String {
    let (name, data) = match mode {
        PageMode::Embedded(bytes) => ("embedded", base64(bytes)),
        PageMode::Fetch => ("fetch", String::new()),
        PageMode::Live => ("live", String::new()),
    };
    PAGE.replacen("/*SEAM_MODE*/", name, 1)
        .replacen("/*SEAM_DATA*/", &data, 1)
}

/// Standard base64 with padding (what the page's `atob` reads).
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Decodes standard base64 (padding optional, whitespace skipped); `None` if it is not.
pub fn base64_decode(text: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let (mut acc, mut bits) = (0u32, 0u32);
    for c in text.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            b'=' | b'\n' | b'\r' | b' ' => continue,
            _ => return None,
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_the_standard() {
        assert_eq!(base64(b""), "");
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
        assert_eq!(base64(&[0xff, 0xfe, 0x00]), "//4A");
        for text in ["", "f", "fo", "foo", "foobar", "any carnal pleasure."] {
            assert_eq!(
                base64_decode(&base64(text.as_bytes())).as_deref(),
                Some(text.as_bytes())
            );
        }
        assert_eq!(base64_decode("not base64!"), None);
    }

    #[test]
    fn the_page_carries_its_mode_and_data() {
        let html = page(PageMode::Embedded(b"SEAMREC\0"));
        assert!(html.contains(r#"const MODE = "embedded";"#));
        assert!(html.contains("U0VBTVJFQwA="));
        assert!(!html.contains("/*SEAM_"));
        assert!(page(PageMode::Live).contains(r#"const MODE = "live";"#));
        // Self-contained: nothing is fetched from another origin.
        assert!(!html.contains("http://") && !html.contains("https://"));
    }
}
