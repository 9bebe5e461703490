//! The layer table of `ARCHITECTURE.md` ("Layers") checked against the code: every
//! `crate::` path outside test code must name a module the table lets the module holding
//! it use (itself included), and every module of the crate must be in the table.
//!
//! Test code is what sits under `#[cfg(test)]`, `#[cfg(feature = "testing")]` or
//! `#[cfg(any(test, feature = "testing"))]` (an item, or a module file declared so):
//! tests may use any module. Paths to the crate root's re-exports count as paths to the
//! module they come from; the root's own items (`read`, `write`, ...) count as `pipeline`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// One row of the table: its layer and, for each module of the row, what it may use.
struct Table {
    layer: BTreeMap<String, u32>,
    may_use: BTreeMap<String, BTreeSet<String>>,
}

/// The names in backticks of `cell`, without those holding `::` (a submodule named for
/// its content, not a module of the crate).
fn backticked(cell: &str) -> Vec<String> {
    cell.split('`')
        .skip(1)
        .step_by(2)
        .filter(|n| !n.contains("::"))
        .map(str::to_string)
        .collect()
}

/// The table of `doc` (the "Layers" section of ARCHITECTURE.md): rows
/// `| N name | modules | may use |`, where "may use" is "nothing" (or "nothing of the
/// crate"), "everything below", or backticked modules and "layers A-B".
fn read_table(doc: &str) -> Table {
    let rows: Vec<(u32, Vec<String>, String)> = doc
        .lines()
        .skip_while(|l| !l.starts_with("## Layers"))
        .skip(1)
        .take_while(|l| !l.starts_with("## "))
        .filter(|l| l.starts_with("| ") && !l.starts_with("| layer"))
        .filter_map(|l| {
            let cells: Vec<&str> = l.trim_matches('|').split('|').map(str::trim).collect();
            let layer: u32 = cells.first()?.split(' ').next()?.parse().ok()?;
            Some((layer, backticked(cells.get(1)?), cells.get(2)?.to_string()))
        })
        .collect();
    assert!(
        !rows.is_empty(),
        "no layer table under \"## Layers\" in ARCHITECTURE.md"
    );
    let mut layer = BTreeMap::new();
    for (n, modules, _) in &rows {
        for m in modules {
            assert!(
                layer.insert(m.clone(), *n).is_none(),
                "module {m} is in two rows of the layer table"
            );
        }
    }
    let of_layers = |lo: u32, hi: u32| -> Vec<String> {
        layer
            .iter()
            .filter(|(_, &n)| (lo..=hi).contains(&n))
            .map(|(m, _)| m.clone())
            .collect()
    };
    let mut may_use = BTreeMap::new();
    for (n, modules, uses) in &rows {
        let mut allowed: BTreeSet<String> = backticked(uses).into_iter().collect();
        if uses.contains("everything below") && *n > 0 {
            allowed.extend(of_layers(0, n - 1));
        }
        if let Some(rest) = uses.split("layers ").nth(1) {
            let range: Vec<u32> = rest
                .split(|c: char| !c.is_ascii_digit())
                .filter(|s| !s.is_empty())
                .take(2)
                .filter_map(|s| s.parse().ok())
                .collect();
            if let [lo, hi] = range[..] {
                allowed.extend(of_layers(lo, hi));
            }
        }
        for u in &allowed {
            assert!(
                layer.contains_key(u),
                "the layer table lets a module use {u}, which is in no row"
            );
        }
        for m in modules {
            may_use.insert(m.clone(), allowed.clone());
        }
    }
    Table { layer, may_use }
}

/// `src` with comments, string and character literals blanked (lengths kept), so that
/// braces and paths are only the code's.
fn code_only(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = b.to_vec();
    let mut i = 0;
    let blank = |out: &mut Vec<u8>, from: usize, to: usize| {
        for x in &mut out[from..to] {
            if *x != b'\n' {
                *x = b' ';
            }
        }
    };
    while i < b.len() {
        match b[i] {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                let end = src[i..].find('\n').map_or(b.len(), |e| i + e);
                blank(&mut out, i, end);
                i = end;
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                let end = src[i + 2..].find("*/").map_or(b.len(), |e| i + 2 + e + 2);
                blank(&mut out, i, end);
                i = end;
            }
            b'r' if matches!(b.get(i + 1), Some(b'"') | Some(b'#')) && raw_start(b, i) => {
                let hashes = b[i + 1..].iter().take_while(|&&c| c == b'#').count();
                if b.get(i + 1 + hashes) != Some(&b'"') {
                    i += 1;
                    continue;
                }
                let close = format!("\"{}", "#".repeat(hashes));
                let start = i + 2 + hashes;
                let end = src[start..]
                    .find(&close)
                    .map_or(b.len(), |e| start + e + close.len());
                blank(&mut out, i, end);
                i = end;
            }
            b'"' => {
                let mut j = i + 1;
                while j < b.len() && b[j] != b'"' {
                    j += if b[j] == b'\\' { 2 } else { 1 };
                }
                let end = (j + 1).min(b.len());
                blank(&mut out, i, end);
                i = end;
            }
            b'\'' => {
                // a character literal ('x', '\n', '\u{..}'), or a lifetime ('a)
                let end = if b.get(i + 1) == Some(&b'\\') {
                    src[i + 2..].find('\'').map(|e| i + 2 + e + 1)
                } else {
                    let c = src[i + 1..].chars().next().map_or(1, char::len_utf8);
                    (b.get(i + 1 + c) == Some(&b'\'')).then_some(i + 2 + c)
                };
                match end {
                    Some(end) => {
                        blank(&mut out, i, end);
                        i = end;
                    }
                    None => i += 1,
                }
            }
            _ => i += 1,
        }
    }
    String::from_utf8(out).unwrap_or_default()
}

/// True when the `r` at `i` starts a raw string (`r"`, `r#"`, `br"`): no identifier
/// character before it but a `b` that starts one itself.
fn raw_start(b: &[u8], i: usize) -> bool {
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    match i {
        0 => true,
        1 => !ident(b[0]) || b[0] == b'b',
        _ => !ident(b[i - 1]) || (b[i - 1] == b'b' && !ident(b[i - 2])),
    }
}

/// True for an attribute that makes an item test code.
fn test_only(attr: &str) -> bool {
    let a: String = attr.chars().filter(|c| !c.is_whitespace()).collect();
    a == "#[cfg(test)]"
        || a == "#[cfg(feature=\"testing\")]"
        || a == "#[cfg(any(test,feature=\"testing\"))]"
}

/// The byte ranges of the items under a test-only attribute in `code` (from
/// [`code_only`], where the feature's name is blanked: the attributes are read from the
/// source `src`), and the names of the modules such items declare without a body.
fn test_items(src: &str, code: &str) -> (Vec<(usize, usize)>, Vec<String>) {
    let b = code.as_bytes();
    let mut ranges = Vec::new();
    let mut files = Vec::new();
    let mut from = 0;
    while let Some(at) = code[from..].find("#[cfg(").map(|e| from + e) {
        let Some(close) = code[at..].find(']').map(|e| at + e + 1) else {
            break;
        };
        from = close;
        if !test_only(&src[at..close]) {
            continue;
        }
        // the item: up to its first `;` or the brace that closes its first `{`
        let mut depth = 0usize;
        let mut j = close;
        let mut end = b.len();
        while j < b.len() {
            match b[j] {
                b'[' | b'(' => depth += 1,
                b']' | b')' => depth = depth.saturating_sub(1),
                b';' if depth == 0 => {
                    end = j + 1;
                    break;
                }
                b'{' if depth == 0 => {
                    let mut braces = 0usize;
                    let mut k = j;
                    while k < b.len() {
                        match b[k] {
                            b'{' => braces += 1,
                            b'}' => {
                                braces -= 1;
                                if braces == 0 {
                                    break;
                                }
                            }
                            _ => {}
                        }
                        k += 1;
                    }
                    end = (k + 1).min(b.len());
                    break;
                }
                _ => {}
            }
            j += 1;
        }
        let item = code[close..end].trim();
        let words: Vec<&str> = item
            .split(|c: char| c.is_whitespace() || c == ';')
            .filter(|w| !w.is_empty())
            .collect();
        if item.ends_with(';') {
            if let Some(p) = words.iter().position(|w| *w == "mod") {
                if let Some(name) = words.get(p + 1) {
                    files.push(name.to_string());
                }
            }
        }
        ranges.push((at, end));
        from = end;
    }
    (ranges, files)
}

/// The first segment of every `crate::` path in `code` outside `skip`, with its line.
fn crate_paths(code: &str, skip: &[(usize, usize)]) -> Vec<(String, usize)> {
    let mut out = Vec::new();
    let b = code.as_bytes();
    for (at, _) in code.match_indices("crate::") {
        let before = if at > 0 { b[at - 1] } else { b' ' };
        if before.is_ascii_alphanumeric() || before == b'_' || before == b'$' {
            continue;
        }
        if skip.iter().any(|&(s, e)| (s..e).contains(&at)) {
            continue;
        }
        let line = code[..at].matches('\n').count() + 1;
        let rest = &code[at + "crate::".len()..];
        let names: Vec<String> = if let Some(group) = rest.strip_prefix('{') {
            // `crate::{a, b::c, d}`: the first segment of each path of the group
            let mut depth = 0usize;
            let mut part = String::new();
            let mut parts = Vec::new();
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => parts.push(std::mem::take(&mut part)),
                    _ => part.push(c),
                }
            }
            parts.push(part);
            parts
                .iter()
                .filter_map(|p| {
                    p.trim()
                        .split("::")
                        .next()
                        .map(str::trim)
                        .map(str::to_string)
                })
                .filter(|n| !n.is_empty())
                .collect()
        } else {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            vec![name]
        };
        out.extend(names.into_iter().map(|n| (n, line)));
    }
    out
}

/// The module each name the crate root re-exports comes from (`pub use m::{A, b};`),
/// from `lib.rs`'s code.
fn root_exports(lib: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for stmt in lib.split(';') {
        let s = stmt.trim();
        let Some(path) = s
            .rsplit("pub use ")
            .next()
            .filter(|_| s.contains("pub use "))
        else {
            continue;
        };
        let path = path.trim().trim_start_matches("crate::");
        let Some((module, names)) = path.split_once("::") else {
            continue;
        };
        for n in names
            .trim_matches(|c| c == '{' || c == '}')
            .split(',')
            .map(str::trim)
            .filter(|n| !n.is_empty())
        {
            out.insert(n.to_string(), module.trim().to_string());
        }
    }
    out
}

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The directory of the modules `file` declares (`a/mod.rs`, `lib.rs`: its own directory;
/// `a/b.rs`: `a/b`).
fn module_dir(file: &Path) -> PathBuf {
    let name = file.file_stem().and_then(|s| s.to_str()).unwrap_or("");
    let parent = file.parent().map(Path::to_path_buf).unwrap_or_default();
    match name {
        "mod" | "lib" | "main" => parent,
        _ => parent.join(name),
    }
}

#[test]
fn every_module_uses_only_what_its_layer_allows() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(root.join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    let table = read_table(&doc);
    let src = root.join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    // read every file once; the module files declared as test code, and everything under
    // their directories, are left out
    let texts: Vec<(PathBuf, String, String)> = files
        .iter()
        .map(|f| {
            let text = std::fs::read_to_string(f).expect("a source file");
            let code = code_only(&text);
            (f.clone(), text, code)
        })
        .collect();
    let mut test_dirs: Vec<PathBuf> = Vec::new();
    let mut items = BTreeMap::new();
    for (f, text, code) in &texts {
        let (ranges, declared) = test_items(text, code);
        for name in declared {
            let dir = module_dir(f);
            test_dirs.push(dir.join(format!("{name}.rs")));
            test_dirs.push(dir.join(name));
        }
        items.insert(f.clone(), ranges);
    }
    let lib = &texts
        .iter()
        .find(|(f, _, _)| f == &src.join("lib.rs"))
        .expect("src/lib.rs")
        .2;
    let exports = root_exports(lib);
    let modules: BTreeSet<String> = texts
        .iter()
        .filter_map(|(f, _, _)| {
            let first = f.strip_prefix(&src).ok()?.components().next()?;
            let name = first
                .as_os_str()
                .to_str()?
                .trim_end_matches(".rs")
                .to_string();
            (name != "lib" && name != "main").then_some(name)
        })
        .collect();
    let mut problems = Vec::new();
    for m in &modules {
        if !table.layer.contains_key(m) && m != "layers" {
            problems.push(format!(
                "module {m} is in no row of ARCHITECTURE.md's layer table"
            ));
        }
    }
    for (f, _, code) in &texts {
        if test_dirs.iter().any(|d| f.starts_with(d)) {
            continue;
        }
        let rel = f.strip_prefix(&src).unwrap_or(f);
        let Some(module) = rel
            .components()
            .next()
            .and_then(|c| c.as_os_str().to_str())
            .map(|s| s.trim_end_matches(".rs").to_string())
        else {
            continue;
        };
        let Some(allowed) = table.may_use.get(&module) else {
            continue;
        };
        for (name, line) in crate_paths(code, &items[f]) {
            let target = if modules.contains(&name) {
                name.clone()
            } else {
                exports
                    .get(&name)
                    .cloned()
                    .unwrap_or_else(|| "pipeline".to_string())
            };
            if target != module && !allowed.contains(&target) {
                problems.push(format!(
                    "src/{}:{line}: {module} (layer {}) uses crate::{name} ({target}, layer {}), which its row does not allow",
                    rel.display(),
                    table.layer[&module],
                    table.layer.get(&target).map_or("none".to_string(), u32::to_string),
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_checker_sees_paths_outside_test_items_only() {
    let src = "use crate::mesh::Mesh;\n\
               // crate::pipeline in a comment\n\
               fn f() { let s = \"crate::cli\"; let c = '{'; crate::quality::eta(); }\n\
               #[cfg(test)]\nmod tests { use crate::pipeline; fn g() { if true { } } }\n\
               #[cfg(any(test, feature = \"testing\"))]\nmod oracle;\n\
               use crate::{msh::read, par};\n\
               const R: &[u8] = br\"crate::cli \\\"; use crate::keysort;\n";
    let code = code_only(src);
    let (ranges, declared) = test_items(src, &code);
    assert_eq!(declared, vec!["oracle".to_string()]);
    let names: Vec<String> = crate_paths(&code, &ranges)
        .into_iter()
        .map(|p| p.0)
        .collect();
    assert_eq!(names, ["mesh", "quality", "msh", "par", "keysort"]);
    let table = read_table(
        "## Layers\n\n| layer | modules | may use |\n|---|---|---|\n\
         | 2 top | `a` | everything below |\n| 1 mid | `b`, `c` | layers 0-0 and `d` |\n\
         | 1 solver | `d` | nothing |\n| 0 base | `e` | nothing of the crate |\n\n## Next\n",
    );
    let set = |m: &str| table.may_use[m].iter().cloned().collect::<Vec<_>>();
    assert_eq!(set("a"), ["b", "c", "d", "e"]);
    assert_eq!(set("b"), ["d", "e"]);
    assert!(set("d").is_empty() && set("e").is_empty());
}
