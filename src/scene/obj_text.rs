//! Text rules every OBJ follows whichever reader parses it (tobj's or the parallel
//! one): comments stripped, the names of `usemtl` and `mtllib` read alike, and vertex
//! colours given to every vertex or to none.

use std::borrow::Cow;

/// The name a `usemtl` or `mtllib` statement gives (`keyword` is which), from a line
/// without its comment: what follows the keyword and the blanks after it (spaces or
/// tabs, however many), trimmed; `None` when the line is another statement or the name
/// is empty.
pub(super) fn argument<'a>(line: &'a str, keyword: &str) -> Option<&'a str> {
    let rest = line.trim_start().strip_prefix(keyword)?;
    if !rest.starts_with(char::is_whitespace) {
        return None;
    }
    let name = rest.trim();
    (!name.is_empty()).then_some(name)
}

/// The material a `usemtl` line names: the rest of the whole line, `#` and all, as the
/// MTL reader reads `newmtl` names (3ds Max names its materials `Material #25`).
pub(super) fn used_material(whole_line: &str) -> Option<&str> {
    argument(whole_line, "usemtl")
}

/// The OBJ text for tobj: without comments, including those after a statement
/// (`f 1 2 3 # quad`), which tobj would otherwise read as indices, but not in a
/// `usemtl` name ([`used_material`]); and with each `usemtl` and `mtllib` written
/// `keyword name`, as tobj reads a name only after a single space at the start of the
/// line.
pub(super) fn strip_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for whole in text.lines() {
        let line = whole.split('#').next().unwrap_or("");
        let named = used_material(whole)
            .map(|name| ("usemtl", name))
            .or_else(|| argument(line, "mtllib").map(|name| ("mtllib", name)));
        match named {
            Some((keyword, name)) => {
                out.push_str(keyword);
                out.push(' ');
                out.push_str(name);
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// The OBJ text (without comments) for tobj, which reads vertex colours only where
/// every `v` has them: where some have colours (`v x y z r g b`) and others not, those
/// without get white. A `v` of five or more than six numbers, colours that are not
/// numbers, or a `w` among coloured vertices is an error naming its line.
pub(super) fn pad_vertex_colours(text: &str) -> Result<Cow<'_, str>, String> {
    let mut counts = [0usize; 2];
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if words.next() != Some("v") {
            continue;
        }
        // Seven at most: enough to tell every case apart without collecting the line.
        let values: [Option<&str>; 7] = std::array::from_fn(|_| words.next());
        let colour = values[3..6].iter().flatten();
        match values.iter().flatten().count() {
            3 | 4 => counts[0] += 1,
            6 if colour.clone().all(|w| w.parse::<f32>().is_ok()) => counts[1] += 1,
            6 => return Err(format!("line {}: the vertex colour is not three numbers", n + 1)),
            k => {
                return Err(format!(
                    "line {}: a vertex has 3 coordinates (and w) or 3 and a colour r g b, not {k}{} numbers",
                    n + 1,
                    if k == values.len() { " or more" } else { "" }
                ))
            }
        }
    }
    if counts[0] == 0 || counts[1] == 0 {
        return Ok(text.into());
    }
    let mut out = String::with_capacity(text.len() + 6 * counts[0]);
    for (n, line) in text.lines().enumerate() {
        out.push_str(line);
        let mut words = line.split_whitespace();
        if words.next() == Some("v") {
            match words.count() {
                3 => out.push_str(" 1 1 1"),
                4 => {
                    return Err(format!(
                        "line {}: a vertex with w among vertices with colours",
                        n + 1
                    ))
                }
                _ => {}
            }
        }
        out.push('\n');
    }
    Ok(out.into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_after_any_blanks() {
        assert_eq!(
            argument("usemtl  Red Paint \r", "usemtl"),
            Some("Red Paint")
        );
        assert_eq!(argument("\tusemtl\tRed", "usemtl"), Some("Red"));
        assert_eq!(argument("usemtl", "usemtl"), None);
        assert_eq!(argument("usemtlx a", "usemtl"), None);
        assert_eq!(
            strip_comments("usemtl\tMaterial #25\nmtllib  a b.mtl # two\n# usemtl x\n"),
            "usemtl Material #25\nmtllib a b.mtl\n\n"
        );
    }

    #[test]
    fn colours_go_to_every_vertex_or_none() {
        let plain = "v 0 0 0\nv 1 0 0\n";
        assert!(matches!(pad_vertex_colours(plain), Ok(Cow::Borrowed(_))));
        let mixed = "v 0 0 0 1 0 0\nv 1 0 0\nvt 0 0\n";
        assert_eq!(
            pad_vertex_colours(mixed).unwrap(),
            "v 0 0 0 1 0 0\nv 1 0 0 1 1 1\nvt 0 0\n"
        );
        let err = pad_vertex_colours("v 0 0 0\nv 0 0 0 a b c\n").unwrap_err();
        assert!(err.starts_with("line 2:"), "{err}");
        let err = pad_vertex_colours("v 0 0 0 1 1\n").unwrap_err();
        assert!(err.contains("not 5 numbers"), "{err}");
        assert!(pad_vertex_colours("v 0 0 0 1 1 1\nv 0 0 0 2\n").is_err());
    }
}
