//! Mesh files a user drops on the page: the project's `tetmesh 1` text and
//! Gmsh `.msh` ASCII, versions 2.x and 4.1. Small hand-written readers (the
//! host's `corofem-io` uses `mshio`, too heavy for the page): only nodes and
//! 4-node tetrahedra (Gmsh element type 4) are read; every other section and
//! element type is skipped. Every error names the line.
//!
//! Gmsh writes one record per line (a node, a tag, an element), and so do
//! these readers expect. Binary `.msh` and MSH 4.0 are refused with a hint.

use std::collections::HashMap;

/// A mesh as read, before it is placed: f64 coordinates in file units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FileMesh {
    /// Node coordinates.
    pub nodes: Vec<[f64; 3]>,
    /// Tetrahedra, 0-based indices into `nodes`.
    pub tets: Vec<[u32; 4]>,
}

/// Largest declared count accepted before anything is allocated.
const MAX_DECLARED: u64 = 5_000_000;
/// Most tetrahedra the page takes: past this a frame takes seconds.
pub const MAX_TETS: usize = 200_000;
/// Most nodes the core addresses (`u16` indices).
pub const MAX_NODES: usize = 65_536;

/// Reads `bytes` as `tetmesh 1` or Gmsh `.msh` (by content, not by name).
pub fn parse(bytes: &[u8]) -> Result<FileMesh, String> {
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(256)]);
    let first = head
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("");
    if first.starts_with("tetmesh") {
        parse_tetmesh(text(bytes)?)
    } else if first == "$MeshFormat" {
        parse_msh(bytes)
    } else if first == "$NOD" {
        Err("MSH 1.0 is not read: save the mesh as MSH 2.2 or 4.1 ASCII".to_owned())
    } else {
        Err(format!(
            "not a mesh file: the first line is \"{}\", expected \"tetmesh 1\" or \"$MeshFormat\"",
            shorten(first)
        ))
    }
}

fn text(bytes: &[u8]) -> Result<&str, String> {
    std::str::from_utf8(bytes).map_err(|e| {
        let line = 1 + bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        format!("line {line}: not text (invalid UTF-8)")
    })
}

fn shorten(s: &str) -> String {
    if s.chars().count() > 40 {
        format!("{}…", s.chars().take(40).collect::<String>())
    } else {
        s.to_owned()
    }
}

/// Lines with 1-based numbers, blank lines skipped.
struct Lines<'a> {
    it: std::iter::Enumerate<std::str::Lines<'a>>,
    last: usize,
}

impl<'a> Lines<'a> {
    fn new(s: &'a str) -> Self {
        Self {
            it: s.lines().enumerate(),
            last: 0,
        }
    }

    fn next(&mut self) -> Option<(usize, &'a str)> {
        for (i, l) in self.it.by_ref() {
            self.last = i + 1;
            let l = l.trim();
            if !l.is_empty() {
                return Some((i + 1, l));
            }
        }
        None
    }

    /// The next line's tokens, or an error naming what was expected.
    fn tokens(&mut self, what: &str) -> Result<(usize, Vec<&'a str>), String> {
        match self.next() {
            Some((n, l)) => Ok((n, l.split_whitespace().collect())),
            None => Err(format!(
                "line {}: the file ends before {what}",
                self.last + 1
            )),
        }
    }
}

fn num<T: std::str::FromStr>(line: usize, tok: &str, what: &str) -> Result<T, String> {
    tok.parse().map_err(|_| {
        format!(
            "line {line}: {what} \"{}\" is not a valid number",
            shorten(tok)
        )
    })
}

fn coord(line: usize, tok: &str, what: &str) -> Result<f64, String> {
    let v: f64 = num(line, tok, what)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("line {line}: {what} is not finite"))
    }
}

fn count(line: usize, tok: &str, what: &str) -> Result<usize, String> {
    let n: u64 = num(line, tok, what)?;
    if n > MAX_DECLARED {
        return Err(format!(
            "line {line}: {what} {n} is more than this page reads ({MAX_DECLARED})"
        ));
    }
    Ok(n as usize)
}

fn expect_len(line: usize, toks: &[&str], n: usize, what: &str) -> Result<(), String> {
    if toks.len() == n {
        Ok(())
    } else {
        Err(format!(
            "line {line}: expected {what} ({n} values), found {} values",
            toks.len()
        ))
    }
}

fn xyz(line: usize, toks: &[&str], what: &str) -> Result<[f64; 3], String> {
    Ok([
        coord(line, toks[0], &format!("x of {what}"))?,
        coord(line, toks[1], &format!("y of {what}"))?,
        coord(line, toks[2], &format!("z of {what}"))?,
    ])
}

/// `tetmesh 1`: header, `n_nodes n_tets`, node lines `x y z`, tetrahedron
/// lines `i j k l` (0-based). Blank lines are allowed; nothing may follow.
pub fn parse_tetmesh(s: &str) -> Result<FileMesh, String> {
    let mut r = Lines::new(s);
    let (ln, t) = r.tokens("the header")?;
    if t != ["tetmesh", "1"] {
        return Err(format!(
            "line {ln}: expected the header \"tetmesh 1\", found \"{}\"",
            shorten(&t.join(" "))
        ));
    }
    let (ln, t) = r.tokens("the counts")?;
    expect_len(ln, &t, 2, "\"<n_nodes> <n_tets>\"")?;
    let n_nodes = count(ln, t[0], "node count")?;
    let n_tets = count(ln, t[1], "tetrahedron count")?;
    let mut m = FileMesh {
        nodes: Vec::with_capacity(n_nodes),
        tets: Vec::with_capacity(n_tets),
    };
    for k in 0..n_nodes {
        let what = format!("node {k}");
        let (ln, t) = r.tokens(&what)?;
        expect_len(ln, &t, 3, &format!("3 coordinates of {what}"))?;
        m.nodes.push(xyz(ln, &t, &what)?);
    }
    for k in 0..n_tets {
        let what = format!("tetrahedron {k}");
        let (ln, t) = r.tokens(&what)?;
        expect_len(ln, &t, 4, &format!("4 node indices of {what}"))?;
        let mut tet = [0u32; 4];
        for (v, tok) in tet.iter_mut().zip(&t) {
            let i: u64 = num(ln, tok, &format!("node index of {what}"))?;
            if i >= n_nodes as u64 {
                return Err(format!(
                    "line {ln}: {what} refers to node {i}, but there are {n_nodes} nodes"
                ));
            }
            *v = i as u32;
        }
        m.tets.push(tet);
    }
    if let Some((ln, _)) = r.next() {
        return Err(format!(
            "line {ln}: unexpected content after the last tetrahedron"
        ));
    }
    Ok(m)
}

/// Gmsh `.msh` ASCII, version 2.x or 4.1.
pub fn parse_msh(bytes: &[u8]) -> Result<FileMesh, String> {
    // The header is ASCII even in binary files: check it before decoding.
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(256)]);
    let mut h = Lines::new(&head);
    h.next(); // $MeshFormat
    let (ln, t) = h.tokens("the format line")?;
    if t.len() < 3 {
        return Err(format!(
            "line {ln}: expected \"version file-type data-size\""
        ));
    }
    let version = t[0];
    if t[1] != "0" {
        return Err(
            "binary .msh is not read: save the mesh as ASCII (Gmsh: File › Export, format ASCII)"
                .to_owned(),
        );
    }
    let s = text(bytes)?;
    let major = version.split('.').next().unwrap_or("");
    match (major, version) {
        ("2", _) => parse_msh_sections(s, Version::V2),
        (_, "4.1") => parse_msh_sections(s, Version::V41),
        _ => Err(format!(
            "MSH version {} is not read: save the mesh as MSH 2.2 or 4.1 ASCII",
            shorten(version)
        )),
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Version {
    V2,
    V41,
}

/// Gmsh element type of the 4-node tetrahedron.
const TET4: u32 = 4;

fn parse_msh_sections(s: &str, version: Version) -> Result<FileMesh, String> {
    let mut r = Lines::new(s);
    let mut tags: HashMap<u64, u32> = HashMap::new();
    let mut m = FileMesh::default();
    // Element node tags, mapped once all nodes are known (a file may list
    // $Elements before $Nodes only in theory, but the map is cheap).
    let mut raw: Vec<(usize, [u64; 4])> = Vec::new();
    let (mut saw_nodes, mut saw_elements) = (false, false);
    let mut skipped = 0usize;
    while let Some((ln, line)) = r.next() {
        let Some(name) = line.strip_prefix('$') else {
            return Err(format!(
                "line {ln}: expected a section such as \"$Nodes\", found \"{}\"",
                shorten(line)
            ));
        };
        let end = format!("$End{name}");
        match name {
            "Nodes" if !saw_nodes => {
                saw_nodes = true;
                match version {
                    Version::V2 => nodes_v2(&mut r, &mut m, &mut tags)?,
                    Version::V41 => nodes_v41(&mut r, &mut m, &mut tags)?,
                }
            }
            "Elements" if !saw_elements => {
                saw_elements = true;
                skipped = match version {
                    Version::V2 => elements_v2(&mut r, &mut raw)?,
                    Version::V41 => elements_v41(&mut r, &mut raw)?,
                };
            }
            "Nodes" | "Elements" => return Err(format!("line {ln}: a second ${name} section")),
            _ => {}
        }
        // Skip to the section's end (at once for the two read above).
        loop {
            match r.next() {
                Some((_, l)) if l == end => break,
                Some((eln, l)) if matches!(name, "Nodes" | "Elements") => {
                    return Err(format!(
                        "line {eln}: expected \"{end}\", found \"{}\"",
                        shorten(l)
                    ))
                }
                Some(_) => {}
                None => {
                    return Err(format!(
                        "line {}: the file ends before \"{end}\"",
                        r.last + 1
                    ))
                }
            }
        }
    }
    if !saw_nodes {
        return Err("no $Nodes section".to_owned());
    }
    if raw.is_empty() {
        return Err(format!(
            "no 4-node tetrahedron (Gmsh type 4) in the file ({skipped} other elements skipped): mesh the volume (Gmsh: Mesh › 3D)"
        ));
    }
    m.tets.reserve(raw.len());
    for (ln, t) in raw {
        let mut tet = [0u32; 4];
        for (v, tag) in tet.iter_mut().zip(t) {
            *v = *tags.get(&tag).ok_or_else(|| {
                format!("line {ln}: the element refers to node {tag}, which $Nodes does not list")
            })?;
        }
        m.tets.push(tet);
    }
    Ok(m)
}

fn add_node(
    ln: usize,
    tag: u64,
    p: [f64; 3],
    m: &mut FileMesh,
    tags: &mut HashMap<u64, u32>,
) -> Result<(), String> {
    if tags.insert(tag, m.nodes.len() as u32).is_some() {
        return Err(format!("line {ln}: node tag {tag} is listed twice"));
    }
    m.nodes.push(p);
    Ok(())
}

fn nodes_v2(r: &mut Lines, m: &mut FileMesh, tags: &mut HashMap<u64, u32>) -> Result<(), String> {
    let (ln, t) = r.tokens("the node count")?;
    expect_len(ln, &t, 1, "the node count")?;
    let n = count(ln, t[0], "node count")?;
    m.nodes.reserve(n);
    for k in 0..n {
        let what = format!("node {} of {n}", k + 1);
        let (ln, t) = r.tokens(&what)?;
        expect_len(ln, &t, 4, &format!("\"tag x y z\" of {what}"))?;
        let tag: u64 = num(ln, t[0], "node tag")?;
        add_node(ln, tag, xyz(ln, &t[1..], &format!("node {tag}"))?, m, tags)?;
    }
    Ok(())
}

fn elements_v2(r: &mut Lines, raw: &mut Vec<(usize, [u64; 4])>) -> Result<usize, String> {
    let (ln, t) = r.tokens("the element count")?;
    expect_len(ln, &t, 1, "the element count")?;
    let n = count(ln, t[0], "element count")?;
    let mut skipped = 0;
    for k in 0..n {
        let what = format!("element {} of {n}", k + 1);
        let (ln, t) = r.tokens(&what)?;
        if t.len() < 3 {
            return Err(format!(
                "line {ln}: expected \"tag type n-tags ...\" of {what}"
            ));
        }
        let ty: u32 = num(ln, t[1], "element type")?;
        let ntags: usize = num(ln, t[2], "number of element tags")?;
        if ty != TET4 {
            skipped += 1;
            continue;
        }
        expect_len(
            ln,
            &t,
            3 + ntags + 4,
            &format!("a tetrahedron with {ntags} tags"),
        )?;
        let mut tet = [0u64; 4];
        for (v, tok) in tet.iter_mut().zip(&t[3 + ntags..]) {
            *v = num(ln, tok, "node tag")?;
        }
        raw.push((ln, tet));
    }
    Ok(skipped)
}

fn nodes_v41(r: &mut Lines, m: &mut FileMesh, tags: &mut HashMap<u64, u32>) -> Result<(), String> {
    let (ln, t) = r.tokens("the $Nodes header")?;
    expect_len(
        ln,
        &t,
        4,
        "\"numEntityBlocks numNodes minNodeTag maxNodeTag\"",
    )?;
    let blocks = count(ln, t[0], "entity block count")?;
    let total = count(ln, t[1], "node count")?;
    m.nodes.reserve(total);
    for b in 0..blocks {
        let (ln, t) = r.tokens(&format!("node block {}", b + 1))?;
        expect_len(
            ln,
            &t,
            4,
            "\"entityDim entityTag parametric numNodesInBlock\"",
        )?;
        let n = count(ln, t[3], "nodes in block")?;
        if m.nodes.len() + n > total {
            return Err(format!(
                "line {ln}: the node blocks hold more than the {total} nodes declared"
            ));
        }
        let mut block_tags = Vec::with_capacity(n);
        for _ in 0..n {
            let (ln, t) = r.tokens("a node tag")?;
            expect_len(ln, &t, 1, "one node tag per line")?;
            block_tags.push((ln, num::<u64>(ln, t[0], "node tag")?));
        }
        for &(_, tag) in &block_tags {
            let (ln, t) = r.tokens(&format!("the coordinates of node {tag}"))?;
            if t.len() < 3 {
                return Err(format!("line {ln}: expected \"x y z\" of node {tag}"));
            }
            add_node(ln, tag, xyz(ln, &t, &format!("node {tag}"))?, m, tags)?;
        }
    }
    if m.nodes.len() != total {
        return Err(format!(
            "$Nodes declares {total} nodes but its blocks hold {}",
            m.nodes.len()
        ));
    }
    Ok(())
}

fn elements_v41(r: &mut Lines, raw: &mut Vec<(usize, [u64; 4])>) -> Result<usize, String> {
    let (ln, t) = r.tokens("the $Elements header")?;
    expect_len(
        ln,
        &t,
        4,
        "\"numEntityBlocks numElements minElementTag maxElementTag\"",
    )?;
    let blocks = count(ln, t[0], "entity block count")?;
    let total = count(ln, t[1], "element count")?;
    let (mut seen, mut skipped) = (0usize, 0usize);
    for b in 0..blocks {
        let (ln, t) = r.tokens(&format!("element block {}", b + 1))?;
        expect_len(
            ln,
            &t,
            4,
            "\"entityDim entityTag elementType numElementsInBlock\"",
        )?;
        let ty: u32 = num(ln, t[2], "element type")?;
        let n = count(ln, t[3], "elements in block")?;
        seen += n;
        if seen > total {
            return Err(format!(
                "line {ln}: the element blocks hold more than the {total} elements declared"
            ));
        }
        for _ in 0..n {
            let (ln, t) = r.tokens("an element")?;
            if ty != TET4 {
                skipped += 1;
                continue;
            }
            expect_len(ln, &t, 5, "\"tag n1 n2 n3 n4\" of a tetrahedron")?;
            let mut tet = [0u64; 4];
            for (v, tok) in tet.iter_mut().zip(&t[1..]) {
                *v = num(ln, tok, "node tag")?;
            }
            raw.push((ln, tet));
        }
    }
    if seen != total {
        return Err(format!(
            "$Elements declares {total} elements but its blocks hold {seen}"
        ));
    }
    Ok(skipped)
}

/// A read mesh made ready for the solver: unused nodes dropped (Gmsh files
/// keep geometry points), counts checked, f32 coordinates. A body whose
/// largest extent is not between 5 cm and 2 m (a file in millimetres, say)
/// is scaled to 0.4 m; the returned note says so.
pub fn prepare(m: &FileMesh) -> Result<(super::demo::Mesh, String), String> {
    if m.tets.is_empty() {
        return Err("the mesh has no tetrahedron".to_owned());
    }
    if m.tets.len() > MAX_TETS {
        return Err(format!(
            "{} tetrahedra: the page takes at most {MAX_TETS} (a frame would take seconds)",
            m.tets.len()
        ));
    }
    let mut new_index = vec![u32::MAX; m.nodes.len()];
    let mut nodes64 = Vec::new();
    for t in &m.tets {
        for &i in t {
            let slot = &mut new_index[i as usize];
            if *slot == u32::MAX {
                *slot = nodes64.len() as u32;
                nodes64.push(m.nodes[i as usize]);
            }
        }
    }
    if nodes64.len() > MAX_NODES {
        return Err(format!(
            "{} nodes: the solver addresses at most {MAX_NODES}",
            nodes64.len()
        ));
    }
    let dropped = m.nodes.len() - nodes64.len();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &nodes64 {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    // `!(x > 0)` also rejects NaN, which `x <= 0` would let through.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(extent > 0.0) {
        return Err("the mesh is flat: all nodes lie at one point".to_owned());
    }
    let scale = if (0.05..=2.0).contains(&extent) {
        1.0
    } else {
        0.4 / extent
    };
    let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), lo[2]];
    let nodes = nodes64
        .iter()
        .map(|p| {
            [
                ((p[0] - centre[0]) * scale) as f32,
                ((p[1] - centre[1]) * scale) as f32,
                ((p[2] - centre[2]) * scale) as f32,
            ]
        })
        .collect();
    let tets = m
        .tets
        .iter()
        .map(|t| t.map(|i| new_index[i as usize]))
        .collect();
    let mut note = String::new();
    if scale != 1.0 {
        note.push_str(&format!("scaled ×{} to 0.4 m. ", sig3(scale)));
    }
    if dropped > 0 {
        note.push_str(&format!("{dropped} nodes in no tetrahedron dropped. "));
    }
    Ok((
        super::demo::Mesh { nodes, tets },
        note.trim_end().to_owned(),
    ))
}

/// Positive `x` to 3 significant digits in plain decimal ("0.004", "25.4",
/// "1500"), without the float formatter (it would add 20 kB to the module).
fn sig3(x: f64) -> String {
    if !(x > 0.0 && x.is_finite()) {
        return "?".to_owned();
    }
    let mut e = x.log10().floor() as i32;
    let mut m = (x / 10f64.powi(e - 2)).round() as u64; // 100..=1000
    if m >= 1000 {
        m /= 10;
        e += 1;
    }
    if e >= 2 {
        return (m * 10u64.pow((e - 2) as u32)).to_string();
    }
    let digits = m.to_string(); // three digits
    let decimals = (2 - e) as usize;
    let s = if decimals >= 3 {
        format!("0.{}{digits}", "0".repeat(decimals - 3))
    } else {
        format!("{}.{}", &digits[..3 - decimals], &digits[3 - decimals..])
    };
    s.trim_end_matches('0').trim_end_matches('.').to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    const TET: &str = "tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 1 2 3\n";

    #[test]
    fn tetmesh_reads_and_reports_errors_by_line() {
        let m = parse(TET.as_bytes()).unwrap();
        assert_eq!(m.nodes.len(), 4);
        assert_eq!(m.tets, vec![[0, 1, 2, 3]]);
        let bad = TET.replace("0 1 2 3", "0 1 2 4");
        assert_eq!(
            parse(bad.as_bytes()).unwrap_err(),
            "line 7: tetrahedron 0 refers to node 4, but there are 4 nodes"
        );
        let bad = TET.replace("1 0 0", "1 x 0");
        assert!(parse(bad.as_bytes())
            .unwrap_err()
            .starts_with("line 4: y of node 1"));
        let bad = format!("{TET}0 1 2 3\n");
        assert!(parse(bad.as_bytes())
            .unwrap_err()
            .contains("after the last"));
        assert!(parse(b"tetmesh 1\n4 1\n0 0 0\n")
            .unwrap_err()
            .contains("ends before node 1"));
        assert!(parse(b"hello").unwrap_err().starts_with("not a mesh file"));
        assert!(parse(b"tetmesh 1\n99999999999 1\n")
            .unwrap_err()
            .contains("more than this page reads"));
    }

    /// Two tetrahedra sharing a face, with a line, a triangle, an unused node
    /// and tags out of order.
    const V2: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 \"body\"\n$EndPhysicalNames\n\
$Nodes\n6\n10 0 0 0\n20 1 0 0\n30 0 1 0\n40 0 0 1\n50 1 1 1\n99 5 5 5\n$EndNodes\n\
$Elements\n4\n1 1 2 0 1 10 20\n2 2 2 0 1 10 20 30\n3 4 2 1 1 10 20 30 40\n4 4 2 1 1 20 30 40 50\n$EndElements\n";

    #[test]
    fn msh2_reads_tets_only_and_maps_tags() {
        let m = parse(V2.as_bytes()).unwrap();
        assert_eq!(m.nodes.len(), 6);
        assert_eq!(m.tets, vec![[0, 1, 2, 3], [1, 2, 3, 4]]);
        let (mesh, note) = prepare(&m).unwrap();
        assert_eq!(mesh.nodes.len(), 5);
        assert_eq!(note, "1 nodes in no tetrahedron dropped.");
        let bad = V2.replace("20 30 40 50", "20 30 40 77");
        assert_eq!(
            parse(bad.as_bytes()).unwrap_err(),
            "line 22: the element refers to node 77, which $Nodes does not list"
        );
        let bad = V2.replace("$EndNodes", "$EndNode");
        assert!(parse(bad.as_bytes())
            .unwrap_err()
            .contains("expected \"$EndNodes\""));
        let bin = V2.replace("2.2 0 8", "2.2 1 8");
        assert!(parse(bin.as_bytes())
            .unwrap_err()
            .starts_with("binary .msh"));
    }

    const V41: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 0 1\n1 0 0 0 1 1 1 0 0\n$EndEntities\n\
$Nodes\n2 5 1 5\n0 1 0 1\n1\n0 0 0\n3 1 0 4\n2\n3\n4\n5\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n\
$Elements\n2 3 1 3\n2 1 2 1\n1 1 2 3\n3 1 4 2\n2 1 2 3 4\n3 2 3 4 5\n$EndElements\n";

    #[test]
    fn msh41_reads_blocks() {
        let m = parse(V41.as_bytes()).unwrap();
        assert_eq!(m.nodes.len(), 5);
        assert_eq!(m.nodes[4], [1.0, 1.0, 1.0]);
        assert_eq!(m.tets, vec![[0, 1, 2, 3], [1, 2, 3, 4]]);
        let bad = V41.replace("3 1 4 2", "3 1 4 3");
        assert!(parse(bad.as_bytes())
            .unwrap_err()
            .contains("more than the 3 elements declared"));
        let v40 = V41.replace("4.1 0 8", "4 0 8");
        assert!(parse(v40.as_bytes())
            .unwrap_err()
            .starts_with("MSH version 4 is not read"));
    }

    #[test]
    fn three_significant_digits() {
        for (x, s) in [
            (0.004, "0.004"),
            (0.00123456, "0.00123"),
            (25.44, "25.4"),
            (1500.2, "1500"),
            (9.996, "10"),
            (0.5, "0.5"),
            (123.0, "123"),
        ] {
            assert_eq!(sig3(x), s, "{x}");
        }
    }

    #[test]
    fn prepare_scales_millimetres_and_rejects_flat() {
        let mut m = parse(TET.as_bytes()).unwrap();
        for p in &mut m.nodes {
            *p = p.map(|c| 100.0 * c);
        }
        let (mesh, note) = prepare(&m).unwrap();
        assert!(note.starts_with("scaled ×0.004"), "{note}");
        assert!((mesh.nodes[1][0] - 0.2).abs() < 1e-6 && (mesh.nodes[1][1] + 0.2).abs() < 1e-6);
        for p in &mut m.nodes {
            *p = [1.0; 3];
        }
        assert!(prepare(&m).unwrap_err().contains("flat"));
    }
}
