//! No import cycle, between the crate's top-level modules nor between its files: each later
//! feature (a query kind, an accelerator, the GPU) depends on the walk, never the other way
//! round, and inside a module a file that uses another is not used by it (what both need lives
//! in one of them, or in a small file of its own).
//!
//! The check reads the sources. Every path written `crate::…`, `super::…` or `self::…`
//! (`use` groups expanded: `use super::{a::X, b::{c, d}}`) outside test code is resolved to the
//! deepest module that is a file; an item a module re-exports (`pub use child::X`) resolves to
//! the file it comes from. That is an edge from the file the path is written in to that file,
//! except edges from a module to its own submodules: a parent (`mod.rs`, or `x.rs` beside its
//! folder `x/`) declares and re-exports its children, which may use its items. Test code is
//! left out: files named `tests.rs` or `testing.rs` or under a `tests/` folder, and a file's
//! `#[cfg(test)] mod tests` at its end.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

type Graph = BTreeMap<String, BTreeSet<String>>;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The code without comments and test code: here everything from a `#[cfg(test)] mod tests`
/// on is dropped (test modules sit at the end of a file), and comment lines (which may name
/// modules) too. Test files are skipped by [`is_test_file`].
fn non_test(src: &str) -> String {
    let code = match src.find("\n#[cfg(test)]\nmod tests") {
        Some(i) => &src[..i],
        None => src,
    };
    code.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// A file (its path under src/, with `/`) that holds only test code.
fn is_test_file(rel: &str) -> bool {
    rel.split('/')
        .any(|c| c == "tests" || c == "tests.rs" || c == "testing.rs")
}

/// The module a file is: `accel/mod.rs` and `accel.rs` are `accel`, `lib.rs` the crate root.
fn module_of(rel: &str) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .trim_end_matches(".rs")
        .split('/')
        .map(String::from)
        .collect();
    if parts.last().is_some_and(|p| p == "mod") || parts == ["lib"] {
        parts.pop();
    }
    parts
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

fn ident_at(code: &str, i: usize) -> &str {
    let n = code.as_bytes()[i..]
        .iter()
        .take_while(|&&c| is_ident(c))
        .count();
    &code[i..i + n]
}

fn skip_ws(code: &str, mut i: usize) -> usize {
    while i < code.len() && code.as_bytes()[i].is_ascii_whitespace() {
        i += 1;
    }
    i
}

/// Parses the path or `use` tree at `code[i..]` (segments so far in `prefix`), pushes each
/// full path to `out`, and returns where it ends. A glob (`*`) ends its path at the module.
fn tree(code: &str, mut i: usize, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) -> usize {
    let depth = prefix.len();
    let mut group = false;
    loop {
        i = skip_ws(code, i);
        if i >= code.len() {
            break;
        }
        if code[i..].starts_with('{') {
            group = true;
            i += 1;
            loop {
                i = skip_ws(code, i);
                if i >= code.len() {
                    break;
                }
                if code[i..].starts_with('}') {
                    i += 1;
                    break;
                }
                let before = i;
                i = skip_ws(code, tree(code, i, prefix, out));
                if code[i..].starts_with("as ") {
                    i = skip_ws(code, i + 3);
                    i += ident_at(code, i).len();
                    i = skip_ws(code, i);
                }
                if code[i..].starts_with(',') {
                    i += 1;
                } else if !code[i..].starts_with('}') && i == before {
                    i += 1; // not a path: step over it
                }
            }
            break;
        }
        if code[i..].starts_with('*') {
            i += 1;
            break;
        }
        let w = ident_at(code, i);
        if w.is_empty() {
            break;
        }
        prefix.push(w.to_string());
        i += w.len();
        let j = skip_ws(code, i);
        if code[j..].starts_with("::") {
            i = j + 2;
        } else {
            break;
        }
    }
    if !group && prefix.len() > depth {
        out.push(prefix.clone());
    }
    prefix.truncate(depth);
    i
}

/// Every path in `code` that starts `crate::`, `super::` or `self::`, `use` groups expanded.
fn paths(code: &str) -> Vec<Vec<String>> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if is_ident(b[i]) {
            let w = ident_at(code, i);
            let follows = i > 0 && (is_ident(b[i - 1]) || b[i - 1] == b':');
            if !follows
                && matches!(w, "crate" | "super" | "self")
                && code[i + w.len()..].starts_with("::")
            {
                i = tree(code, i, &mut Vec::new(), &mut out);
            } else {
                i += w.len();
            }
        } else {
            i += 1;
        }
    }
    out
}

/// The paths a file re-exports (`pub use`, `pub(crate) use`, `pub(super) use`), each with the
/// name it is re-exported as; paths may start with a child module's name.
fn reexports(code: &str) -> Vec<(String, Vec<String>)> {
    let mut out = Vec::new();
    for vis in ["pub use ", "pub(crate) use ", "pub(super) use "] {
        for (i, _) in code.match_indices(vis) {
            let mut trees = Vec::new();
            tree(code, i + vis.len(), &mut Vec::new(), &mut trees);
            for p in trees {
                let name = p.last().unwrap().clone();
                if name != "self" {
                    out.push((name, p));
                }
            }
        }
    }
    out
}

/// A crate's files by module, and what each re-exports.
struct Crate {
    files: BTreeMap<Vec<String>, String>,
    /// Module → (name → absolute path, from the crate root).
    reexports: BTreeMap<Vec<String>, BTreeMap<String, Vec<String>>>,
}

impl Crate {
    /// `sources`: (path under src/, text) of every file, test files included.
    fn new(sources: &[(String, String)]) -> Crate {
        let files: BTreeMap<Vec<String>, String> = sources
            .iter()
            .map(|(rel, _)| (module_of(rel), rel.clone()))
            .collect();
        let mut c = Crate {
            files,
            reexports: BTreeMap::new(),
        };
        for (rel, text) in sources {
            if is_test_file(rel) {
                continue;
            }
            let m = module_of(rel);
            let mut names = BTreeMap::new();
            for (name, p) in reexports(&non_test(text)) {
                names.insert(name, c.absolute(&m, &p));
            }
            c.reexports.insert(m, names);
        }
        c
    }

    /// The segments of `path`, written in module `from`, from the crate root (a path that
    /// starts with neither `crate`, `super` nor `self` is relative to `from`).
    fn absolute(&self, from: &[String], path: &[String]) -> Vec<String> {
        let mut m: Vec<String> = from.to_vec();
        let mut rest = path;
        if let Some(first) = path.first() {
            match first.as_str() {
                "crate" => {
                    m.clear();
                    rest = &path[1..];
                }
                "self" => rest = &path[1..],
                _ => {}
            }
        }
        for seg in rest {
            match seg.as_str() {
                "super" => {
                    m.pop();
                }
                "self" => {}
                s => m.push(s.to_string()),
            }
        }
        m
    }

    /// The module, a file, that an absolute path's item lives in: the deepest file module on
    /// it, or where that module's re-export of the item leads.
    fn resolve(&self, abs: &[String], hops: usize) -> Vec<String> {
        let mut m: Vec<String> = Vec::new();
        for seg in abs {
            let mut next = m.clone();
            next.push(seg.clone());
            if self.files.contains_key(&next) {
                m = next;
                continue;
            }
            if hops < 8 {
                if let Some(target) = self.reexports.get(&m).and_then(|r| r.get(seg)) {
                    if target.as_slice() != next.as_slice() {
                        return self.resolve(target, hops + 1);
                    }
                }
            }
            break;
        }
        m
    }

    /// File → files it uses, over the non-test files.
    fn file_graph(&self, sources: &[(String, String)]) -> Graph {
        let mut graph = Graph::new();
        for (rel, text) in sources {
            if is_test_file(rel) {
                continue;
            }
            let from = module_of(rel);
            let deps = graph.entry(rel.clone()).or_default();
            for p in paths(&non_test(text)) {
                let to = self.resolve(&self.absolute(&from, &p), 0);
                // Its own submodules (or itself): a parent declares and re-exports them.
                if to.starts_with(&from) {
                    continue;
                }
                deps.insert(self.files[&to].clone());
            }
        }
        graph
    }
}

/// The top-level modules' graph the file graph implies (`lib.rs`'s items are no module).
fn module_graph(files: &Graph) -> Graph {
    let top = |rel: &str| module_of(rel).first().cloned();
    let mut graph = Graph::new();
    for (a, deps) in files {
        let Some(ta) = top(a) else { continue };
        let entry = graph.entry(ta.clone()).or_default();
        for b in deps {
            if let Some(tb) = top(b) {
                if tb != ta {
                    entry.insert(tb);
                }
            }
        }
    }
    graph
}

/// The first cycle a depth-first search meets (a back edge), as the path around it.
fn find_cycle(graph: &Graph) -> Option<Vec<String>> {
    fn visit(
        m: &str,
        graph: &Graph,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(m) {
            Some(2) => return None,
            Some(1) => {
                let i = path.iter().position(|p| p == m).unwrap();
                let mut cycle = path[i..].to_vec();
                cycle.push(m.to_string());
                return Some(cycle);
            }
            _ => {}
        }
        state.insert(m.to_string(), 1);
        path.push(m.to_string());
        for d in graph.get(m).into_iter().flatten() {
            if let Some(c) = visit(d, graph, state, path) {
                return Some(c);
            }
        }
        path.pop();
        state.insert(m.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    graph
        .keys()
        .find_map(|m| visit(m, graph, &mut state, &mut Vec::new()))
}

/// Every cycle `find_cycle` meets when each one found is cut at its last edge (at most 20),
/// so that one failing run names them all.
fn cycles(graph: &Graph) -> Vec<Vec<String>> {
    let mut g = graph.clone();
    let mut out = Vec::new();
    while let Some(c) = find_cycle(&g) {
        let (a, b) = (&c[c.len() - 2], &c[c.len() - 1]);
        g.get_mut(a).unwrap().remove(b);
        out.push(c);
        if out.len() == 20 {
            break;
        }
    }
    out
}

fn sources() -> Vec<(String, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files
        .iter()
        .map(|f| {
            let rel = f.strip_prefix(&src).unwrap().to_str().unwrap();
            (rel.replace('\\', "/"), fs::read_to_string(f).unwrap())
        })
        .collect()
}

#[test]
fn top_level_modules_have_no_cycle() {
    let src = sources();
    let graph = module_graph(&Crate::new(&src).file_graph(&src));
    for (m, deps) in &graph {
        eprintln!(
            "{m} -> {}",
            deps.iter().cloned().collect::<Vec<_>>().join(", ")
        );
    }
    if let Some(cycle) = find_cycle(&graph) {
        panic!("import cycle: {}", cycle.join(" -> "));
    }
    assert!(graph.len() > 10, "only {} modules found", graph.len());
}

#[test]
fn files_have_no_cycle() {
    let src = sources();
    let graph = Crate::new(&src).file_graph(&src);
    let found = cycles(&graph);
    let text: Vec<String> = found.iter().map(|c| c.join(" -> ")).collect();
    assert!(found.is_empty(), "import cycles:\n{}", text.join("\n"));
    let edges: usize = graph.values().map(BTreeSet::len).sum();
    assert!(edges > 100, "only {edges} edges found");
}

/// The checker reads paths and brace groups and finds cycles (so a pass above means something).
#[test]
fn the_checker_reads_paths_and_groups() {
    let got = paths(
        "use crate::{a::X, b, c::{d, e as f}};\nlet x = crate::f::g::<u8>();\n\
         use super::super::h::{self, I};\nself::j(); my_super::k; x::super::l;",
    );
    let s = |p: &str| p.split("::").map(String::from).collect::<Vec<_>>();
    let want: Vec<Vec<String>> = [
        "crate::a::X",
        "crate::b",
        "crate::c::d",
        "crate::c::e",
        "crate::f::g",
        "super::super::h::self",
        "super::super::h::I",
        "self::j",
    ]
    .iter()
    .map(|p| s(p))
    .collect();
    assert_eq!(got, want);
    assert_eq!(
        non_test("x\n// crate::z\n#[cfg(test)]\nmod tests;\ncrate::y"),
        "x"
    );
    assert_eq!(module_of("a/mod.rs"), s("a"));
    assert_eq!(module_of("a/b.rs"), s("a::b"));
    assert_eq!(module_of("lib.rs"), Vec::<String>::new());
    assert!(is_test_file("a/tests/x.rs") && is_test_file("a/tests.rs"));
    assert!(!is_test_file("a/testsuite.rs"));
    let g = |edges: &[(&str, &str)]| {
        let mut g = Graph::new();
        for (a, b) in edges {
            g.entry(a.to_string()).or_default().insert(b.to_string());
        }
        g
    };
    assert_eq!(find_cycle(&g(&[("a", "b"), ("b", "c"), ("a", "c")])), None);
    assert_eq!(
        find_cycle(&g(&[("a", "b"), ("b", "c"), ("c", "a")])),
        Some(vec!["a".into(), "b".into(), "c".into(), "a".into()])
    );
}

/// A tiny crate in memory: its file graph has the edges the paths name, and a planted cycle
/// (through a re-export, a `crate::` path or a `super::` group) fails the check.
#[test]
fn the_file_check_finds_a_planted_cycle() {
    let krate = |y: &str| -> Vec<(String, String)> {
        [
            ("lib.rs", "pub mod a;\npub mod b;\npub use a::T;"),
            ("a/mod.rs", "mod x;\nmod y;\npub use x::X;\npub struct T;"),
            ("a/x.rs", "use super::y::Y;\npub struct X;"),
            ("a/y.rs", y),
            ("a/tests.rs", "use super::x::X;\nuse super::y::Y;"),
            ("b.rs", "use crate::a::T;\nfn f() -> crate::T { T }"),
        ]
        .iter()
        .map(|(p, t)| (p.to_string(), t.to_string()))
        .collect()
    };
    let graph = |y: &str| {
        let src = krate(y);
        Crate::new(&src).file_graph(&src)
    };
    let set = |fs: &[&str]| fs.iter().map(|f| f.to_string()).collect::<BTreeSet<_>>();
    // No cycle: y uses its parent's own item; test code may use anything.
    let tail = "\n#[cfg(test)]\nmod tests {\n    use super::super::x::X;\n}";
    let ok = graph(&format!("use super::T;\npub struct Y;{tail}"));
    assert_eq!(ok["a/x.rs"], set(&["a/y.rs"]));
    assert_eq!(ok["a/y.rs"], set(&["a/mod.rs"]));
    assert_eq!(ok["a/mod.rs"], set(&[]), "a parent's edges to its children");
    assert_eq!(
        ok["b.rs"],
        set(&["a/mod.rs"]),
        "crate::T is a::T re-exported"
    );
    assert!(!ok.contains_key("a/tests.rs"));
    assert!(cycles(&ok).is_empty());
    // Planted: y uses x, by each way of writing it.
    for y in [
        "use super::X;",
        "use super::{T, x::X};",
        "fn f() { crate::a::x::X; }",
        "fn f() { crate::a::X; }",
        "fn f() { self::super::x::X; }",
    ] {
        let bad = graph(y);
        assert_eq!(
            cycles(&bad),
            vec![vec!["a/x.rs", "a/y.rs", "a/x.rs"]],
            "{y}: {bad:?}"
        );
    }
    // And a cycle between top-level modules.
    let src = krate("use crate::b;");
    let mut src2 = src.clone();
    src2[5].1 = "use crate::a::T;\nuse crate::a::x::X;".into();
    src2[3].1 = "pub fn g() { crate::b::f(); }".into();
    let g = Crate::new(&src2).file_graph(&src2);
    assert!(find_cycle(&module_graph(&g)).is_some());
}
