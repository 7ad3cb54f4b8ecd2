mod fmi_support;
use fmi_support::*;
use std::time::Instant;

#[test]
fn explore() {
    let f = paper_scene("a");
    let t0 = Instant::now();
    let mut t = 0.0;
    for k in 0..1000 {
        let s = f.do_step(t, 1e-4);
        assert!(ok(s), "{k} {:?}", f.log.take());
        t += 1e-4;
    }
    eprintln!("1000 steps: {:?}", t0.elapsed());
    for name in [
        "s_f1",
        "s_f2",
        "s_b1",
        "s_b2",
        "s_b",
        "s_a",
        "base_pitch",
        "w_A",
        "w_B",
        "dte",
    ] {
        eprintln!("{name} = {}", f.get_real(name));
    }
    for h in [1.0, 10.0, 1e3, 1e300] {
        let st = f.get_state();
        let t0 = Instant::now();
        let s = f.do_step(f.time(), h);
        eprintln!("h={h}: {:?} in {:?}: {:?}", s, t0.elapsed(), f.log.take());
        f.set_state(st);
        f.free_state(st);
    }
}
