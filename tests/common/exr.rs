//! Crafted EXR files for the tests of hostile input.

/// An EXR whose header claims `w`x`h` pixels of float R, G, B (uncompressed scan lines,
/// an offset table of one entry per line), all naming one line of zeros.
pub fn claiming(w: i32, h: i32) -> Vec<u8> {
    let mut b = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    let mut attribute = |name: &str, kind: &str, value: &[u8]| {
        for text in [name, kind] {
            b.extend_from_slice(text.as_bytes());
            b.push(0);
        }
        b.extend_from_slice(&(value.len() as i32).to_le_bytes());
        b.extend_from_slice(value);
    };
    // Float channels B, G, R (a channel list is sorted by name), linear, 1x1 sampling.
    let mut chlist = Vec::new();
    for name in ["B", "G", "R"] {
        chlist.extend_from_slice(name.as_bytes());
        chlist.push(0);
        for v in [2i32, 0, 1, 1] {
            chlist.extend_from_slice(&v.to_le_bytes());
        }
    }
    chlist.push(0);
    attribute("channels", "chlist", &chlist);
    attribute("compression", "compression", &[0]);
    let window: Vec<u8> = [0, 0, w - 1, h - 1]
        .iter()
        .flat_map(|v: &i32| v.to_le_bytes())
        .collect();
    attribute("dataWindow", "box2i", &window);
    attribute("displayWindow", "box2i", &window);
    attribute("lineOrder", "lineOrder", &[0]);
    attribute("pixelAspectRatio", "float", &1f32.to_le_bytes());
    attribute("screenWindowCenter", "v2f", &[0; 8]);
    attribute("screenWindowWidth", "float", &1f32.to_le_bytes());
    b.push(0);
    let data_at = (b.len() + 8 * h as usize) as u64;
    for _ in 0..h {
        b.extend_from_slice(&data_at.to_le_bytes());
    }
    b.extend_from_slice(&0i32.to_le_bytes());
    b.extend_from_slice(&(12 * w).to_le_bytes());
    b.extend(std::iter::repeat_n(0u8, 12 * w as usize));
    b
}
