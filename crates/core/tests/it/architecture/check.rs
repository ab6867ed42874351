//! The import graph of a crate's source, file by file, and the two rules CONTRIBUTING.md
//! states for it: no circle of imports, and no stage importing a stage above it. Shared by
//! the core's and the sweep's tests (each runs it on its own crate).
//!
//! Every form an import takes is read: `use` trees with braces at any depth (`use
//! super::{pass::X, y::{self, Z}}`), `crate::`, `super::` and `self::` paths written inline
//! in code, bare paths to a child module, and `mod.rs` files (a folder's front door is the
//! folder's module). A path resolves to the deepest module it names, following a front
//! door's `pub use` to the file that defines the item, so `use super::light::Incident`
//! reaches the file that defines `Incident`. Re-exports are not edges (a front door lists
//! its children's items without depending on them); tests, comments and strings are not
//! read.

// Each crate's tests use part of what is shared here.
#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module by its path from the crate root (`["scene", "light"]`; the root is `[]`).
pub type Module = Vec<String>;

/// The modules of a crate and the imports between them.
#[derive(Debug, Default)]
pub struct Graph {
    /// Every module's file.
    pub files: BTreeMap<Module, PathBuf>,
    /// `a → b` when `a`'s code names something `b` defines, with the names.
    pub edges: BTreeMap<Module, BTreeMap<Module, BTreeSet<String>>>,
}

/// `module` as `scene/light` (`<root>` for the crate root).
pub fn shown(module: &[String]) -> String {
    if module.is_empty() {
        "<root>".to_string()
    } else {
        module.join("/")
    }
}

/// The import graph of the crate whose sources are under `src`.
pub fn crate_graph(src: &Path) -> Graph {
    let mut files = BTreeMap::new();
    for path in rust_files(src) {
        let rel = path.strip_prefix(src).unwrap().with_extension("");
        let mut parts: Module = rel
            .components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect();
        if matches!(
            parts.last().map(String::as_str),
            Some("mod" | "lib" | "main")
        ) {
            parts.pop();
        }
        files.insert(parts, path);
    }
    let texts: BTreeMap<Module, String> = files
        .iter()
        .map(|(m, p)| (m.clone(), code(&std::fs::read_to_string(p).unwrap())))
        .collect();
    graph_of(files, &texts)
}

/// The graph of modules whose code (already stripped) is `texts`.
pub fn graph_of(files: BTreeMap<Module, PathBuf>, texts: &BTreeMap<Module, String>) -> Graph {
    let mut defined: BTreeMap<Module, BTreeSet<String>> = BTreeMap::new();
    let mut reexports: BTreeMap<Module, BTreeMap<String, Module>> = BTreeMap::new();
    let mut uses: BTreeMap<Module, Vec<Module>> = BTreeMap::new();
    for (module, text) in texts {
        defined.insert(module.clone(), definitions(text));
        for (public, tree) in use_declarations(text) {
            for path in expand(&tree) {
                let Some(absolute) = absolute(&files, module, &path) else {
                    continue;
                };
                if public {
                    if let Some(name) = path.last() {
                        let name = name.split(" as ").last().unwrap().trim().to_string();
                        reexports
                            .entry(module.clone())
                            .or_default()
                            .insert(name, absolute);
                    }
                } else {
                    uses.entry(module.clone()).or_default().push(absolute);
                }
            }
        }
        for path in inline_paths(&without_use_declarations(text)) {
            if let Some(absolute) = absolute(&files, module, &path) {
                uses.entry(module.clone()).or_default().push(absolute);
            }
        }
    }
    let mut edges: BTreeMap<Module, BTreeMap<Module, BTreeSet<String>>> = BTreeMap::new();
    for (module, paths) in &uses {
        for path in paths {
            let Some(target) = resolve(&files, &defined, &reexports, path, 0) else {
                continue;
            };
            if &target != module && !target.is_empty() {
                edges
                    .entry(module.clone())
                    .or_default()
                    .entry(target)
                    .or_default()
                    .insert(path.last().cloned().unwrap_or_default());
            }
        }
    }
    Graph { files, edges }
}

/// Every `.rs` file under `folder`.
fn rust_files(folder: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(folder).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(rust_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out.sort();
    out
}

/// `text` without comments, string and character literals (kept as `""` and `' '`) and
/// `#[cfg(test)]` items: only the code that builds the crate.
pub fn code(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < bytes.len() {
        let rest = &text[i..];
        if rest.starts_with("//") {
            i += rest.find('\n').unwrap_or(rest.len());
        } else if rest.starts_with("/*") {
            i += block_comment_len(rest);
        } else if let Some(len) = raw_string_len(rest) {
            out.push_str("\"\"");
            i += len;
        } else if bytes[i] == b'"' {
            out.push_str("\"\"");
            i += quoted_len(rest, '"');
        } else if bytes[i] == b'\'' && char_literal_len(rest).is_some() {
            out.push_str("' '");
            i += char_literal_len(rest).unwrap();
        } else {
            let c = rest.chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
        }
    }
    without_test_items(&out)
}

/// The length of a `/* … */` comment (nested ones too) at the start of `text`.
fn block_comment_len(text: &str) -> usize {
    let mut depth = 0;
    let mut i = 0;
    while i < text.len() {
        if text[i..].starts_with("/*") {
            depth += 1;
            i += 2;
        } else if text[i..].starts_with("*/") {
            depth -= 1;
            i += 2;
            if depth == 0 {
                return i;
            }
        } else {
            i += text[i..].chars().next().unwrap().len_utf8();
        }
    }
    text.len()
}

/// The length of a raw string (`r"…"`, `r#"…"#`, `br"…"`) at the start of `text`.
fn raw_string_len(text: &str) -> Option<usize> {
    let after_b = text.strip_prefix('b').unwrap_or(text);
    let after_r = after_b.strip_prefix('r')?;
    let hashes = after_r.len() - after_r.trim_start_matches('#').len();
    let body = after_r[hashes..].strip_prefix('"')?;
    let close = format!("\"{}", "#".repeat(hashes));
    let end = body.find(&close)?;
    Some(text.len() - body.len() + end + close.len())
}

/// The length of a literal quoted by `quote` (escapes skipped) at the start of `text`.
fn quoted_len(text: &str, quote: char) -> usize {
    let mut chars = text.char_indices().skip(1);
    while let Some((i, c)) = chars.next() {
        if c == '\\' {
            chars.next();
        } else if c == quote {
            return i + 1;
        }
    }
    text.len()
}

/// The length of a character literal at the start of `text`, `None` for a lifetime.
fn char_literal_len(text: &str) -> Option<usize> {
    let mut chars = text.char_indices().skip(1);
    let (_, first) = chars.next()?;
    if first == '\\' {
        return Some(quoted_len(text, '\''));
    }
    let (i, second) = chars.next()?;
    (second == '\'').then_some(i + 1)
}

/// `text` without the items after `#[cfg(test)]` (a module's braces, or an item to its `;`
/// or closing brace).
fn without_test_items(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let item = &rest[at..];
        let open = item.find('{');
        let semi = item.find(';');
        let end = match (open, semi) {
            (Some(o), Some(s)) if s < o => s + 1,
            (Some(o), _) => o + matching_brace(&item[o..]),
            (None, Some(s)) => s + 1,
            (None, None) => item.len(),
        };
        rest = &item[end..];
    }
    out.push_str(rest);
    out
}

/// The length up to and including the brace that closes the one `text` starts with.
fn matching_brace(text: &str) -> usize {
    let mut depth = 0;
    for (i, c) in text.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return i + 1;
                }
            }
            _ => {}
        }
    }
    text.len()
}

/// The names `text` defines (items, and modules it declares).
fn definitions(text: &str) -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    let words: Vec<&str> = text
        .split(|c: char| !(c.is_alphanumeric() || c == '_' || c == '!'))
        .filter(|w| !w.is_empty())
        .collect();
    for pair in words.windows(2) {
        if matches!(
            pair[0],
            "struct" | "enum" | "fn" | "trait" | "const" | "static" | "type" | "union" | "mod"
        ) {
            names.insert(pair[1].to_string());
        }
    }
    names
}

/// Each `use` declaration of `text`: where it starts (at `use`), where its `;` is, and
/// whether it is public (a re-export).
fn use_spans(text: &str) -> Vec<(usize, usize, bool)> {
    let mut out = Vec::new();
    for (start, _) in text.match_indices("use ") {
        let before = &text[..start];
        if before
            .chars()
            .last()
            .is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':')
        {
            continue;
        }
        let Some(end) = text[start..].find(';') else {
            continue;
        };
        let line_start = before.rfind(['\n', ';', '{', '}']).map_or(0, |i| i + 1);
        let public = before[line_start..].trim_start().starts_with("pub");
        out.push((start, start + end, public));
    }
    out
}

/// Each `use` declaration of `text`: whether it is public (a re-export) and its tree.
fn use_declarations(text: &str) -> Vec<(bool, String)> {
    use_spans(text)
        .into_iter()
        .map(|(start, end, public)| (public, text[start + 4..end].to_string()))
        .collect()
}

/// `text` with its `use` declarations blanked (their paths are read as trees).
fn without_use_declarations(text: &str) -> String {
    let mut out = text.to_string();
    for (start, end, _) in use_spans(text) {
        out.replace_range(start..end, &" ".repeat(end - start));
    }
    out
}

/// A `use` tree as paths: `a::{b, c::{d, self}}` → `a::b`, `a::c::d`, `a::c`.
pub fn expand(tree: &str) -> Vec<Vec<String>> {
    let tree: String = tree.split_whitespace().collect::<Vec<_>>().join(" ");
    let Some(open) = tree.find('{') else {
        return vec![segments(&tree)];
    };
    let prefix = segments(tree[..open].trim_end_matches("::"));
    let body = &tree[open + 1..open + matching_brace(&tree[open..]) - 1];
    let mut items = Vec::new();
    let (mut depth, mut current) = (0, String::new());
    for c in body.chars() {
        match c {
            ',' if depth == 0 => items.push(std::mem::take(&mut current)),
            '{' => {
                depth += 1;
                current.push(c);
            }
            '}' => {
                depth -= 1;
                current.push(c);
            }
            _ => current.push(c),
        }
    }
    items.push(current);
    let mut out = Vec::new();
    for item in items.iter().map(|i| i.trim()).filter(|i| !i.is_empty()) {
        for path in expand(item) {
            let mut full = prefix.clone();
            // `self` in a group names the prefix itself.
            full.extend(path.into_iter().filter(|s| s != "self"));
            out.push(full);
        }
    }
    out
}

/// `a::b as c` → `["a", "b"]` (the alias is the crate's business, not the graph's).
fn segments(path: &str) -> Vec<String> {
    let path = path.split(" as ").next().unwrap_or(path);
    path.split("::")
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect()
}

/// The `crate::…`, `super::…` and `self::…` paths written in code.
fn inline_paths(text: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < text.len() {
        let rest = &text[i..];
        let starts = ["crate::", "super::", "self::"]
            .iter()
            .any(|s| rest.starts_with(s));
        let boundary = i == 0
            || !(bytes[i - 1].is_ascii_alphanumeric()
                || bytes[i - 1] == b'_'
                || bytes[i - 1] == b':');
        if starts && boundary {
            let len = rest
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(rest.len());
            out.push(segments(rest[..len].trim_end_matches(':')));
            i += len;
        } else {
            i += rest.chars().next().unwrap().len_utf8();
        }
    }
    out
}

/// `path` written in `module` as a path from the crate root, or `None` when it names
/// another crate.
fn absolute(files: &BTreeMap<Module, PathBuf>, module: &Module, path: &[String]) -> Option<Module> {
    let first = path.first()?;
    match first.as_str() {
        "crate" => Some(path[1..].to_vec()),
        "self" => Some(module.iter().chain(&path[1..]).cloned().collect()),
        "super" => {
            let ups = path.iter().take_while(|s| *s == "super").count();
            let base = &module[..module.len().checked_sub(ups)?];
            Some(base.iter().chain(&path[ups..]).cloned().collect())
        }
        _ => {
            let child: Module = module.iter().chain([first]).cloned().collect();
            files
                .contains_key(&child)
                .then(|| module.iter().chain(path).cloned().collect())
        }
    }
}

/// The module whose file defines what `path` names: its longest module prefix, through
/// that module's `pub use` when it does not define the next name itself.
fn resolve(
    files: &BTreeMap<Module, PathBuf>,
    defined: &BTreeMap<Module, BTreeSet<String>>,
    reexports: &BTreeMap<Module, BTreeMap<String, Module>>,
    path: &[String],
    depth: usize,
) -> Option<Module> {
    let k = (0..=path.len())
        .rev()
        .find(|&k| files.contains_key(&path[..k]))?;
    let (module, rest) = (path[..k].to_vec(), &path[k..]);
    let Some(next) = rest.first() else {
        return Some(module);
    };
    if depth >= 16 || defined.get(&module).is_some_and(|d| d.contains(next)) {
        return Some(module);
    }
    let named = reexports.get(&module).and_then(|r| r.get(next));
    // `pub use child::*`: the child that defines the name.
    let globbed = || {
        reexports.get(&module)?.get("*").and_then(|glob| {
            let child = &glob[..glob.len() - 1];
            defined
                .get(child)
                .is_some_and(|d| d.contains(next))
                .then(|| child.iter().chain([next]).cloned().collect::<Module>())
        })
    };
    match named.cloned().or_else(globbed) {
        Some(target) => {
            let full: Vec<String> = target.iter().chain(&rest[1..]).cloned().collect();
            resolve(files, defined, reexports, &full, depth + 1)
        }
        None => Some(module),
    }
}

/// The circles of `graph` (strongly connected components of more than one module), each
/// with the edges inside it.
pub fn circles(graph: &Graph) -> Vec<String> {
    let nodes: Vec<&Module> = graph.files.keys().collect();
    let index: BTreeMap<&Module, usize> = nodes.iter().enumerate().map(|(i, m)| (*m, i)).collect();
    let successors: Vec<Vec<usize>> = nodes
        .iter()
        .map(|m| {
            graph.edges.get(*m).map_or(Vec::new(), |e| {
                e.keys().filter_map(|t| index.get(t).copied()).collect()
            })
        })
        .collect();
    strongly_connected(&successors)
        .into_iter()
        .filter(|c| c.len() > 1)
        .map(|component| {
            let members: BTreeSet<usize> = component.iter().copied().collect();
            let mut lines = vec![format!(
                "circle: {}",
                component
                    .iter()
                    .map(|&i| shown(nodes[i]))
                    .collect::<Vec<_>>()
                    .join(", ")
            )];
            for &a in &component {
                for (b, names) in graph.edges.get(nodes[a]).into_iter().flatten() {
                    if index.get(b).is_some_and(|j| members.contains(j)) {
                        lines.push(format!(
                            "    {} → {} ({})",
                            shown(nodes[a]),
                            shown(b),
                            names.iter().cloned().collect::<Vec<_>>().join(", ")
                        ));
                    }
                }
            }
            lines.join("\n")
        })
        .collect()
}

/// Tarjan's strongly connected components, iteratively (a deep crate must not overflow
/// the test thread's stack).
fn strongly_connected(successors: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let n = successors.len();
    let (mut index, mut low) = (vec![usize::MAX; n], vec![0; n]);
    let (mut on_stack, mut stack, mut out) = (vec![false; n], Vec::new(), Vec::new());
    let mut next = 0;
    for root in 0..n {
        if index[root] != usize::MAX {
            continue;
        }
        let mut call: Vec<(usize, usize)> = vec![(root, 0)];
        index[root] = next;
        low[root] = next;
        next += 1;
        stack.push(root);
        on_stack[root] = true;
        while let Some(&(v, child)) = call.last() {
            if let Some(&w) = successors[v].get(child) {
                call.last_mut().expect("v is on the call stack").1 += 1;
                if index[w] == usize::MAX {
                    index[w] = next;
                    low[w] = next;
                    next += 1;
                    stack.push(w);
                    on_stack[w] = true;
                    call.push((w, 0));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            call.pop();
            if let Some(&(parent, _)) = call.last() {
                low[parent] = low[parent].min(low[v]);
            }
            if low[v] == index[v] {
                let mut component = Vec::new();
                while let Some(w) = stack.pop() {
                    on_stack[w] = false;
                    component.push(w);
                    if w == v {
                        break;
                    }
                }
                component.sort_unstable();
                out.push(component);
            }
        }
    }
    out
}

/// The imports that run against `layers` (lowest first: a module of a layer may import
/// only modules of the layers below it; modules of no layer are not checked): each as
/// `from → to (names)`.
pub fn against_layers(graph: &Graph, layers: &[&str]) -> Vec<String> {
    let layer_of = |m: &Module| {
        m.first()
            .and_then(|top| layers.iter().position(|l| l == top))
    };
    let mut out = Vec::new();
    for (from, targets) in &graph.edges {
        let Some(a) = layer_of(from) else { continue };
        for (to, names) in targets {
            if let Some(b) = layer_of(to)
                && b > a
            {
                out.push(format!(
                    "{} → {} ({}): `{}` sits below `{}`",
                    shown(from),
                    shown(to),
                    names.iter().cloned().collect::<Vec<_>>().join(", "),
                    layers[a],
                    layers[b]
                ));
            }
        }
    }
    out
}

/// The names a map's code spans hold: each span split at spaces, commas and brackets, each
/// piece's last path component without `/` or `.rs` (`pbrt/` → `pbrt`,
/// `scene/light/incident.rs` → `incident`), and the pieces that name a folder or file
/// (ending in `/` or `.rs`).
fn named_in(map: &str) -> (BTreeSet<String>, BTreeSet<String>) {
    let (mut names, mut paths) = (BTreeSet::new(), BTreeSet::new());
    for (i, span) in map.split('`').enumerate() {
        if i % 2 == 0 {
            continue;
        }
        for piece in span.split([' ', ',', '(', ')', '{', '}']) {
            let last = piece
                .trim_end_matches('/')
                .rsplit('/')
                .next()
                .unwrap_or("")
                .trim_end_matches(".rs");
            if !last.is_empty() {
                names.insert(last.to_string());
            }
            if piece.ends_with('/') || piece.ends_with(".rs") {
                paths.insert(last.to_string());
            }
        }
    }
    (names, paths)
}

/// Where `map` (a crate's section of CONTRIBUTING.md) and the tree under `src` disagree:
/// a top-level module, or a direct child of a top-level folder, that the map does not name;
/// a folder or file the map names that is nowhere under `src`. The folders of `own_maps`
/// name their children in their own `mod.rs` instead; the children of `per_kind` folders
/// are one module per kind of something the map names as a kind (the verbs).
pub fn map_mismatches(src: &Path, map: &str, own_maps: &[&str], per_kind: &[&str]) -> Vec<String> {
    let (names, paths) = named_in(map);
    let stem = |p: &Path| p.file_stem().unwrap().to_string_lossy().into_owned();
    let children = |dir: &Path| -> Vec<PathBuf> {
        let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_dir() || p.extension().is_some_and(|e| e == "rs"))
            .filter(|p| !matches!(stem(p).as_str(), "mod" | "lib" | "main"))
            .collect();
        out.sort();
        out
    };
    let mut out = Vec::new();
    for top in children(src) {
        let name = stem(&top);
        if !names.contains(&name) {
            out.push(format!("`{name}` is not in the map"));
        }
        if !top.is_dir() || per_kind.contains(&name.as_str()) {
            continue;
        }
        let (listed, whose) = if own_maps.contains(&name.as_str()) {
            let front = std::fs::read_to_string(top.join("mod.rs")).unwrap();
            let docs: String = front
                .lines()
                .filter_map(|l| l.trim_start().strip_prefix("//!"))
                .collect::<Vec<_>>()
                .join("\n");
            (named_in(&docs).0, format!("{name}/mod.rs's map"))
        } else {
            (names.clone(), "the map".to_string())
        };
        for child in children(&top) {
            let child = stem(&child);
            if !listed.contains(&child) {
                out.push(format!("`{name}/{child}` is not in {whose}"));
            }
        }
    }
    let present: BTreeSet<String> = rust_files(src)
        .iter()
        .flat_map(|f| {
            f.strip_prefix(src)
                .unwrap()
                .components()
                .map(|c| {
                    c.as_os_str()
                        .to_string_lossy()
                        .trim_end_matches(".rs")
                        .to_string()
                })
                .collect::<Vec<_>>()
        })
        .collect();
    for path in paths {
        if !present.contains(&path) {
            out.push(format!(
                "the map names `{path}`, which is nowhere under {}",
                src.display()
            ));
        }
    }
    out
}

/// The section of `contributing` from the heading `from` to the next heading of its level
/// or above.
pub fn section<'a>(contributing: &'a str, from: &str) -> &'a str {
    let start = contributing
        .find(from)
        .unwrap_or_else(|| panic!("CONTRIBUTING.md has no `{from}`"));
    let level = from.chars().take_while(|&c| c == '#').count();
    let rest = &contributing[start + from.len()..];
    let end = rest
        .match_indices("\n#")
        .find(|(i, _)| rest[i + 1..].chars().take_while(|&c| c == '#').count() <= level)
        .map_or(rest.len(), |(i, _)| i);
    &contributing[start..start + from.len() + end]
}

/// The graph of the crate under `src`, checked to have found the crate (more than 50
/// modules).
pub fn source_graph(src: &Path) -> Graph {
    let graph = crate_graph(src);
    assert!(
        graph.files.len() > 50,
        "{} modules found",
        graph.files.len()
    );
    graph
}

/// Fails, naming each circle and its edges, when `graph` has one.
pub fn assert_no_circle(graph: &Graph) {
    let found = circles(graph);
    assert!(
        found.is_empty(),
        "imports run in a circle; move what the files share into a leaf of their own:\n{}",
        found.join("\n")
    );
}

/// Fails, naming each import, when `graph` imports against the stage order `layers`.
pub fn assert_stage_order(graph: &Graph, layers: &[&str]) {
    let found = against_layers(graph, layers);
    assert!(
        found.is_empty(),
        "imports against the stage order {layers:?}:\n{}",
        found.join("\n")
    );
}
