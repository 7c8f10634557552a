//! In every crate of the workspace, the modules depend on each other one way only: no module
//! reaches itself through the paths (`crate::…`, `super::…`, a `mod.rs` naming its children)
//! used in the code of `src/` (comments and `#[cfg(test)]` parts left out), neither between
//! module files nor between the top-level modules they belong to.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Module = Vec<String>;

/// Every `.rs` file under `dir` with its module path (`lib.rs`: the root, `a/mod.rs`: `a`).
fn module_files(src: &Path, dir: &Path, out: &mut BTreeMap<Module, PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            module_files(src, &path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let rel = path.strip_prefix(src).unwrap().with_extension("");
            let mut module: Module = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            if matches!(
                module.last().map(String::as_str),
                Some("mod" | "lib" | "main")
            ) {
                module.pop();
            }
            out.insert(module, path);
        }
    }
}

/// The code of a file: comments and everything from the first `#[cfg(test)]` removed.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    text.lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Paths such as `crate::a::b` or `super::c` in `code`, `use x::{y, z::w}` groups expanded
/// one level.
fn paths(code: &str) -> Vec<Vec<String>> {
    let is_ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = Vec::new();
    let bytes: Vec<char> = code.chars().collect();
    let mut i = 0;
    while i < bytes.len() {
        if !is_ident(bytes[i]) || (i > 0 && (is_ident(bytes[i - 1]) || bytes[i - 1] == ':')) {
            i += 1;
            continue;
        }
        // Read `ident(::ident)*` and an optional `::{ … }` group.
        let mut parts = Vec::new();
        let mut j = i;
        loop {
            let start = j;
            while j < bytes.len() && is_ident(bytes[j]) {
                j += 1;
            }
            parts.push(bytes[start..j].iter().collect::<String>());
            if j + 2 < bytes.len() && bytes[j] == ':' && bytes[j + 1] == ':' {
                if bytes[j + 2] == '{' {
                    let close = (j + 3..bytes.len()).find(|&k| bytes[k] == '}').unwrap();
                    let group: String = bytes[j + 3..close].iter().collect();
                    for item in group.split(',') {
                        let item = item.trim();
                        if !item.is_empty() {
                            let mut p = parts.clone();
                            p.extend(item.split("::").map(|s| s.trim().to_string()));
                            out.push(p);
                        }
                    }
                    j = close + 1;
                    parts.clear();
                    break;
                }
                j += 2;
                continue;
            }
            break;
        }
        if parts.len() > 1 {
            out.push(parts);
        }
        i = j.max(i + 1);
    }
    out
}

/// The `src/` folder of every crate of the workspace, by crate folder name.
fn crate_sources() -> Vec<(String, PathBuf)> {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let mut out: Vec<(String, PathBuf)> = std::fs::read_dir(crates)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.join("src").is_dir())
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                p.join("src"),
            )
        })
        .collect();
    out.sort();
    out
}

/// Dependencies between the module files of the crate whose sources are `src`.
fn file_graph(src: &Path) -> BTreeMap<Module, BTreeSet<Module>> {
    let mut files = BTreeMap::new();
    module_files(src, src, &mut files);
    let known: BTreeSet<Module> = files.keys().cloned().collect();
    // The longest module that a path starts with (never the root: `crate::NetError` and
    // other root re-exports are not dependencies on every module).
    let resolve = |p: &[String]| -> Option<Module> {
        (1..=p.len())
            .rev()
            .map(|n| p[..n].to_vec())
            .find(|m| known.contains(m))
    };
    let mut graph = BTreeMap::new();
    for (me, file) in &files {
        let dir_module =
            file.ends_with("mod.rs") || file.ends_with("lib.rs") || file.ends_with("main.rs");
        let here: Module = if dir_module {
            me.clone()
        } else {
            me[..me.len() - 1].to_vec()
        };
        let mut deps = BTreeSet::new();
        for p in paths(&code(&std::fs::read_to_string(file).unwrap())) {
            let target = match p[0].as_str() {
                "crate" => resolve(&p[1..]),
                "super" => {
                    let mut base = me[..me.len().saturating_sub(1)].to_vec();
                    let mut rest = &p[1..];
                    while rest.first().is_some_and(|s| s == "super") {
                        base.pop();
                        rest = &rest[1..];
                    }
                    base.extend(rest.iter().cloned());
                    resolve(&base)
                }
                "self" => resolve(&[here.clone(), p[1..].to_vec()].concat()),
                first if dir_module => {
                    let child = [here.clone(), vec![first.to_string()]].concat();
                    known.contains(&child).then_some(child)
                }
                _ => None,
            };
            if let Some(t) = target
                && &t != me
            {
                deps.insert(t);
            }
        }
        graph.insert(me.clone(), deps);
    }
    graph
}

/// A cycle of `graph`, if there is one.
fn find_cycle(graph: &BTreeMap<Module, BTreeSet<Module>>) -> Option<Vec<Module>> {
    fn visit(
        v: &Module,
        graph: &BTreeMap<Module, BTreeSet<Module>>,
        state: &mut BTreeMap<Module, u8>,
        stack: &mut Vec<Module>,
    ) -> Option<Vec<Module>> {
        state.insert(v.clone(), 1);
        stack.push(v.clone());
        for w in graph.get(v).into_iter().flatten() {
            match state.get(w).copied().unwrap_or(0) {
                0 => {
                    if let Some(c) = visit(w, graph, state, stack) {
                        return Some(c);
                    }
                }
                1 => {
                    let at = stack.iter().position(|m| m == w).unwrap();
                    return Some(stack[at..].to_vec());
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(v.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for v in graph.keys() {
        if state.get(v).copied().unwrap_or(0) == 0
            && let Some(c) = visit(v, graph, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

fn show(cycle: &[Module]) -> String {
    cycle
        .iter()
        .map(|m| m.join("::"))
        .collect::<Vec<_>>()
        .join(" → ")
}

#[test]
fn module_files_depend_one_way() {
    let crates = crate_sources();
    assert!(crates.len() >= 10, "only {} crates found", crates.len());
    for (name, src) in &crates {
        let graph = file_graph(src);
        assert!(!graph.is_empty(), "{name}: no module files");
        if let Some(c) = find_cycle(&graph) {
            panic!("{name}: module cycle: {}", show(&c));
        }
    }
    let net = crate_sources()
        .into_iter()
        .find(|(n, _)| n == "net")
        .unwrap()
        .1;
    assert!(
        file_graph(&net).len() > 20,
        "the net crate's module files were not all found"
    );
}

/// The top-level modules of a crate (the files and folders under `src/`) and which others
/// each one uses.
fn top_level_graph(src: &Path) -> BTreeMap<Module, BTreeSet<Module>> {
    let mut top: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for (from, deps) in file_graph(src) {
        let Some(a) = from.first() else { continue };
        let entry = top.entry(vec![a.clone()]).or_default();
        for d in deps {
            if d[0] != *a {
                entry.insert(vec![d[0].clone()]);
            }
        }
    }
    top
}

#[test]
fn top_level_modules_depend_one_way() {
    for (name, src) in crate_sources() {
        let top = top_level_graph(&src);
        if name == "net" {
            assert!(
                top[&vec!["train".to_string()]].contains(&vec!["model".to_string()]),
                "the graph misses train → model"
            );
        }
        if let Some(c) = find_cycle(&top) {
            panic!("{name}: module cycle: {}", show(&c));
        }
    }
}
