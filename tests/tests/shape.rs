//! The shape of the workspace's sources, checked on every test run: no import circle between
//! the files of any crate, the library crates' files and functions within their bounds, and
//! bench's functions within theirs (the limits DESIGN.md names). A file that outgrows its bound becomes a folder; a function
//! that outgrows its bound is split where its phases are.
//!
//! Sources are read as text: comments and string literals are blanked out first, a function
//! is measured from its opening brace to the matching closing one, and a trailing
//! `#[cfg(test)] mod tests` does not count towards its file. An import edge is a `crate::…` or
//! `super::…` path resolved to the deepest module file it names; edges between a module and
//! its own ancestors (a module root re-exporting its children, a child using its parent) are
//! not circles.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Lines a library file may have, its trailing tests aside.
const MAX_FILE_LINES: usize = 400;
/// Lines a library function may have.
const MAX_FN_LINES: usize = 80;
/// Lines a function of bench (the `seam` commands and harnesses) may have; its files have
/// no bound.
const MAX_BENCH_FN_LINES: usize = 100;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate sits in the workspace")
        .to_path_buf()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|x| x == "rs") {
            out.push(path);
        }
    }
}

/// `src` with comments, string and character literals replaced by blanks (newlines kept), so
/// that braces and paths inside them do not count.
fn blank(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    let keep_lines = |seg: &[u8], out: &mut Vec<u8>| {
        out.extend(seg.iter().map(|&c| if c == b'\n' { b'\n' } else { b' ' }));
    };
    while i < b.len() {
        let rest = &b[i..];
        if rest.starts_with(b"//") {
            let end = rest.iter().position(|&c| c == b'\n').unwrap_or(rest.len());
            keep_lines(&rest[..end], &mut out);
            i += end;
        } else if rest.starts_with(b"/*") {
            let end = rest[2..]
                .windows(2)
                .position(|w| w == b"*/")
                .map_or(rest.len(), |p| p + 4);
            keep_lines(&rest[..end], &mut out);
            i += end;
        } else if rest.starts_with(b"r#\"") || rest.starts_with(b"r\"") {
            let hashes = rest[1..].iter().take_while(|&&c| c == b'#').count();
            let mut close = vec![b'"'];
            close.extend(std::iter::repeat_n(b'#', hashes));
            let open = 2 + hashes;
            let end = rest[open..]
                .windows(close.len())
                .position(|w| w == close.as_slice())
                .map_or(rest.len(), |p| open + p + close.len());
            keep_lines(&rest[..end], &mut out);
            i += end;
        } else if rest[0] == b'"' {
            let mut j = 1;
            while j < rest.len() && rest[j] != b'"' {
                j += if rest[j] == b'\\' { 2 } else { 1 };
            }
            let end = (j + 1).min(rest.len());
            keep_lines(&rest[..end], &mut out);
            i += end;
        } else if rest[0] == b'\'' && char_literal_len(rest).is_some() {
            let len = char_literal_len(rest).unwrap_or(1);
            keep_lines(&rest[..len], &mut out);
            i += len;
        } else {
            out.push(rest[0]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The length of a character literal at the start of `s` (`'a'`, `'\n'`, `'\u{1F600}'`), or
/// `None` for a lifetime.
fn char_literal_len(s: &[u8]) -> Option<usize> {
    if s.len() >= 3 && s[1] != b'\\' {
        let width = std::str::from_utf8(&s[1..s.len().min(5)])
            .ok()
            .or_else(|| std::str::from_utf8(&s[1..2]).ok())
            .and_then(|t| t.chars().next())
            .map_or(1, char::len_utf8);
        return (s.get(1 + width) == Some(&b'\'')).then_some(width + 2);
    }
    if s.len() >= 4 && s[1] == b'\\' {
        let close = s[2..].iter().take(10).position(|&c| c == b'\'')?;
        return Some(close + 3);
    }
    None
}

/// Where a trailing `#[cfg(test)] mod tests` starts, if there is one.
fn tests_start(src: &str) -> Option<usize> {
    let at = src.find("#[cfg(test)]")?;
    src[at..]
        .trim_start_matches("#[cfg(test)]")
        .trim_start()
        .starts_with("mod tests")
        .then_some(at)
}

/// The functions of `blanked` longer than `limit` lines, as `name (N lines)`, tests aside.
fn long_functions(blanked: &str, limit: usize) -> Vec<String> {
    let end = tests_start(blanked).unwrap_or(blanked.len());
    let text = &blanked[..end];
    let bytes = text.as_bytes();
    let mut found = Vec::new();
    let mut from = 0;
    while let Some(at) = text[from..].find("fn ") {
        let start = from + at;
        from = start + 3;
        if start > 0 && (bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'_') {
            continue;
        }
        let name: String = text[start + 3..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        // The body opens at the first `{` before any `;` (a declaration has none).
        let Some(open) = text[start..].find(['{', ';']).map(|p| start + p) else {
            break;
        };
        if bytes[open] == b';' {
            continue;
        }
        let mut depth = 0usize;
        let mut close = open;
        for (k, &c) in bytes[open..].iter().enumerate() {
            match c {
                b'{' => depth += 1,
                b'}' => {
                    depth -= 1;
                    if depth == 0 {
                        close = open + k;
                        break;
                    }
                }
                _ => {}
            }
        }
        let lines = text[open..close].matches('\n').count();
        if lines > limit {
            let line = text[..start].matches('\n').count() + 1;
            found.push(format!("{name} at line {line} ({lines} lines)"));
        }
    }
    found
}

/// The module path of a source file under `src` (`cluster/mod.rs` is `cluster`).
fn module_of(file: &Path, src: &Path) -> Vec<String> {
    let rel = file
        .strip_prefix(src)
        .expect("under src")
        .with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The modules `blanked` (the file of module `me`) uses through `crate::` and `super::` paths,
/// each resolved to the deepest module of `modules` it names.
fn uses(blanked: &str, me: &[String], modules: &BTreeSet<Vec<String>>) -> BTreeSet<Vec<String>> {
    let mut out = BTreeSet::new();
    let bytes = blanked.as_bytes();
    for keyword in ["crate::", "super::"] {
        let mut from = 0;
        while let Some(at) = blanked[from..].find(keyword) {
            let start = from + at;
            from = start + keyword.len();
            if start > 0 && (bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'_') {
                continue;
            }
            let path: Vec<String> = blanked[start..]
                .split("::")
                .map(|s| {
                    s.chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect::<String>()
                })
                .take_while(|s| !s.is_empty())
                .collect();
            // `super` is the parent of this module, whether its file is `x.rs` or `x/mod.rs`.
            let mut base: Vec<String> = if path[0] == "crate" {
                Vec::new()
            } else {
                me[..me.len().saturating_sub(1)].to_vec()
            };
            let mut rest = &path[1..];
            while rest.first().is_some_and(|s| s == "super") {
                base.pop();
                rest = &rest[1..];
            }
            let mut candidate = base;
            candidate.extend(rest.iter().cloned());
            for k in (0..=candidate.len()).rev() {
                let module = candidate[..k].to_vec();
                if modules.contains(&module) {
                    if module.as_slice() != me {
                        out.insert(module);
                    }
                    break;
                }
            }
        }
    }
    out
}

/// The circles among the files of the crate whose sources are under `src`: each strongly
/// connected set of two or more files, ancestor edges aside.
fn circles(src: &Path) -> Vec<Vec<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let modules: BTreeMap<Vec<String>, PathBuf> = files
        .iter()
        .map(|f| (module_of(f, src), f.clone()))
        .collect();
    let names: BTreeSet<Vec<String>> = modules.keys().cloned().collect();
    let ancestor = |a: &[String], b: &[String]| a.len() <= b.len() && b[..a.len()] == *a;
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for (module, file) in &modules {
        let text = blank(&std::fs::read_to_string(file).expect("readable source"));
        let targets = uses(&text, module, &names)
            .into_iter()
            .filter(|t| !ancestor(t, module) && !ancestor(module, t))
            .collect();
        edges.insert(module.clone(), targets);
    }
    strongly_connected(&edges)
        .into_iter()
        .filter(|set| set.len() > 1)
        .map(|set| {
            set.iter()
                .map(|m| {
                    modules[m]
                        .strip_prefix(src)
                        .expect("under src")
                        .display()
                        .to_string()
                })
                .collect()
        })
        .collect()
}

/// Tarjan's strongly connected components of a small graph.
fn strongly_connected(
    edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
) -> Vec<Vec<Vec<String>>> {
    struct State<'a> {
        edges: &'a BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        index: BTreeMap<&'a Vec<String>, usize>,
        low: BTreeMap<&'a Vec<String>, usize>,
        stack: Vec<&'a Vec<String>>,
        on_stack: BTreeSet<&'a Vec<String>>,
        found: Vec<Vec<Vec<String>>>,
    }
    fn visit<'a>(v: &'a Vec<String>, s: &mut State<'a>) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        for w in s.edges.get(v).into_iter().flatten() {
            let Some((w, _)) = s.edges.get_key_value(w) else {
                continue;
            };
            if !s.index.contains_key(w) {
                visit(w, s);
                let low = s.low[v].min(s.low[w]);
                s.low.insert(v, low);
            } else if s.on_stack.contains(w) {
                let low = s.low[v].min(s.index[w]);
                s.low.insert(v, low);
            }
        }
        if s.low[v] == s.index[v] {
            let mut set = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                set.push(w.clone());
                if w == v {
                    break;
                }
            }
            s.found.push(set);
        }
    }
    let mut state = State {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        found: Vec::new(),
    };
    for v in edges.keys() {
        if !state.index.contains_key(v) {
            visit(v, &mut state);
        }
    }
    state.found
}

#[test]
fn no_import_circle_in_any_crate() {
    let root = workspace();
    let mut found = Vec::new();
    for krate in ["transport", "sim", "proxy", "bench", "tests", "anchor"] {
        for circle in circles(&root.join(krate).join("src")) {
            found.push(format!("{krate}: {}", circle.join(" -> ")));
        }
    }
    assert!(found.is_empty(), "import circles:\n{}", found.join("\n"));
}

#[test]
fn library_files_and_functions_stay_within_their_bounds() {
    let root = workspace();
    let mut found = Vec::new();
    let limits = [
        ("transport", Some(MAX_FILE_LINES), MAX_FN_LINES),
        ("sim", Some(MAX_FILE_LINES), MAX_FN_LINES),
        ("proxy", Some(MAX_FILE_LINES), MAX_FN_LINES),
        ("anchor", Some(MAX_FILE_LINES), MAX_FN_LINES),
        ("bench", None, MAX_BENCH_FN_LINES),
    ];
    for (krate, file_limit, fn_limit) in limits {
        let mut files = Vec::new();
        rust_files(&root.join(krate).join("src"), &mut files);
        for file in files {
            let src = std::fs::read_to_string(&file).expect("readable source");
            let blanked = blank(&src);
            let name = file
                .strip_prefix(&root)
                .expect("in the workspace")
                .display();
            let lines = blanked[..tests_start(&blanked).unwrap_or(blanked.len())]
                .matches('\n')
                .count();
            if let Some(limit) = file_limit
                && lines > limit
            {
                found.push(format!("{name}: {lines} lines (at most {limit})"));
            }
            for f in long_functions(&blanked, fn_limit) {
                found.push(format!("{name}: fn {f} (at most {fn_limit})"));
            }
        }
    }
    assert!(found.is_empty(), "over their bounds:\n{}", found.join("\n"));
}

#[test]
fn the_checks_see_what_they_look_for() {
    // A circle of three files, and one through a parent that is not an ancestor edge.
    let dir = std::env::temp_dir().join(format!("seam-shape-{}", std::process::id()));
    let src = dir.join("src");
    std::fs::create_dir_all(src.join("c")).expect("temp dir");
    let write = |p: &str, s: &str| std::fs::write(src.join(p), s).expect("write");
    write("lib.rs", "mod a; mod b; mod c;\n");
    write(
        "a.rs",
        "use crate::b::B; // crate::c in a comment is no edge\n",
    );
    write(
        "b.rs",
        "use crate::c::d::D;\nconst S: &str = \"crate::a\";\n",
    );
    write("c/mod.rs", "mod d;\n");
    write("c/d.rs", "use crate::a::A;\nuse super::X;\n");
    let found = circles(&src);
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(found.len(), 1, "{found:?}");
    let mut circle = found[0].clone();
    circle.sort();
    assert_eq!(circle, ["a.rs", "b.rs", "c/d.rs"]);
    // A function's length is its body's, strings and comments blanked.
    let long = format!(
        "fn short() {{ let s = \"{{\"; }}\nfn long() {{\n{}}}\n#[cfg(test)]\nmod tests {{ fn t() {{\n{}}} }}\n",
        "    x();\n".repeat(5),
        "\n".repeat(9)
    );
    assert_eq!(
        long_functions(&blank(&long), 4),
        ["long at line 2 (6 lines)"]
    );
}

/// The module names a source file declares (`mod x;`, `pub mod x;`, `pub(crate) mod x {`),
/// test modules aside.
fn declared_modules(blanked: &str) -> Vec<String> {
    let end = tests_start(blanked).unwrap_or(blanked.len());
    blanked[..end]
        .lines()
        .filter_map(|line| {
            let line = line.trim_start();
            let rest = line
                .strip_prefix("pub(crate) mod ")
                .or_else(|| line.strip_prefix("pub mod "))
                .or_else(|| line.strip_prefix("mod "))?;
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            (!name.is_empty() && name != "tests").then_some(name)
        })
        .collect()
}

/// The `# Layout` section of a module root's docs (`//!` lines), if it has one.
fn layout_section(src: &str) -> Option<String> {
    let docs: Vec<&str> = src
        .lines()
        .take_while(|l| l.starts_with("//!") || l.trim().is_empty())
        .filter_map(|l| l.strip_prefix("//!"))
        .collect();
    let at = docs.iter().position(|l| l.trim() == "# Layout")?;
    let rest = docs[at + 1..]
        .iter()
        .take_while(|l| !l.trim_start().starts_with("# "))
        .copied()
        .collect::<Vec<_>>()
        .join("\n");
    Some(rest)
}

#[test]
fn every_layout_lists_its_modules_and_the_tests_crate_its_files() {
    let root = workspace();
    let mut found = Vec::new();
    for krate in ["transport", "sim", "proxy", "bench", "tests", "anchor"] {
        let mut files = Vec::new();
        rust_files(&root.join(krate).join("src"), &mut files);
        for file in files {
            let src = std::fs::read_to_string(&file).expect("readable source");
            let Some(layout) = layout_section(&src) else {
                continue;
            };
            let name = file
                .strip_prefix(&root)
                .expect("in the workspace")
                .display();
            for module in declared_modules(&blank(&src)) {
                let listed = [
                    format!("`{module}`"),
                    format!("[`{module}`]"),
                    format!("`{module}/`"),
                    format!("`{module}::"),
                ]
                .iter()
                .any(|form| layout.contains(form.as_str()));
                if !listed {
                    found.push(format!("{name}: its layout does not list `{module}`"));
                }
            }
        }
    }
    let tests_doc = std::fs::read_to_string(root.join("tests/src/lib.rs")).expect("tests crate");
    let mut test_files = Vec::new();
    rust_files(&root.join("tests/tests"), &mut test_files);
    for file in test_files {
        let listed = format!(
            "`tests/{}`",
            file.file_name().expect("a file").to_string_lossy()
        );
        if !tests_doc.contains(&listed) {
            found.push(format!("tests/src/lib.rs does not list {listed}"));
        }
    }
    assert!(
        found.is_empty(),
        "layouts out of step with the tree:\n{}",
        found.join("\n")
    );
}
