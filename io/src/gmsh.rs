//! Gmsh `.msh` files: ASCII MSH 4.1, 2.x and the old 1.0 by hand, binary MSH 4.1
//! through the `mshio` crate (feature `gmsh-binary`, on by default).
//!
//! The ASCII readers are hand-written, need nothing but `std` and share one
//! reading loop: only two sections matter (`$Nodes`, `$Elements`), every other
//! section is skipped, and Gmsh writes one record per line (a node tag, a node's
//! coordinates, an element), which the readers expect and which lets them skip
//! element types without knowing their node counts. MSH 1.0 (`$NOD` / `$ELM`,
//! e.g. SOFA's `liver.msh`) has the structure of MSH 2. `$Nodes` may come before
//! or after `$Elements`. The crates that claim MSH 2 support (`rutile` 0.1.1,
//! `msh-rw` 0.1.0) are unmaintained since 2020–2021 and describe their MSH 2
//! support as incomplete; `mshio` reads only MSH 4.1 and pulls in `nom` and `num`,
//! too much for a small wasm module. Binary MSH 2 is not read
//! ([`MeshError::Unsupported`]).
//!
//! For binary MSH 4.1, `mshio` does the parsing and error reporting. Two small
//! scans of the raw bytes surround it: one refuses absurd section counts before
//! `mshio` allocates, and one reads the node tags in file order, because `mshio`
//! keeps tags only when they are sparse (and then in a hash map), assuming dense
//! tags are listed in increasing order, which the format does not promise.
//!
//! In every version only 4-node tetrahedra (element type 4) are kept; points,
//! lines, triangles and other types are skipped. Node tags are arbitrary positive
//! integers: they are mapped to 0-based indices in the order the nodes appear in
//! the file. Nodes that no tetrahedron uses are kept (see
//! [`drop_unused_nodes`](crate::drop_unused_nodes)).

use std::collections::HashMap;

#[cfg(feature = "gmsh-binary")]
use mshio::mshfile::ElementType;

use crate::error::{check_count, MeshError};
#[cfg(feature = "gmsh-binary")]
use crate::guard::catch_quietly;
use crate::mesh::Mesh;
use crate::text::{plural, shorten, tokens, LineReader};

/// Gmsh element type number of the 4-node tetrahedron.
const GMSH_TET4: u64 = 4;

/// Whether a Gmsh element type is a tetrahedron of second or higher order
/// (10-node type 11 and the complete and incomplete ones of GmshDefines.h),
/// which the readers skip and the error message names.
fn higher_order_tet(ty: u64) -> bool {
    matches!(ty, 11 | 29..=33 | 71..=75 | 79..=83)
}

/// The MSH version a file declares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Version {
    /// MSH 1.0 (`$NOD` ... `$ELM`).
    V1,
    /// MSH 2.x ASCII.
    V2Ascii,
    /// MSH 4.1 ASCII.
    V41Ascii,
    /// MSH 4.1 binary.
    #[cfg(feature = "gmsh-binary")]
    V41Binary,
}

/// What [`parse_msh`] reads, for error messages.
#[cfg(feature = "gmsh-binary")]
const READABLE: &str = "MSH 4.1 (ASCII or binary), MSH 2.x ASCII and MSH 1.0";
#[cfg(not(feature = "gmsh-binary"))]
const READABLE: &str = "MSH 4.1 ASCII, MSH 2.x ASCII and MSH 1.0";

/// Parses the bytes of a Gmsh `.msh` file of version 1.0, 2.x (ASCII) or 4.1
/// (ASCII, and binary with the `gmsh-binary` feature); the version is detected
/// from the `$MeshFormat` header (MSH 1.0 has none and starts with `$NOD`).
///
/// `name` is only used in error messages (normally the file name). Declared node
/// and element counts are checked against [`MAX_COUNT`](crate::MAX_COUNT) before
/// anything is allocated for them.
pub fn parse_msh(bytes: &[u8], name: &str) -> Result<Mesh, MeshError> {
    match detect_version(bytes, name)? {
        #[cfg(feature = "gmsh-binary")]
        Version::V41Binary => parse_v41_binary(bytes, name),
        version => parse_ascii(utf8(bytes, name)?, name, version),
    }
}

fn utf8<'a>(bytes: &'a [u8], name: &str) -> Result<&'a str, MeshError> {
    std::str::from_utf8(bytes).map_err(|e| {
        let line = 1 + bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        MeshError::Malformed {
            file: name.to_owned(),
            line: Some(line),
            expected: "ASCII text".to_owned(),
            found: "bytes that are not valid UTF-8".to_owned(),
        }
    })
}

/// The first `n` lines of `bytes` (as lossy text, trimmed) with their line numbers,
/// skipping blank lines. Only used on the ASCII header of a file.
fn head_lines(bytes: &[u8], n: usize) -> Vec<(usize, String)> {
    bytes
        .split(|&b| b == b'\n')
        .take(64)
        .enumerate()
        .map(|(i, l)| (i + 1, String::from_utf8_lossy(l).trim().to_owned()))
        .filter(|(_, l)| !l.is_empty())
        .take(n)
        .collect()
}

fn detect_version(bytes: &[u8], name: &str) -> Result<Version, MeshError> {
    let head = head_lines(bytes, 2);
    let Some((ln, first)) = head.first() else {
        return Err(MeshError::Truncated {
            file: name.to_owned(),
            line: 1,
            expected: "\"$MeshFormat\" (Gmsh 2 or 4) or \"$NOD\" (Gmsh 1)".to_owned(),
        });
    };
    if first == "$NOD" {
        return Ok(Version::V1);
    }
    if first != "$MeshFormat" {
        return Err(MeshError::Malformed {
            file: name.to_owned(),
            line: Some(*ln),
            expected: "\"$MeshFormat\" (Gmsh 2 or 4) or \"$NOD\" (Gmsh 1)".to_owned(),
            found: format!("\"{}\"", shorten(first)),
        });
    }
    let Some((ln, fmt)) = head.get(1) else {
        return Err(MeshError::Truncated {
            file: name.to_owned(),
            line: ln + 1,
            expected: "format line \"<version> <file-type> <data-size>\"".to_owned(),
        });
    };
    let ln = Some(*ln);
    let t = tokens(fmt);
    if t.len() != 3 {
        return Err(MeshError::Malformed {
            file: name.to_owned(),
            line: ln,
            expected: "format line \"<version> <file-type> <data-size>\"".to_owned(),
            found: format!("\"{}\"", shorten(fmt)),
        });
    }
    let binary = match t[1] {
        "0" => false,
        "1" => true,
        other => {
            return Err(MeshError::Malformed {
                file: name.to_owned(),
                line: ln,
                expected: "file type 0 (ASCII) or 1 (binary)".to_owned(),
                found: format!("\"{}\"", shorten(other)),
            })
        }
    };
    // The data size matters for binary files only (mshio panics on odd sizes).
    if binary && !matches!(t[2], "4" | "8") {
        return Err(MeshError::Unsupported {
            file: name.to_owned(),
            line: ln,
            what: format!(
                "data size \"{}\" (only 8, as Gmsh writes, or 4)",
                shorten(t[2])
            ),
        });
    }
    let version = t[0];
    let unsupported = |what: String| MeshError::Unsupported {
        file: name.to_owned(),
        line: ln,
        what: format!(
            "{what}; readable are {READABLE} \
             (in Gmsh: File > Export, format \"Version 4.1\" or \"Version 2 ASCII\")"
        ),
    };
    if version == "4.1" {
        match binary {
            false => Ok(Version::V41Ascii),
            #[cfg(feature = "gmsh-binary")]
            true => Ok(Version::V41Binary),
            #[cfg(not(feature = "gmsh-binary"))]
            true => Err(unsupported("binary MSH 4.1".to_owned())),
        }
    } else if version == "2" || version.starts_with("2.") {
        if binary {
            Err(unsupported(format!("binary MSH {version}")))
        } else {
            Ok(Version::V2Ascii)
        }
    } else {
        Err(unsupported(format!("MSH version {}", shorten(version))))
    }
}

// ---------------------------------------------------------------------------
// ASCII: MSH 1.0, 2.x and 4.1 (hand-written)
// ---------------------------------------------------------------------------

/// Section markers of the ASCII versions (MSH 2 and 4.1 share theirs).
struct Markers {
    nodes: &'static str,
    end_nodes: &'static str,
    elements: &'static str,
    end_elements: &'static str,
}

const V1_MARKERS: Markers = Markers {
    nodes: "$NOD",
    end_nodes: "$ENDNOD",
    elements: "$ELM",
    end_elements: "$ENDELM",
};

const V2_MARKERS: Markers = Markers {
    nodes: "$Nodes",
    end_nodes: "$EndNodes",
    elements: "$Elements",
    end_elements: "$EndElements",
};

/// The nodes of a `$Nodes` section: coordinates in file order and the index of
/// each tag.
struct NodeTable {
    coords: Vec<[f64; 3]>,
    index_of: HashMap<u64, usize>,
}

/// The tetrahedra of an `$Elements` section as node tags, each with its line
/// (mapped to indices once every section is read), and how many elements of
/// other types were skipped.
#[derive(Default)]
struct RawTets {
    tets: Vec<(usize, [u64; 4])>,
    skipped: usize,
    /// How many of the skipped are higher-order tetrahedra.
    higher_order: usize,
}

fn parse_ascii(text: &str, name: &str, version: Version) -> Result<Mesh, MeshError> {
    let m = if version == Version::V1 {
        &V1_MARKERS
    } else {
        &V2_MARKERS
    };
    let mut r = LineReader::new(text, name);
    let mut nodes: Option<NodeTable> = None;
    let mut tets: Option<RawTets> = None;

    while let Some((ln, line)) = r.next_line() {
        if line == m.nodes {
            if nodes.is_some() {
                return Err(MeshError::Unsupported {
                    file: name.to_owned(),
                    line: Some(ln),
                    what: format!("a second {} section", m.nodes),
                });
            }
            nodes = Some(if version == Version::V41Ascii {
                read_nodes_v41(&mut r, ln)?
            } else {
                read_nodes(&mut r, ln, m)?
            });
        } else if line == m.elements {
            if tets.is_some() {
                return Err(MeshError::Unsupported {
                    file: name.to_owned(),
                    line: Some(ln),
                    what: format!("a second {} section", m.elements),
                });
            }
            tets = Some(if version == Version::V41Ascii {
                read_elements_v41(&mut r, ln)?
            } else {
                read_elements(&mut r, ln, m, version)?
            });
        } else if let Some(section) = line.strip_prefix('$') {
            skip_section(&mut r, ln, section)?;
        } else {
            return Err(r.malformed(
                ln,
                "a section start such as \"$Nodes\"".to_owned(),
                format!("\"{}\"", shorten(line)),
            ));
        }
    }

    let Some(NodeTable {
        coords: nodes,
        index_of,
    }) = nodes
    else {
        return Err(MeshError::Malformed {
            file: name.to_owned(),
            line: None,
            expected: format!("a {} section", m.nodes),
            found: "none".to_owned(),
        });
    };
    let RawTets {
        tets: raw,
        skipped,
        higher_order,
    } = tets.unwrap_or_default();
    if raw.is_empty() {
        return Err(MeshError::NoTetrahedra {
            file: name.to_owned(),
            skipped,
            higher_order,
        });
    }
    let mut tets = Vec::with_capacity(raw.len());
    for (ln, tags) in raw {
        let mut tet = [0usize; 4];
        for (v, tag) in tet.iter_mut().zip(tags) {
            *v = *index_of
                .get(&tag)
                .ok_or_else(|| MeshError::UnknownNodeTag {
                    file: name.to_owned(),
                    line: Some(ln),
                    tag,
                })?;
        }
        tets.push(tet);
    }
    Ok(Mesh { nodes, tets })
}

/// Skips an unknown section `$Name` ... `$EndName` (case-insensitively, as MSH 1
/// writes `$ENDNAME`).
fn skip_section(r: &mut LineReader<'_>, start: usize, section: &str) -> Result<(), MeshError> {
    let end = format!("$End{section}");
    loop {
        let (_, line) =
            r.expect_line(|| format!("\"{end}\" closing the section on line {start}"))?;
        if line.eq_ignore_ascii_case(&end) {
            return Ok(());
        }
    }
}

/// Reads the count line of a section and checks it against the limit.
fn read_count(r: &mut LineReader<'_>, what: &str) -> Result<usize, MeshError> {
    let (ln, line) = r.expect_line(|| format!("the number of {what}s"))?;
    let t = tokens(line);
    if t.len() != 1 {
        return Err(r.malformed(
            ln,
            format!("1 value (the number of {what}s)"),
            plural(t.len(), "value"),
        ));
    }
    let n = r.u64(ln, t[0], || format!("number of {what}s"))?;
    check_count(r.file(), Some(ln), what, n)
}

/// After the declared number of entries, checks that the end marker follows.
fn expect_end(
    r: &mut LineReader<'_>,
    end: &str,
    what: &str,
    declared: usize,
) -> Result<(), MeshError> {
    let (ln, line) = r.expect_line(|| format!("\"{end}\""))?;
    if line == end {
        return Ok(());
    }
    if line.starts_with('$') {
        return Err(r.malformed(ln, format!("\"{end}\""), format!("\"{}\"", shorten(line))));
    }
    // Count the surplus entries to say how many there really are.
    let mut found = declared + 1;
    while let Some((_, l)) = r.next_line() {
        if l == end || l.starts_with('$') {
            break;
        }
        found += 1;
    }
    Err(MeshError::CountMismatch {
        file: r.file().to_owned(),
        line: Some(ln),
        what: format!("{what}s"),
        declared,
        found,
    })
}

fn read_nodes(r: &mut LineReader<'_>, start: usize, m: &Markers) -> Result<NodeTable, MeshError> {
    let n = read_count(r, "node")?;
    let mut nodes = Vec::with_capacity(n);
    let mut tags: HashMap<u64, usize> = HashMap::with_capacity(n);
    for k in 0..n {
        let (ln, line) = r.expect_line(|| {
            format!(
                "node {} of {n} of the {} section on line {start}",
                k + 1,
                m.nodes
            )
        })?;
        if line == m.end_nodes {
            return Err(MeshError::CountMismatch {
                file: r.file().to_owned(),
                line: Some(ln),
                what: "nodes".to_owned(),
                declared: n,
                found: k,
            });
        }
        let t = tokens(line);
        if t.len() != 4 {
            return Err(r.malformed(
                ln,
                "a node \"<tag> <x> <y> <z>\" (4 values)".to_owned(),
                plural(t.len(), "value"),
            ));
        }
        let tag = r.u64(ln, t[0], || "node tag".to_owned())?;
        let mut p = [0.0; 3];
        for (c, (v, tok)) in p.iter_mut().zip(&t[1..]).enumerate() {
            *v = r.f64(ln, tok, || {
                format!("{} coordinate of node tag {tag}", ["x", "y", "z"][c])
            })?;
        }
        if let Some(first) = tags.insert(tag, k) {
            return Err(r.malformed(
                ln,
                "a unique node tag".to_owned(),
                format!(
                    "tag {tag} again (first used by node {} of the section)",
                    first + 1
                ),
            ));
        }
        nodes.push(p);
    }
    expect_end(r, m.end_nodes, "node", n)?;
    Ok(NodeTable {
        coords: nodes,
        index_of: tags,
    })
}

fn read_elements(
    r: &mut LineReader<'_>,
    start: usize,
    m: &Markers,
    version: Version,
) -> Result<RawTets, MeshError> {
    let n = read_count(r, "element")?;
    let mut tets = Vec::new();
    let (mut skipped, mut higher_order) = (0, 0);
    for k in 0..n {
        let (ln, line) = r.expect_line(|| {
            format!(
                "element {} of {n} of the {} section on line {start}",
                k + 1,
                m.elements
            )
        })?;
        if line == m.end_elements {
            return Err(MeshError::CountMismatch {
                file: r.file().to_owned(),
                line: Some(ln),
                what: "elements".to_owned(),
                declared: n,
                found: k,
            });
        }
        let t = tokens(line);
        // MSH 2: tag type n-tags <tags...> <nodes...>
        // MSH 1: number type reg-phys reg-elem n-nodes <nodes...>
        let (layout, min_len) = if version == Version::V1 {
            (
                "\"<number> <type> <reg-phys> <reg-elem> <n-nodes> <nodes...>\"",
                5,
            )
        } else {
            ("\"<tag> <type> <n-tags> <tags...> <nodes...>\"", 3)
        };
        if t.len() < min_len {
            return Err(r.malformed(ln, format!("an element {layout}"), plural(t.len(), "value")));
        }
        r.u64(ln, t[0], || "element tag".to_owned())?;
        let ty = r.u64(ln, t[1], || "element type".to_owned())?;
        if ty != GMSH_TET4 {
            skipped += 1;
            higher_order += usize::from(higher_order_tet(ty));
            continue;
        }
        let first_node = if version == Version::V1 {
            let nn = r.u64(ln, t[4], || "number of nodes".to_owned())?;
            if nn != 4 {
                return Err(r.malformed(
                    ln,
                    "4 nodes for a tetrahedron (type 4)".to_owned(),
                    format!("{nn}"),
                ));
            }
            5
        } else {
            let nt = r.u64(ln, t[2], || "number of tags".to_owned())?;
            // Bounded by the line length, so no overflow below.
            3 + nt.min(t.len() as u64) as usize
        };
        if t.len() != first_node + 4 {
            return Err(r.malformed(
                ln,
                format!(
                    "{} values for a tetrahedron (type 4): {layout}",
                    first_node + 4
                ),
                plural(t.len(), "value"),
            ));
        }
        let mut tet = [0u64; 4];
        for (v, tok) in tet.iter_mut().zip(&t[first_node..]) {
            *v = r.u64(ln, tok, || "node tag".to_owned())?;
        }
        tets.push((ln, tet));
    }
    expect_end(r, m.end_elements, "element", n)?;
    Ok(RawTets {
        tets,
        skipped,
        higher_order,
    })
}

/// Reads a header line of `n` values (`layout` names them) and returns its
/// line number and tokens.
fn header<'a>(
    r: &mut LineReader<'a>,
    n: usize,
    layout: &str,
) -> Result<(usize, Vec<&'a str>), MeshError> {
    let (ln, line) = r.expect_line(|| format!("\"{layout}\""))?;
    let t = tokens(line);
    if t.len() != n {
        return Err(r.malformed(
            ln,
            format!("\"{layout}\" ({n} values)"),
            plural(t.len(), "value"),
        ));
    }
    Ok((ln, t))
}

/// A line of a block that is a section marker: the block holds fewer entries
/// than declared, `found` in all so far.
fn short_block(
    r: &LineReader<'_>,
    ln: usize,
    what: &str,
    declared: usize,
    found: usize,
) -> MeshError {
    MeshError::CountMismatch {
        file: r.file().to_owned(),
        line: Some(ln),
        what: what.to_owned(),
        declared,
        found,
    }
}

/// MSH 4.1 `$Nodes`: a header, then entity blocks of node tags (one per line)
/// followed by their coordinates (one node per line; a parametric block adds
/// the entity dimension's number of parametric coordinates, which are skipped).
fn read_nodes_v41(r: &mut LineReader<'_>, start: usize) -> Result<NodeTable, MeshError> {
    let (ln, t) = header(
        r,
        4,
        "<numEntityBlocks> <numNodes> <minNodeTag> <maxNodeTag>",
    )?;
    let blocks = r.u64(ln, t[0], || "number of node entity blocks".to_owned())?;
    let blocks = check_count(r.file(), Some(ln), "node entity block", blocks)?;
    let total = r.u64(ln, t[1], || "number of nodes".to_owned())?;
    let total = check_count(r.file(), Some(ln), "node", total)?;
    r.u64(ln, t[2], || "smallest node tag".to_owned())?;
    r.u64(ln, t[3], || "largest node tag".to_owned())?;
    let mut coords = Vec::with_capacity(total);
    let mut index_of: HashMap<u64, usize> = HashMap::with_capacity(total);
    let mut block_tags = Vec::new();
    for b in 0..blocks {
        let (bln, line) = r.expect_line(|| {
            format!(
                "node block {} of {blocks} of the $Nodes section on line {start}",
                b + 1
            )
        })?;
        if line.starts_with('$') {
            return Err(short_block(r, bln, "nodes", total, coords.len()));
        }
        let t = tokens(line);
        if t.len() != 4 {
            return Err(r.malformed(
                bln,
                "a node block \"<entityDim> <entityTag> <parametric> <numNodesInBlock>\" (4 values)"
                    .to_owned(),
                plural(t.len(), "value"),
            ));
        }
        let dim = r.u64(bln, t[0], || "entity dimension (0 to 3)".to_owned())?;
        r.i64(bln, t[1], || "entity tag".to_owned())?;
        let parametric = r.u64(bln, t[2], || "parametric flag (0 or 1)".to_owned())?;
        if dim > 3 || parametric > 1 {
            return Err(r.malformed(
                bln,
                "entity dimension 0 to 3 and parametric flag 0 or 1".to_owned(),
                format!("{dim} and {parametric}"),
            ));
        }
        let n = r.u64(bln, t[3], || "number of nodes in the block".to_owned())?;
        let n = check_count(r.file(), Some(bln), "node", n)?;
        if n > total - coords.len() {
            return Err(short_block(r, bln, "nodes", total, coords.len() + n));
        }
        block_tags.clear();
        for k in 0..n {
            let (tln, line) = r.expect_line(|| {
                format!("node tag {} of {n} of the node block on line {bln}", k + 1)
            })?;
            if line.starts_with('$') {
                return Err(short_block(r, tln, "nodes", total, coords.len() + k));
            }
            let t = tokens(line);
            if t.len() != 1 {
                return Err(r.malformed(
                    tln,
                    format!(
                        "a node tag alone on its line (node {} of the block on line {bln})",
                        k + 1
                    ),
                    plural(t.len(), "value"),
                ));
            }
            block_tags.push(r.u64(tln, t[0], || "node tag".to_owned())?);
        }
        // Parametric coordinates: u on a curve, u v on a surface, u v w in a volume.
        let values = 3 + if parametric == 1 { dim as usize } else { 0 };
        for &tag in &block_tags {
            let (cln, line) = r.expect_line(|| format!("the coordinates of node tag {tag}"))?;
            let t = tokens(line);
            if t.len() != values {
                return Err(r.malformed(
                    cln,
                    format!("{values} coordinates of node tag {tag}"),
                    plural(t.len(), "value"),
                ));
            }
            let mut p = [0.0; 3];
            for (c, (v, tok)) in p.iter_mut().zip(&t).enumerate() {
                *v = r.f64(cln, tok, || {
                    format!("{} coordinate of node tag {tag}", ["x", "y", "z"][c])
                })?;
            }
            if let Some(first) = index_of.insert(tag, coords.len()) {
                return Err(r.malformed(
                    cln,
                    "a unique node tag".to_owned(),
                    format!(
                        "tag {tag} again (first used by node {} of the section)",
                        first + 1
                    ),
                ));
            }
            coords.push(p);
        }
    }
    if coords.len() != total {
        return Err(short_block(r, ln, "nodes", total, coords.len()));
    }
    expect_end(r, "$EndNodes", "node", total)?;
    Ok(NodeTable { coords, index_of })
}

/// MSH 4.1 `$Elements`: a header, then entity blocks of one element type, one
/// element per line (`<tag> <node tags...>`); blocks of other types than the
/// 4-node tetrahedron are skipped line by line.
fn read_elements_v41(r: &mut LineReader<'_>, start: usize) -> Result<RawTets, MeshError> {
    let (ln, t) = header(
        r,
        4,
        "<numEntityBlocks> <numElements> <minElementTag> <maxElementTag>",
    )?;
    let blocks = r.u64(ln, t[0], || "number of element entity blocks".to_owned())?;
    let blocks = check_count(r.file(), Some(ln), "element entity block", blocks)?;
    let total = r.u64(ln, t[1], || "number of elements".to_owned())?;
    let total = check_count(r.file(), Some(ln), "element", total)?;
    r.u64(ln, t[2], || "smallest element tag".to_owned())?;
    r.u64(ln, t[3], || "largest element tag".to_owned())?;
    let mut raw = RawTets::default();
    let mut seen = 0usize;
    for b in 0..blocks {
        let (bln, line) = r.expect_line(|| {
            format!(
                "element block {} of {blocks} of the $Elements section on line {start}",
                b + 1
            )
        })?;
        if line.starts_with('$') {
            return Err(short_block(r, bln, "elements", total, seen));
        }
        let t = tokens(line);
        if t.len() != 4 {
            return Err(r.malformed(
                bln,
                "an element block \"<entityDim> <entityTag> <elementType> <numElementsInBlock>\" (4 values)"
                    .to_owned(),
                plural(t.len(), "value"),
            ));
        }
        r.u64(bln, t[0], || "entity dimension".to_owned())?;
        r.i64(bln, t[1], || "entity tag".to_owned())?;
        let ty = r.u64(bln, t[2], || "element type".to_owned())?;
        let n = r.u64(bln, t[3], || "number of elements in the block".to_owned())?;
        let n = check_count(r.file(), Some(bln), "element", n)?;
        if n > total - seen {
            return Err(short_block(r, bln, "elements", total, seen + n));
        }
        for k in 0..n {
            let (eln, line) = r.expect_line(|| {
                format!(
                    "element {} of {n} of the element block on line {bln}",
                    k + 1
                )
            })?;
            if line.starts_with('$') {
                return Err(short_block(r, eln, "elements", total, seen + k));
            }
            if ty != GMSH_TET4 {
                raw.skipped += 1;
                raw.higher_order += usize::from(higher_order_tet(ty));
                continue;
            }
            let t = tokens(line);
            if t.len() != 5 {
                return Err(r.malformed(
                    eln,
                    "a tetrahedron \"<tag> <n1> <n2> <n3> <n4>\" (5 values)".to_owned(),
                    plural(t.len(), "value"),
                ));
            }
            r.u64(eln, t[0], || "element tag".to_owned())?;
            let mut tet = [0u64; 4];
            for (v, tok) in tet.iter_mut().zip(&t[1..]) {
                *v = r.u64(eln, tok, || "node tag".to_owned())?;
            }
            raw.tets.push((eln, tet));
        }
        seen += n;
    }
    if seen != total {
        return Err(short_block(r, ln, "elements", total, seen));
    }
    expect_end(r, "$EndElements", "element", total)?;
    Ok(raw)
}

// ---------------------------------------------------------------------------
// Binary MSH 4.1 (mshio)
// ---------------------------------------------------------------------------

/// The binary layout of an MSH 4.1 file: the size of its `size_t` in bytes and
/// whether it is big-endian.
#[cfg(feature = "gmsh-binary")]
#[derive(Debug, Clone, Copy)]
struct Layout {
    size: usize,
    big_endian: bool,
}

/// Reads the two leading counts of the `$Nodes` or `$Elements` section (number of
/// entity blocks and number of entries) without parsing the rest, so absurd counts
/// are refused before `mshio` sees them. Returns `None` if the section is absent
/// or too short; `mshio` then reports the problem.
#[cfg(feature = "gmsh-binary")]
fn section_counts(bytes: &[u8], section: &str, layout: Layout) -> Option<(u64, u64)> {
    let rest = section_body(bytes, section)?;
    let read = |i: usize| {
        Some(uint(
            rest.get(i * layout.size..(i + 1) * layout.size)?,
            layout.big_endian,
        ))
    };
    Some((read(0)?, read(1)?))
}

/// The binary layout of an MSH 4.1 file whose header says it is binary, or `None`
/// if the header does not end as the format requires. The header was validated by
/// [`detect_version`].
#[cfg(feature = "gmsh-binary")]
fn binary_layout(bytes: &[u8]) -> Option<Layout> {
    let head = head_lines(bytes, 2);
    let size: usize = tokens(&head.get(1)?.1).get(2)?.parse().ok()?;
    // The header line is followed by the integer 1 in the file's byte order.
    let marker = b"\n$EndMeshFormat";
    let end = bytes.windows(marker.len()).position(|w| w == marker)?;
    let one = bytes.get(end.checked_sub(4)?..end)?;
    Some(Layout {
        size,
        big_endian: one == [0, 0, 0, 1],
    })
}

/// An unsigned integer of `b.len()` (at most 8) bytes.
#[cfg(feature = "gmsh-binary")]
fn uint(b: &[u8], big_endian: bool) -> u64 {
    let fold = |v: u64, &byte: &u8| (v << 8) | u64::from(byte);
    if big_endian {
        b.iter().fold(0, fold)
    } else {
        b.iter().rev().fold(0, fold)
    }
}

/// The file from just after the marker line of section `section` (e.g. `$Nodes`)
/// to its end.
#[cfg(feature = "gmsh-binary")]
fn section_body<'a>(bytes: &'a [u8], section: &str) -> Option<&'a [u8]> {
    let marker = format!("\n{section}");
    let pos = bytes
        .windows(marker.len())
        .position(|w| w == marker.as_bytes())?;
    let mut rest = &bytes[pos + marker.len()..];
    if rest.first() == Some(&b'\r') {
        rest = &rest[1..];
    }
    rest.strip_prefix(b"\n")
}

/// Reads the node tags of a binary MSH 4.1 `$Nodes` section in file order,
/// skipping the coordinates. `None` if the section does not have the expected
/// layout (mshio has already accepted it, so this means a parametric or otherwise
/// unusual block).
#[cfg(feature = "gmsh-binary")]
fn scan_node_tags(bytes: &[u8], layout: Layout) -> Option<Vec<u64>> {
    let body = section_body(bytes, "$Nodes")?;
    let mut tags = Vec::new();
    let mut at = 0usize;
    let mut read = |len: usize| -> Option<u64> {
        let b = body.get(at..at.checked_add(len)?)?;
        at += len;
        Some(uint(b, layout.big_endian))
    };
    let size = layout.size;
    let blocks = read(size)?;
    for _ in 0..3 {
        read(size)?; // total, min tag, max tag
    }
    for _ in 0..blocks {
        // Entity dimension and tag (ints), parametric flag (int), count.
        let (_dim, _entity, parametric) = (read(4)?, read(4)?, read(4)?);
        let n = read(size)?;
        if parametric != 0 {
            return None;
        }
        for _ in 0..n {
            tags.push(read(size)?);
        }
        // Skip the coordinates (doubles).
        for _ in 0..n.saturating_mul(3) {
            read(8)?;
        }
    }
    Some(tags)
}

#[cfg(feature = "gmsh-binary")]
fn parse_v41_binary(bytes: &[u8], name: &str) -> Result<Mesh, MeshError> {
    let layout = binary_layout(bytes);
    if let Some(layout) = layout {
        for (section, what) in [("$Nodes", "node"), ("$Elements", "element")] {
            if let Some((blocks, count)) = section_counts(bytes, section, layout) {
                check_count(name, None, &format!("{what} entity block"), blocks)?;
                check_count(name, None, what, count)?;
            }
        }
    }

    // mshio 0.4 still has a few `unimplemented!`/`expect` paths.
    let parsed =
        catch_quietly(|| mshio::parse_msh_bytes(bytes).map_err(|e| mshio_error(bytes, name, &e)))
            .ok_or_else(|| MeshError::Parse {
            file: name.to_owned(),
            line: None,
            message: "Gmsh MSH 4.1: the mshio parser failed (panicked) on this file".to_owned(),
        })?;
    let msh = parsed?;

    let Some(msh_nodes) = msh.data.nodes else {
        return Err(MeshError::Malformed {
            file: name.to_owned(),
            line: None,
            expected: "a $Nodes section".to_owned(),
            found: "none".to_owned(),
        });
    };
    let total = check_count(name, None, "node", msh_nodes.num_nodes)?;
    let coords: Vec<[f64; 3]> = msh_nodes
        .node_blocks
        .iter()
        .flat_map(|block| block.nodes.iter().map(|n| [n.x, n.y, n.z]))
        .collect();
    // mshio keeps node tags only when they are sparse and then in a hash map; read
    // them in file order ourselves so any tag layout maps correctly.
    if coords.len() != total {
        return Err(MeshError::CountMismatch {
            file: name.to_owned(),
            line: None,
            what: "nodes in $Nodes".to_owned(),
            declared: total,
            found: coords.len(),
        });
    }
    let tags = layout
        .and_then(|layout| scan_node_tags(bytes, layout))
        .filter(|tags| tags.len() == coords.len())
        .ok_or_else(|| MeshError::Parse {
            file: name.to_owned(),
            line: None,
            message: "Gmsh MSH 4.1: could not read the node tags of the $Nodes section".to_owned(),
        })?;
    let mut index_of: HashMap<u64, usize> = HashMap::with_capacity(total);
    for (i, &tag) in tags.iter().enumerate() {
        if index_of.insert(tag, i).is_some() {
            return Err(MeshError::Malformed {
                file: name.to_owned(),
                line: None,
                expected: "unique node tags".to_owned(),
                found: format!("node tag {tag} more than once"),
            });
        }
    }
    let nodes = coords;
    if let Some(bad) = nodes.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(MeshError::Malformed {
            file: name.to_owned(),
            line: None,
            expected: "finite node coordinates".to_owned(),
            found: format!("{:?} for node {}", nodes[bad], bad),
        });
    }

    let mut tets = Vec::new();
    let (mut skipped, mut higher_order) = (0, 0);
    if let Some(elements) = &msh.data.elements {
        check_count(name, None, "element", elements.num_elements)?;
        for block in &elements.element_blocks {
            if block.element_type != ElementType::Tet4 {
                skipped += block.elements.len();
                if higher_order_tet(block.element_type as u64) {
                    higher_order += block.elements.len();
                }
                continue;
            }
            for element in &block.elements {
                let mut tet = [0usize; 4];
                if element.nodes.len() != 4 {
                    return Err(MeshError::Malformed {
                        file: name.to_owned(),
                        line: None,
                        expected: "4 nodes per tetrahedron".to_owned(),
                        found: format!(
                            "{} for element {}",
                            element.nodes.len(),
                            element.element_tag
                        ),
                    });
                }
                for (v, tag) in tet.iter_mut().zip(&element.nodes) {
                    *v = *index_of.get(tag).ok_or(MeshError::UnknownNodeTag {
                        file: name.to_owned(),
                        line: None,
                        tag: *tag,
                    })?;
                }
                tets.push(tet);
            }
        }
    }
    if tets.is_empty() {
        return Err(MeshError::NoTetrahedra {
            file: name.to_owned(),
            skipped,
            higher_order,
        });
    }
    Ok(Mesh { nodes, tets })
}

/// Turns mshio's error backtrace into a [`MeshError::Parse`] with the byte
/// offset where the innermost parser failed.
#[cfg(feature = "gmsh-binary")]
fn mshio_error(bytes: &[u8], name: &str, e: &mshio::MshParserError<&[u8]>) -> MeshError {
    let trace = e.filtered_backtrace();
    // Innermost error first; the position is where the innermost parser failed.
    let offset = e
        .backtrace
        .first()
        .map(|(rest, _)| bytes.len().saturating_sub(rest.len()))
        .unwrap_or(0);
    let describe =
        |kind: &mshio::error::MshParserErrorKind| kind.to_string().trim_end_matches('.').to_owned();
    // Outermost context first. mshio nests contexts that repeat their
    // parent ("entity section" holds "entity section: points"): a context
    // that starts with the one before it replaces it.
    let mut parts: Vec<String> = Vec::new();
    let innermost = match trace.first() {
        Some((_, kind)) => describe(kind),
        None => "invalid MSH 4.1 data".to_owned(),
    };
    for part in trace
        .iter()
        .skip(1)
        .rev()
        .map(|(_, k)| describe(k))
        .chain([innermost])
    {
        if let Some(last) = parts.last() {
            if part == *last || part.starts_with(&format!("{last}: ")) {
                parts.pop();
            }
        }
        parts.push(part);
    }
    MeshError::Parse {
        file: name.to_owned(),
        line: None,
        message: format!(
            "Gmsh MSH 4.1: {} (at byte offset {offset})",
            parts.join(": ")
        ),
    }
}
