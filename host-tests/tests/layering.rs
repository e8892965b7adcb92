//! The core's structure, read from its source: the top-level modules import
//! one another one way (no cycle), no function is longer than
//! [`MAX_LINES`], and none carries more than [`MAX_CFG`] `#[cfg]`s.
//!
//! `cargo test -p corofem-host-tests --test layering -- --nocapture` prints
//! the module graph (each module with the modules it imports, from the
//! bottom up) and the longest functions.
//!
//! The source is read as text (rustfmt's layout): a module's imports are the
//! `crate::name` paths outside comments, with the crate root's re-exports
//! (`pub use module::Item` in lib.rs) taken to the module they come from.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// Longest function allowed, in lines (signature to closing brace).
const MAX_LINES: usize = 200;
/// Most `#[cfg(...)]` attributes allowed in one function.
const MAX_CFG: usize = 10;
/// The hand-written Cortex-M4F assembly product: one `asm!` block, long by
/// nature.
const EXEMPT: &[&str] = &["fpu_product.rs"];

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../core/src")
}

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The top-level module a file belongs to (`None` for lib.rs).
fn module_of(path: &Path) -> Option<String> {
    let rel = path.strip_prefix(src()).unwrap();
    let first = rel.components().next()?.as_os_str().to_str()?.to_string();
    if first == "lib.rs" {
        return None;
    }
    Some(first.trim_end_matches(".rs").to_string())
}

/// The code of a file without comments and without its unit tests.
fn code(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        if line.trim() == "#[cfg(test)]"
            && lines
                .peek()
                .is_some_and(|l| l.trim_start().starts_with("mod "))
        {
            break;
        }
        let code = match line.find("//") {
            Some(i) => &line[..i],
            None => line,
        };
        out.push(code.to_string());
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The crate root's re-exports: item name → the module it comes from.
fn reexports(lib: &str) -> BTreeMap<String, String> {
    let mut map = BTreeMap::new();
    let joined = code(lib).join(" ");
    for stmt in joined.split(';') {
        let Some(i) = stmt.find("pub use ") else {
            continue;
        };
        let path = stmt[i + 8..].trim();
        let module: String = path.chars().take_while(|&c| is_ident(c)).collect();
        let rest = &path[module.len()..];
        for name in rest.split(|c: char| !is_ident(c)).filter(|s| !s.is_empty()) {
            map.insert(name.to_string(), module.clone());
        }
    }
    map
}

/// The modules a file's code imports, by `crate::` paths.
fn imports(
    lines: &[String],
    modules: &BTreeSet<String>,
    roots: &BTreeMap<String, String>,
) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let text = lines.join("\n");
    let mut rest = text.as_str();
    while let Some(i) = rest.find("crate::") {
        let after = &rest[i + 7..];
        let names: Vec<String> = if let Some(list) = after.strip_prefix('{') {
            // `crate::{a::X, Y}`: the first segment of each entry.
            let end = list.find('}').unwrap_or(list.len());
            list[..end]
                .split(',')
                .map(|e| e.trim().chars().take_while(|&c| is_ident(c)).collect())
                .collect()
        } else {
            vec![after.chars().take_while(|&c| is_ident(c)).collect()]
        };
        for name in names {
            if modules.contains(&name) {
                out.insert(name);
            } else if let Some(m) = roots.get(&name) {
                out.insert(m.clone());
            }
        }
        rest = after;
    }
    out
}

struct Function {
    file: String,
    name: String,
    lines: usize,
    cfgs: usize,
}

/// Every function of a file's code: from the `fn` line to the closing brace
/// at its indentation, with the `#[cfg(` attributes inside.
fn functions(file: &str, lines: &[String]) -> Vec<Function> {
    let mut out = Vec::new();
    for (start, line) in lines.iter().enumerate() {
        let t = line.trim_start();
        let indent = line.len() - t.len();
        let words: Vec<&str> = t.split_whitespace().collect();
        let Some(k) = words.iter().position(|w| *w == "fn") else {
            continue;
        };
        let prefix_ok = words[..k].iter().all(|w| {
            matches!(
                *w,
                "pub"
                    | "pub(crate)"
                    | "pub(super)"
                    | "const"
                    | "unsafe"
                    | "extern"
                    | "\"C\""
                    | "async"
            )
        });
        if !prefix_ok || words.get(k + 1).is_none() {
            continue;
        }
        let name: String = words[k + 1].chars().take_while(|&c| is_ident(c)).collect();
        let close = format!("{}}}", " ".repeat(indent));
        // A declaration without a body (a trait's) ends with `;` first.
        let Some(end) = lines[start..].iter().position(|l| {
            l.trim_end() == close
                || (l.trim_end().ends_with(';')
                    && !l.contains('{')
                    && l.trim_start().starts_with("fn"))
        }) else {
            continue;
        };
        let body = &lines[start..=start + end];
        out.push(Function {
            file: file.to_string(),
            name,
            lines: end + 1,
            cfgs: body.iter().filter(|l| l.contains("#[cfg(")).count(),
        });
    }
    out
}

/// The modules on a cycle of `graph`, if any (Tarjan's strongly connected
/// components of more than one module).
fn cycles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct State<'a> {
        graph: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a str) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        s.on.insert(v);
        for w in s.graph.get(v).into_iter().flatten() {
            let w = w.as_str();
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if s.on.contains(w) {
                let iw = s.index[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on.remove(w);
                comp.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                s.out.push(comp);
            }
        }
    }
    let mut s = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !s.index.contains_key(v.as_str()) {
            visit(&mut s, v);
        }
    }
    s.out
}

struct Core {
    graph: BTreeMap<String, BTreeSet<String>>,
    functions: Vec<Function>,
}

fn read_core() -> Core {
    let mut paths = Vec::new();
    files(&src(), &mut paths);
    let modules: BTreeSet<String> = paths.iter().filter_map(|p| module_of(p)).collect();
    let roots = reexports(&fs::read_to_string(src().join("lib.rs")).unwrap());
    let mut graph: BTreeMap<String, BTreeSet<String>> = modules
        .iter()
        .map(|m| (m.clone(), BTreeSet::new()))
        .collect();
    let mut all = Vec::new();
    for p in &paths {
        let lines = code(&fs::read_to_string(p).unwrap());
        let rel = p.strip_prefix(src()).unwrap().display().to_string();
        if let Some(m) = module_of(p) {
            let mut deps = imports(&lines, &modules, &roots);
            deps.remove(&m);
            graph.get_mut(&m).unwrap().extend(deps);
        }
        if !EXEMPT.iter().any(|e| rel.ends_with(e)) {
            all.extend(functions(&rel, &lines));
        }
    }
    Core {
        graph,
        functions: all,
    }
}

/// The modules from the bottom up: each after every module it imports
/// (those on a cycle last, in name order).
fn layers(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<(usize, String)> {
    let mut level: BTreeMap<&str, usize> = BTreeMap::new();
    let mut changed = true;
    let mut rounds = 0;
    while changed && rounds <= graph.len() {
        changed = false;
        rounds += 1;
        for (m, deps) in graph {
            let l = deps
                .iter()
                .map(|d| level.get(d.as_str()).map_or(0, |l| l + 1))
                .max()
                .unwrap_or(0);
            if level.get(m.as_str()) != Some(&l) {
                level.insert(m, l);
                changed = true;
            }
        }
    }
    let mut out: Vec<(usize, String)> =
        level.into_iter().map(|(m, l)| (l, m.to_string())).collect();
    out.sort();
    out
}

#[test]
fn core_modules_import_one_way() {
    let core = read_core();
    println!("core's top-level modules, from the bottom up (floor: module -> what it imports):");
    for (floor, m) in layers(&core.graph) {
        let deps: Vec<&str> = core.graph[&m].iter().map(String::as_str).collect();
        println!("  {floor:2}: {m} -> {}", deps.join(", "));
    }
    let found = cycles(&core.graph);
    assert!(
        found.is_empty(),
        "import cycles among core's top-level modules: {found:?}"
    );
    // The reader sees real imports: the step imports the contact stages and
    // the scene's state, and the storage sits below the scene.
    assert!(core.graph["step"].contains("contact") && core.graph["step"].contains("state"));
    assert!(core.graph["scene"].contains("storage") && !core.graph["storage"].contains("scene"));
}

#[test]
fn no_core_function_is_long_or_full_of_cfg() {
    let core = read_core();
    let mut by_len: Vec<&Function> = core.functions.iter().collect();
    by_len.sort_by(|a, b| b.lines.cmp(&a.lines).then(a.name.cmp(&b.name)));
    println!("the longest functions in core/src (lines, #[cfg]s):");
    for f in by_len.iter().take(10) {
        println!("  {:4} {:3}  {}::{}", f.lines, f.cfgs, f.file, f.name);
    }
    let mut by_cfg: Vec<&Function> = core.functions.iter().collect();
    by_cfg.sort_by(|a, b| b.cfgs.cmp(&a.cfgs).then(a.name.cmp(&b.name)));
    println!("the most #[cfg]s in one function:");
    for f in by_cfg.iter().take(5) {
        println!("  {:3}  {}::{}", f.cfgs, f.file, f.name);
    }
    // The reader finds the functions (the crate has hundreds).
    assert!(
        core.functions.len() > 300,
        "{} functions found",
        core.functions.len()
    );
    let long: Vec<_> = by_len
        .iter()
        .filter(|f| f.lines > MAX_LINES)
        .map(|f| (&f.file, &f.name, f.lines))
        .collect();
    assert!(
        long.is_empty(),
        "functions over {MAX_LINES} lines: {long:?}"
    );
    let cfg: Vec<_> = by_cfg
        .iter()
        .filter(|f| f.cfgs > MAX_CFG)
        .map(|f| (&f.file, &f.name, f.cfgs))
        .collect();
    assert!(
        cfg.is_empty(),
        "functions with more than {MAX_CFG} #[cfg]: {cfg:?}"
    );
}
