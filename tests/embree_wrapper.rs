use ember::embree::{BuildQuality, Device};
use glam::Vec3;
#[test]
fn probe() {
    let d = Device::new("").unwrap();
    eprintln!(
        "empty: {:?}",
        d.build_triangle_scene(&[], &[], BuildQuality::High)
            .map(|s| s.memory_bytes())
    );
    let d2 = Device::new("threads=abc").err().unwrap();
    eprintln!("{:?}", d2);
    let n = 1000u32;
    let mut v = Vec::new();
    let mut t = Vec::new();
    for i in 0..n {
        let x = i as f32;
        v.push(Vec3::new(x, 0., 0.));
        v.push(Vec3::new(x + 1., 0., 0.));
        v.push(Vec3::new(x, 1., 0.));
        t.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    d.set_memory_limit(Some(10_000));
    eprintln!(
        "oom: {:?}",
        d.build_triangle_scene(&v, &t, BuildQuality::High)
            .map(|s| s.memory_bytes())
    );
    d.set_memory_limit(None);
    eprintln!(
        "after: {:?} in use {}",
        d.build_triangle_scene(&v, &t, BuildQuality::High)
            .map(|s| s.memory_bytes()),
        d.bytes_in_use()
    );
    let vn = vec![Vec3::NAN; 3];
    eprintln!(
        "nan: {:?}",
        d.build_triangle_scene(&vn, &[[0, 1, 2]], BuildQuality::High)
            .map(|s| s.memory_bytes())
    );
}
