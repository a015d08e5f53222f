//! Text fixes every OBJ and MTL gets before it is parsed, by either reader (tobj's and
//! the parallel one): comments stripped, grey colours expanded.

/// The OBJ text without comments, including those after a statement
/// (`f 1 2 3 # quad`), which tobj would otherwise read as indices.
pub(super) fn strip_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        out.push_str(line.split('#').next().unwrap_or(""));
        out.push('\n');
    }
    out
}

/// Makes every colour statement (`Ka`, `Kd`, `Ks`, `Ke`) carry three numbers before tobj
/// sees it: the MTL spec allows a single value for grey (`Kd 0.5` = `Kd 0.5 0.5 0.5`),
/// and tobj 4.0 panics on fewer than three words. Zero or two values are an error
/// naming the line.
pub(super) fn normalize_mtl_colours(text: &str) -> Result<std::borrow::Cow<'_, str>, String> {
    fn colour(line: &str) -> Option<(&str, Vec<&str>)> {
        let mut words = line.split_whitespace();
        let key = words.next()?;
        matches!(key, "Ka" | "Kd" | "Ks" | "Ke").then(|| (key, words.take(3).collect()))
    }
    let needs_rewrite = text
        .lines()
        .any(|l| colour(l).is_some_and(|(_, values)| values.len() < 3));
    if !needs_rewrite {
        return Ok(text.into());
    }
    let mut out = String::with_capacity(text.len() + 64);
    for (n, line) in text.lines().enumerate() {
        match colour(line) {
            Some((key, values)) if values.len() == 1 => {
                let v = values[0];
                out.push_str(&format!("{key} {v} {v} {v}"));
            }
            Some((key, values)) if values.len() < 3 => {
                return Err(format!(
                    "line {}: {key} needs three numbers (or one for grey), got {}",
                    n + 1,
                    values.len()
                ));
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    Ok(out.into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey_colours_are_expanded_and_short_ones_refused() {
        let text = "newmtl a\nKd 0.5\nKs 1 2 3\n";
        assert_eq!(
            normalize_mtl_colours(text).unwrap(),
            "newmtl a\nKd 0.5 0.5 0.5\nKs 1 2 3\n"
        );
        assert!(matches!(
            normalize_mtl_colours("Kd 1 2 3\n").unwrap(),
            std::borrow::Cow::Borrowed(_)
        ));
        let err = normalize_mtl_colours("newmtl a\nKe 1 2\n").unwrap_err();
        assert_eq!(
            err,
            "line 2: Ke needs three numbers (or one for grey), got 2"
        );
    }
}
