//! MTL files laid out as exporters lay them out (proptest, stable toolchain): the same
//! materials written cleanly and written the way 3ds Max, Maya or SketchUp write them
//! (indentation, runs of spaces and tabs between a key and its values, trailing blanks,
//! CRLF or CR line ends, a byte-order mark, keys in another case, comments, keys ember
//! ignores) must load as the same materials, with the same warnings.
//!
//! `EMBER_FUZZ_SECONDS=N` runs for N seconds (`.ci/fuzz.sh` does).

mod common;

use std::collections::HashMap;

use ember::scene::{load_obj_from_str, LoadOptions};
use proptest::prelude::*;

/// One statement: its key, values and whether its key may change case.
#[derive(Clone, Debug)]
struct Statement {
    key: &'static str,
    values: String,
}

#[derive(Clone, Debug)]
struct Material {
    name: String,
    statements: Vec<Statement>,
}

/// How one file lays its lines out.
#[derive(Clone, Debug)]
struct Layout {
    end: &'static str,
    bom: bool,
    /// Per line: indentation, the gap after the key, trailing blanks, key upper-cased,
    /// a comment line before it.
    lines: Vec<(String, String, String, bool, bool)>,
}

fn number() -> impl Strategy<Value = String> {
    (0u32..1000).prop_map(|n| format!("{}", n as f32 / 997.0))
}

fn colour() -> impl Strategy<Value = String> {
    prop_oneof![
        (number(), number(), number()).prop_map(|(r, g, b)| format!("{r} {g} {b}")),
        number(),
    ]
}

fn statement() -> impl Strategy<Value = Statement> {
    let of = |key: &'static str, values: BoxedStrategy<String>| {
        values.prop_map(move |values| Statement { key, values })
    };
    prop_oneof![
        of("Kd", colour().boxed()),
        of("Ks", colour().boxed()),
        of("Ke", colour().boxed()),
        of("Ka", colour().boxed()),
        of("Tf", colour().boxed()),
        of("Ns", number().boxed()),
        of("Ni", (1u32..4).prop_map(|n| n.to_string()).boxed()),
        of("d", number().boxed()),
        of("Tr", number().boxed()),
        of("illum", (0u32..10).prop_map(|n| n.to_string()).boxed()),
        of("Pr", number().boxed()),
        of("sharpness", number().boxed()),
        of("map_Kd", "[a-z]{1,6}( [a-z]{1,4})?\\.png".boxed()),
        of("map_Ka", "[a-z]{1,6}\\.jpg".boxed()),
        of("bump", "-bm 0\\.5 [a-z]{1,6}\\.png".boxed()),
    ]
}

fn materials() -> impl Strategy<Value = Vec<Material>> {
    let material = (
        "[A-Za-z][A-Za-z0-9_#]{0,6}( [A-Za-z0-9]{1,5})?",
        prop::collection::vec(statement(), 0..8),
    )
        .prop_map(|(name, statements)| Material { name, statements });
    prop::collection::vec(material, 1..4)
}

fn blanks(max: usize) -> impl Strategy<Value = String> {
    prop::collection::vec(prop_oneof![Just(' '), Just('\t')], 0..=max)
        .prop_map(|v| v.into_iter().collect())
}

fn layout() -> impl Strategy<Value = Layout> {
    let line = (
        blanks(3),
        blanks(3),
        blanks(3),
        any::<bool>(),
        prop::bool::weighted(0.1),
    );
    (
        prop_oneof![Just("\n"), Just("\r\n"), Just("\r")],
        any::<bool>(),
        prop::collection::vec(line, 64),
    )
        .prop_map(|(end, bom, lines)| Layout { end, bom, lines })
}

/// The library written plainly, one space between key and values.
fn clean(materials: &[Material]) -> String {
    let mut text = String::new();
    for m in materials {
        text += &format!("newmtl {}\n", m.name);
        for s in &m.statements {
            text += &format!("{} {}\n", s.key, s.values);
        }
    }
    text
}

/// The same library in `layout`.
fn messy(materials: &[Material], layout: &Layout) -> String {
    let mut text = String::from(if layout.bom { "\u{feff}" } else { "" });
    let mut lines = layout.lines.iter().cycle();
    let mut line = |key: &str, values: &str, text: &mut String| {
        let (indent, gap, trailing, upper, comment) = lines.next().unwrap();
        if *comment {
            *text += &format!("# exported{}", layout.end);
        }
        let key = if *upper {
            key.to_uppercase()
        } else {
            key.to_owned()
        };
        *text += &format!("{indent}{key} {gap}{values}{trailing}{}", layout.end);
    };
    for m in materials {
        line("newmtl", &m.name, &mut text);
        for s in &m.statements {
            line(s.key, &s.values, &mut text);
        }
    }
    text
}

const OBJ: &str = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

fn check(input: &(Vec<Material>, Layout)) -> Result<bool, TestCaseError> {
    let (materials, layout) = input;
    let load = |text: String| {
        let mtl = HashMap::from([("m.mtl".to_owned(), text)]);
        load_obj_from_str(OBJ, &mtl, &LoadOptions::default())
    };
    let clean_text = clean(materials);
    let messy_text = messy(materials, layout);
    let (a, b) = match (load(clean_text.clone()), load(messy_text.clone())) {
        (Ok(a), Ok(b)) => (a, b),
        (a, b) => {
            let (a, b) = (
                a.err().map(|e| e.to_string()),
                b.err().map(|e| e.to_string()),
            );
            prop_assert!(
                a.is_some() && b.is_some(),
                "{a:?} vs {b:?}\n{clean_text}\n{messy_text:?}"
            );
            return Ok(false);
        }
    };
    prop_assert_eq!(
        &a.0.materials,
        &b.0.materials,
        "{}\n{:?}",
        clean_text,
        messy_text
    );
    // Line numbers differ where comments were added; the warnings say the same else.
    let strip = |w: &Vec<String>| {
        w.iter()
            .map(|w| {
                w.split_once(": ")
                    .map_or(w.clone(), |(_, rest)| rest.to_owned())
            })
            .collect::<Vec<_>>()
    };
    prop_assert_eq!(strip(&a.1.warnings), strip(&b.1.warnings));
    Ok(true)
}

#[test]
fn fuzz_mtl_layouts() {
    common::fuzz::run(
        "fuzz_mtl_layouts",
        "loaded alike",
        (materials(), layout()),
        check,
    );
}
