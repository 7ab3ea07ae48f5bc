//! Glob patterns with Redis's `PSUBSCRIBE` rules, for backends that match patterns themselves.
//!
//! `*` matches any run of bytes, `?` one byte, `[abc]`, `[a-z]` and `[^a]` one byte of (or not
//! of) a class, and `\` makes the next byte literal. Redis matches patterns on the server; the
//! shared-memory backend matches them here against the channel names it discovers.

/// Whether `text` matches the glob `pattern`.
pub fn glob_match(pattern: &str, text: &str) -> bool {
    matches(pattern.as_bytes(), text.as_bytes())
}

fn matches(pattern: &[u8], text: &[u8]) -> bool {
    // Iterative matcher with one backtrack point for the latest `*`: linear in practice and
    // never recursive, so a hostile pattern cannot blow the stack.
    let (mut p, mut t) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while t < text.len() {
        if p < pattern.len() {
            match pattern[p] {
                b'*' => {
                    star = Some((p, t));
                    p += 1;
                    continue;
                }
                b'?' => {
                    p += 1;
                    t += 1;
                    continue;
                }
                b'[' => {
                    if let Some((hit, next)) = class_matches(pattern, p, text[t]) {
                        if hit {
                            p = next;
                            t += 1;
                            continue;
                        }
                    } else if text[t] == b'[' {
                        // An unclosed `[` is a literal, as in Redis.
                        p += 1;
                        t += 1;
                        continue;
                    }
                }
                b'\\' if p + 1 < pattern.len() => {
                    if pattern[p + 1] == text[t] {
                        p += 2;
                        t += 1;
                        continue;
                    }
                }
                literal => {
                    if literal == text[t] {
                        p += 1;
                        t += 1;
                        continue;
                    }
                }
            }
        }
        match star {
            Some((star_p, star_t)) => {
                p = star_p + 1;
                t = star_t + 1;
                star = Some((star_p, star_t + 1));
            }
            None => return false,
        }
    }
    pattern[p..].iter().all(|&b| b == b'*')
}

/// Matches `byte` against the class opening at `pattern[open]`. Returns whether it matched and
/// the index after the closing `]`, or `None` when the class is never closed.
fn class_matches(pattern: &[u8], open: usize, byte: u8) -> Option<(bool, usize)> {
    let mut i = open + 1;
    let negate = pattern.get(i) == Some(&b'^');
    if negate {
        i += 1;
    }
    let mut hit = false;
    let mut first = true;
    while i < pattern.len() {
        let c = pattern[i];
        if c == b']' && !first {
            return Some((hit != negate, i + 1));
        }
        first = false;
        if c == b'\\' && i + 1 < pattern.len() {
            hit |= pattern[i + 1] == byte;
            i += 2;
        } else if i + 2 < pattern.len() && pattern[i + 1] == b'-' && pattern[i + 2] != b']' {
            let (lo, hi) = (c.min(pattern[i + 2]), c.max(pattern[i + 2]));
            hit |= (lo..=hi).contains(&byte);
            i += 3;
        } else {
            hit |= c == byte;
            i += 1;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::glob_match;

    #[test]
    fn star_and_question_mark() {
        assert!(glob_match("physics_events:*", "physics_events:abc"));
        assert!(glob_match("physics_events:*", "physics_events:"));
        assert!(!glob_match("physics_events:*", "replication:abc"));
        assert!(glob_match("a*b*c", "axxbyyc"));
        assert!(!glob_match("a*b*c", "axxbyy"));
        assert!(glob_match("h?llo", "hello"));
        assert!(!glob_match("h?llo", "hllo"));
        assert!(glob_match("*", "anything"));
    }

    #[test]
    fn classes_and_escapes() {
        assert!(glob_match("h[ae]llo", "hallo"));
        assert!(!glob_match("h[ae]llo", "hillo"));
        assert!(glob_match("h[^e]llo", "hallo"));
        assert!(!glob_match("h[^e]llo", "hello"));
        assert!(glob_match("pod[0-9]", "pod7"));
        assert!(!glob_match("pod[0-9]", "podx"));
        assert!(glob_match(r"a\*b", "a*b"));
        assert!(!glob_match(r"a\*b", "axb"));
        assert!(glob_match("a[b", "a[b"));
    }

    #[test]
    fn pathological_pattern_is_fast() {
        // Backtracking over every star would take on the order of 200^50 steps; the matcher
        // keeps one backtrack point, so this is microseconds even in a debug build. The bound
        // is a million times that, and only tells the two apart.
        let text = "a".repeat(200);
        let started = std::time::Instant::now();
        assert!(!glob_match(&format!("{}b", "a*".repeat(50)), &text));
        let took = started.elapsed();
        assert!(
            took < std::time::Duration::from_secs(1),
            "a pathological pattern took {took:?}"
        );
    }
}
