//! The core's shape, as docs/architecture.md describes it: its top-level
//! modules import one another in one direction (no circle, test modules
//! included), and no source file of the core outgrows a reading.
//!
//! An import is any path `crate::NAME` (or `crate::{NAME, ..}`) outside a
//! comment in a file of module `A` that names another top-level module
//! `NAME`: `A` depends on `NAME`. Doc comments are comments: a doc link
//! to a higher module is not an import.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// The longest a source file of the core may be.
const MAX_LINES: usize = 1000;

/// The core's top-level modules, bottom up: each may import only those
/// before it (the order of docs/architecture.md and the crate docs).
const LAYERS: [&str; 20] = [
    "math",
    "sampler",
    "geometry",
    "camera",
    "error",
    "light",
    "material",
    "analysis",
    "scene",
    "parse",
    "stats",
    "highlight",
    "caustic",
    "integrator",
    "film",
    "render",
    "budget",
    "multicore",
    "denoise",
    "demo",
];

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../src")
}

/// Every `.rs` file below `dir`.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The top-level module a file of the core belongs to (`None`: lib.rs).
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel.components().next()?.as_os_str().to_str()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    (name != "lib").then(|| name.to_string())
}

/// `text` without its `//` comments (doc comments included) and block
/// comments. String literals in the core hold no `//` that matters here.
fn strip_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find('/') {
        out.push_str(&rest[..i]);
        let tail = &rest[i..];
        if tail.starts_with("//") {
            rest = tail.find('\n').map_or("", |j| &tail[j..]);
        } else if tail.starts_with("/*") {
            rest = tail.find("*/").map_or("", |j| &tail[j + 2..]);
        } else {
            out.push('/');
            rest = &tail[1..];
        }
    }
    out.push_str(rest);
    out
}

/// The identifiers named right after `crate::`, including each one of a
/// `crate::{a, b::c}` group.
fn crate_paths(code: &str) -> Vec<String> {
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    let mut out = Vec::new();
    for (i, _) in code.match_indices("crate::") {
        let after = &code[i + "crate::".len()..];
        if let Some(group) = after.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            // only the group's top level: `a, b::{c, d}, e`
            let mut depth = 0;
            let mut start = true;
            for (k, c) in group[..end].char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => start = true,
                    c if start && !c.is_whitespace() => {
                        out.push(ident(&group[k..]));
                        start = false;
                    }
                    _ => {}
                }
            }
        } else {
            out.push(ident(after));
        }
    }
    out
}

/// Module -> module it imports -> the files that do.
type Graph = BTreeMap<String, BTreeMap<String, BTreeSet<String>>>;

fn module_graph() -> (Graph, BTreeSet<String>) {
    let src = src_dir();
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let modules: BTreeSet<String> = files.iter().filter_map(|f| module_of(&src, f)).collect();
    let mut graph = Graph::new();
    for f in &files {
        let Some(m) = module_of(&src, f) else {
            continue;
        };
        let code = strip_comments(&fs::read_to_string(f).unwrap());
        for t in crate_paths(&code) {
            if t != m && modules.contains(&t) {
                let rel = f.strip_prefix(&src).unwrap().display().to_string();
                graph
                    .entry(m.clone())
                    .or_default()
                    .entry(t)
                    .or_default()
                    .insert(rel);
            }
        }
    }
    (graph, modules)
}

/// A circle of the graph, if it has one: the modules along it, first
/// repeated at the end.
fn find_circle(graph: &Graph, modules: &BTreeSet<String>) -> Option<Vec<String>> {
    // 0 unvisited, 1 on the current path, 2 done
    fn visit(
        m: &str,
        graph: &Graph,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(m.to_string(), 1);
        path.push(m.to_string());
        for next in graph.get(m).into_iter().flat_map(|e| e.keys()) {
            match state.get(next.as_str()).copied().unwrap_or(0) {
                1 => {
                    let from = path.iter().position(|p| p == next).unwrap();
                    let mut c = path[from..].to_vec();
                    c.push(next.clone());
                    return Some(c);
                }
                0 => {
                    if let Some(c) = visit(next, graph, state, path) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        path.pop();
        state.insert(m.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for m in modules {
        if state.get(m.as_str()).copied().unwrap_or(0) == 0
            && let Some(c) = visit(m, graph, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

#[test]
fn the_core_imports_in_one_direction() {
    let (graph, modules) = module_graph();
    // the reader works: the layers the architecture names are there
    for (a, b) in [
        ("integrator", "scene"),
        ("scene", "material"),
        ("material", "error"),
        ("budget", "render"),
    ] {
        assert!(
            graph.get(a).is_some_and(|e| e.contains_key(b)),
            "expected {a} to import {b}: {graph:?}"
        );
    }
    if let Some(circle) = find_circle(&graph, &modules) {
        let steps: Vec<String> = circle
            .windows(2)
            .map(|w| format!("{} -> {} ({:?})", w[0], w[1], graph[&w[0]][&w[1]]))
            .collect();
        panic!(
            "import circle among the core's modules:\n{}",
            steps.join("\n")
        );
    }
}

#[test]
fn each_module_imports_only_the_layers_below_it() {
    let (graph, modules) = module_graph();
    let rank = |m: &str| LAYERS.iter().position(|l| *l == m);
    for m in &modules {
        assert!(
            rank(m).is_some(),
            "module {m} is not in LAYERS (place it, and in docs/architecture.md)"
        );
    }
    for (a, edges) in &graph {
        for (b, files) in edges {
            assert!(
                rank(b) < rank(a),
                "{a} imports {b}, which is not below it ({files:?}); LAYERS: {LAYERS:?}"
            );
        }
    }
}

#[test]
fn the_circle_finder_finds_a_circle() {
    let mut graph = Graph::new();
    let modules: BTreeSet<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
    fn edge(graph: &mut Graph, x: &str, y: &str) {
        graph
            .entry(x.into())
            .or_default()
            .entry(y.into())
            .or_default()
            .insert("f.rs".into());
    }
    edge(&mut graph, "a", "b");
    edge(&mut graph, "b", "c");
    assert_eq!(find_circle(&graph, &modules), None);
    edge(&mut graph, "c", "a");
    let c = find_circle(&graph, &modules).unwrap();
    assert_eq!(c.first(), c.last());
    assert_eq!(c.len(), 4);
}

#[test]
fn imports_are_read_outside_comments_and_in_groups() {
    let code = strip_comments(
        "use crate::{geometry::Vec3, math};\n/// [`crate::parse`]\n// crate::budget\n\
         let x = crate::sampler::mix64(1); /* crate::film */",
    );
    assert_eq!(crate_paths(&code), ["geometry", "math", "sampler"]);
}

#[test]
fn no_core_file_outgrows_a_reading() {
    let mut files = Vec::new();
    rust_files(&src_dir(), &mut files);
    assert!(files.len() > 20);
    let long: Vec<String> = files
        .iter()
        .filter_map(|f| {
            let n = fs::read_to_string(f).unwrap().lines().count();
            (n > MAX_LINES).then(|| format!("{}: {n} lines", f.display()))
        })
        .collect();
    assert!(
        long.is_empty(),
        "core files over {MAX_LINES} lines: {long:?}"
    );
}

/// The longest a function of the core, the harness's library or the build
/// script may be: one screen, so that each does one job that a reader
/// holds in view.
const MAX_FN_LINES: usize = 150;

/// The functions of `text` longer than `max` lines, as `(name, first line,
/// lines)`: a line that starts (after indentation and qualifiers such as
/// `pub(crate)`, `const`, `unsafe`) with `fn NAME` opens one, and the first
/// later line that is its indentation followed by `}` closes it. (rustfmt's
/// layout: a function's closing brace stands alone at the indentation of
/// its signature.)
fn long_functions(text: &str, max: usize) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut found = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let body = line.trim_start();
        let indent = &line[..line.len() - body.len()];
        let mut rest = body;
        for q in [
            "pub(crate) ",
            "pub(super) ",
            "pub ",
            "const ",
            "async ",
            "unsafe ",
        ] {
            rest = rest.strip_prefix(q).unwrap_or(rest);
        }
        let Some(sig) = rest.strip_prefix("fn ") else {
            continue;
        };
        let name: String = sig
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        // a declaration without a body (a trait's) ends on its own line,
        // and so does a one-line function
        let opens = body.matches('{').count();
        if line.trim_end().ends_with(';') || opens > 0 && opens == body.matches('}').count() {
            continue;
        }
        let close = format!("{indent}}}");
        if let Some(end) = lines[i + 1..].iter().position(|l| l.trim_end() == close) {
            let n = end + 2;
            if n > max {
                found.push((name, i + 1, n));
            }
        }
    }
    found
}

#[test]
fn no_function_outgrows_a_screen() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    rust_files(&src_dir(), &mut files);
    rust_files(&root.join("host-tests/src"), &mut files);
    files.push(root.join("build.rs"));
    assert!(files.len() > 30);
    let long: Vec<String> = files
        .iter()
        .flat_map(|f| {
            let text = fs::read_to_string(f).unwrap();
            long_functions(&text, MAX_FN_LINES)
                .into_iter()
                .map(move |(name, at, n)| format!("{}:{at} fn {name}: {n} lines", f.display()))
        })
        .collect();
    assert!(
        long.is_empty(),
        "functions over {MAX_FN_LINES} lines: {long:?}"
    );
}

/// The length check finds a long function (at any indentation, with
/// qualifiers), and leaves short ones and bodiless declarations alone.
#[test]
fn the_length_check_counts_a_function_from_its_signature_to_its_brace() {
    let body = "        let x = 1;\n".repeat(5);
    let text = format!(
        "impl A {{\n    fn short() {{}}\n    pub(crate) const fn long() -> u32 {{\n{body}    }}\n}}\n\
         trait T {{\n    fn decl(&self);\n}}\nfn top() {{\n{body}}}\n"
    );
    assert_eq!(
        long_functions(&text, 6),
        [("long".to_string(), 3, 7), ("top".to_string(), 14, 7)]
    );
    assert!(long_functions(&text, 7).is_empty());
}
