//! `cargo xtask circles`: no two source files of a crate import each other, directly or through a
//! cycle. Per crate, every file under `src/` is a module (`a.rs` and `a/mod.rs` are `a`, `a/b.rs` is
//! `a::b`); a file imports the module that a `crate::…` or `super::…` path in it resolves to (the
//! longest prefix that is a module). The crate root is left out of the graph: its `pub use` lines
//! re-export, they are not a dependency of the root on its modules' users.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module path of every `.rs` file under `src` (the root file as the empty path).
fn modules(src: &Path) -> BTreeMap<String, PathBuf> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(src).unwrap_or(&p).with_extension("");
                let mut parts: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                if parts.last().is_some_and(|l| l == "mod") {
                    parts.pop();
                }
                if parts.len() == 1 && ["lib", "main"].contains(&parts[0].as_str()) {
                    parts.clear();
                }
                out.insert(parts.join("::"), p);
            }
        }
    }
    out
}

/// The `crate::`/`super::` paths of a file's text, each as its segments (braced groups expanded).
fn paths(text: &str, module: &str) -> Vec<Vec<String>> {
    let code: String = text
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    let mut out = Vec::new();
    for (anchor, base) in [("crate::", Vec::new()), ("super::", parent(module))] {
        let mut rest = code.as_str();
        while let Some(i) = rest.find(anchor) {
            let before = rest[..i].chars().last();
            rest = &rest[i + anchor.len()..];
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
                continue;
            }
            expand(rest, &base, &mut out);
        }
    }
    out
}

fn parent(module: &str) -> Vec<String> {
    let mut p: Vec<String> = module
        .split("::")
        .filter(|s| !s.is_empty())
        .map(String::from)
        .collect();
    p.pop();
    p
}

/// Segments of the path at the start of `rest`, under `base`; a `{…}` group adds one path per item.
fn expand(rest: &str, base: &[String], out: &mut Vec<Vec<String>>) {
    let mut segs = base.to_vec();
    let mut s = rest;
    loop {
        let end = s
            .find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(s.len());
        if end == 0 {
            if let Some(group) = s.strip_prefix('{') {
                let mut depth = 0;
                let mut start = 0;
                for (i, c) in group.char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' if depth == 0 => {
                            expand(group[start..i].trim(), &segs, out);
                            return;
                        }
                        '}' => depth -= 1,
                        ',' if depth == 0 => {
                            expand(group[start..i].trim(), &segs, out);
                            start = i + 1;
                        }
                        _ => {}
                    }
                }
            }
            break;
        }
        segs.push(s[..end].to_string());
        s = &s[end..];
        match s.strip_prefix("::") {
            Some(r) => s = r,
            None => break,
        }
    }
    out.push(segs);
}

/// Items the crate root re-exports (`pub use module::…::Name`): name → the module it comes from, so
/// that `crate::Name` counts as an import of that module.
fn root_reexports(mods: &BTreeMap<String, PathBuf>) -> BTreeMap<String, String> {
    let text = mods
        .get("")
        .and_then(|p| std::fs::read_to_string(p).ok())
        .unwrap_or_default();
    let mut out = BTreeMap::new();
    for stmt in text.split(';') {
        let Some(i) = stmt.find("pub use ") else {
            continue;
        };
        let mut found = Vec::new();
        expand(
            stmt[i + 8..].trim().trim_start_matches("crate::"),
            &[],
            &mut found,
        );
        for p in found {
            let module = (1..p.len())
                .rev()
                .map(|k| p[..k].join("::"))
                .find(|cand| mods.contains_key(cand));
            if let (Some(m), Some(name)) = (module, p.last()) {
                out.insert(name.clone(), m);
            }
        }
    }
    out
}

/// The module-to-module import edges of one crate (root excluded, self-references dropped).
pub fn edges(src: &Path) -> BTreeSet<(String, String)> {
    let mods = modules(src);
    let reexports = root_reexports(&mods);
    let mut out = BTreeSet::new();
    for (m, file) in &mods {
        if m.is_empty() {
            continue;
        }
        let text = std::fs::read_to_string(file).unwrap_or_default();
        for p in paths(&text, m) {
            let target = (1..=p.len())
                .rev()
                .map(|k| p[..k].join("::"))
                .find(|cand| mods.contains_key(cand))
                .or_else(|| p.first().and_then(|n| reexports.get(n)).cloned());
            if let Some(t) = target
                && t != *m
                && !t.is_empty()
                // A module's own submodules are its parts, not its imports.
                && !t.starts_with(&format!("{m}::"))
            {
                out.insert((m.clone(), t));
            }
        }
    }
    out
}

/// The cycles among `edges`: each strongly connected set of two or more modules.
pub fn cycles(edges: &BTreeSet<(String, String)>) -> Vec<Vec<String>> {
    let nodes: BTreeSet<&String> = edges.iter().flat_map(|(a, b)| [a, b]).collect();
    let reach = |from: &String| {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.clone()];
        while let Some(n) = stack.pop() {
            for (a, b) in edges {
                if *a == n && seen.insert(b.clone()) {
                    stack.push(b.clone());
                }
            }
        }
        seen
    };
    let reachable: BTreeMap<&String, BTreeSet<String>> =
        nodes.iter().map(|n| (*n, reach(n))).collect();
    let mut done = BTreeSet::new();
    let mut out = Vec::new();
    for n in &nodes {
        if done.contains(*n) {
            continue;
        }
        let scc: Vec<String> = nodes
            .iter()
            .filter(|m| reachable[*n].contains(**m) && reachable[**m].contains(*n))
            .map(|m| (*m).clone())
            .collect();
        done.extend(scc.iter().cloned());
        if scc.len() > 1 {
            out.push(scc);
        }
    }
    out
}

/// Every crate's `src` folder under the workspace's `crates/`.
pub fn crate_sources(root: &Path) -> Vec<(String, PathBuf)> {
    let mut out: Vec<(String, PathBuf)> = std::fs::read_dir(root.join("crates"))
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.join("src").is_dir())
        .map(|p| {
            (
                p.file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned(),
                p.join("src"),
            )
        })
        .collect();
    out.sort();
    out
}

/// Prints every crate's edges and cycles; `false` when a crate has a cycle.
pub fn run(root: &Path) -> bool {
    let mut ok = true;
    for (name, src) in crate_sources(root) {
        let e = edges(&src);
        let c = cycles(&e);
        println!("{name}: {} import edges, {} cycles", e.len(), c.len());
        for (a, b) in &e {
            println!("  {a} -> {b}");
        }
        for cycle in &c {
            println!("  CYCLE: {}", cycle.join(" <-> "));
            ok = false;
        }
    }
    ok
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(files: &[(&str, &str)], expected_cycles: usize) {
        let dir = tempfile::tempdir().unwrap();
        for (name, text) in files {
            let p = dir.path().join(name);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
        let c = cycles(&edges(dir.path()));
        assert_eq!(c.len(), expected_cycles, "{c:?}");
    }

    #[test]
    fn a_two_file_circle_is_found() {
        check(
            &[
                ("lib.rs", "mod a; mod b;"),
                ("a.rs", "use crate::b::X;"),
                ("b.rs", "use crate::{a::Y, c};"),
            ],
            1,
        );
    }

    #[test]
    fn a_circle_through_super_and_a_three_file_circle_are_found() {
        check(
            &[
                ("lib.rs", "mod s; mod p; mod q; mod r;"),
                ("s/mod.rs", "mod t; use crate::p::Z;"),
                ("s/t.rs", "use super::W;"),
                ("p.rs", "use crate::q::A;"),
                ("q.rs", "use crate::r::B;"),
                ("r.rs", "fn f() { crate::p::g() }"),
            ],
            1,
        );
    }

    #[test]
    fn a_circle_through_a_root_reexport_is_found() {
        check(
            &[
                ("lib.rs", "mod a; mod b; pub use b::{Thing, other::X};"),
                ("a.rs", "fn f(x: &crate::Thing) {}"),
                ("b.rs", "use crate::a::f;"),
            ],
            1,
        );
    }

    #[test]
    fn one_way_imports_and_comments_are_no_circle() {
        check(
            &[
                ("lib.rs", "pub use a::X; mod a; mod b;"),
                ("a.rs", "// crate::b::Y in a comment\nuse crate::X;"),
                ("b.rs", "use crate::a::X;"),
            ],
            0,
        );
    }

    /// The invariant of ARCHITECTURE.md, on the workspace itself.
    #[test]
    fn no_crate_of_the_workspace_has_a_file_circle() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        for (name, src) in crate_sources(&root) {
            let c = cycles(&edges(&src));
            assert!(c.is_empty(), "crate {name}: circles {c:?}");
        }
    }
}
