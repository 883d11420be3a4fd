//! Temporary: inspect one problem (OTG_DEBUG="p0,v0,a0,pf,vf,af,vmax,amax,jmax;..." ).
mod common;
use common::RuckigOracle;
use interpd_otg::{Input, Limits, Otg, State, Trajectory};

#[test]
#[ignore]
fn debug_one() {
    let spec = std::env::var("OTG_DEBUG").unwrap();
    let dofs: Vec<Vec<f64>> =
        spec.split(';').map(|d| d.split(',').map(|x| x.trim().parse().unwrap()).collect()).collect();
    let mut input = Input::new(dofs.len());
    for (i, d) in dofs.iter().enumerate() {
        input.current[i] = State { p: d[0], v: d[1], a: d[2] };
        input.target[i] = State { p: d[3], v: d[4], a: d[5] };
        input.limits[i] = Limits::symmetric(d[6], d[7], d[8]);
    }
    if std::env::var("OTG_VEL").is_ok() {
        input.control = interpd_otg::ControlInterface::Velocity;
    }
    let mut otg = Otg::new();
    let mut t = Trajectory::default();
    let r = otg.calculate(&input, &mut t);
    eprintln!("ours: {r:?} duration {}", t.duration());
    for p in t.profiles() {
        eprintln!("  brake {:?} t {:?} j {:?} total {}", p.brake, p.t, p.j, p.duration());
        eprintln!("  v {:?}\n  a {:?}\n  {:?} {:?} {:?}", p.v, p.a, p.limits, p.direction, p.control_signs);
    }
    eprintln!("independent: {:?}", t.independent_min_durations());
    let mut o = RuckigOracle::new(input.dofs);
    let rr = o.calculate(&input);
    eprintln!("ruckig: {rr:?}");
    if rr.is_ok() {
        let skip: Vec<f64> = t.profiles().iter().map(|p| p.brake.duration).collect();
        eprintln!("ruckig validation {:?}", common::validate_ruckig(&input, &o, &skip));
    }
}
