//! FMUs as tools really export them: extra platform binaries, sources/, resources read at
//! instantiation, declared types, aliases, Integer/Boolean/Enumeration parameters,
//! canBeInstantiatedOnlyOncePerProcess, the unpack cache, and recovery after an FMU error.

mod common;

use fmucal_shared::fmu::schema::{Value, VarType};
use fmucal_shared::fmu::{Fmu, FmuError, Instance, Interface};
use fmucal_shared::sim::{SimError, SimSpec, Simulator, simulate};

fn me() -> SimSpec {
    SimSpec { interface: Some(Interface::ModelExchange), tolerance: Some(1e-9), ..Default::default() }
}

#[test]
fn extra_platform_binaries_and_sources_are_tolerated() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("decay", cache.path());
    for dir in ["binaries/win64", "binaries/win32", "binaries/darwin64", "sources", "resources"] {
        assert!(fmu.dir.join(dir).is_dir(), "{dir} missing from the unpacked FMU");
    }
    let r = simulate(&fmu, &me()).unwrap();
    assert!((r.column("x").unwrap().last().unwrap() - (-2.0f64).exp()).abs() < 1e-6);
}

#[test]
fn resource_file_is_read_at_instantiation() {
    let tmp = tempfile::tempdir().unwrap();
    let doubled = common::repack("decay", tmp.path(), "doubled.fmu", |name, bytes| {
        Some(if name == "resources/decay.txt" { b"factor = 2.0\n".to_vec() } else { bytes })
    });
    let fmu = common::load(&doubled, &tmp.path().join("cache"));
    let r = simulate(&fmu, &me()).unwrap();
    for (t, x) in r.time.iter().zip(r.column("x").unwrap()) {
        assert!((x - (-2.0 * t).exp()).abs() < 1e-6, "factor 2 from resources not applied at t={t}");
    }
    assert_eq!(simulate(&fmu, &SimSpec { outputs: vec!["resourceFactor".into()], ..me() }).unwrap().columns[0][0], 2.0);

    let missing =
        common::repack("decay", tmp.path(), "missing.fmu", |name, b| (!name.starts_with("resources/")).then_some(b));
    let fmu = common::load(&missing, &tmp.path().join("cache"));
    let err = simulate(&fmu, &me()).unwrap_err().to_string();
    assert!(err.contains("fmi2Instantiate") && err.contains("decay.txt"), "{err}");
}

#[test]
fn declared_types_supply_unit_and_bounds() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("decay", cache.path());
    let k = fmu.description.variable("k").unwrap();
    assert_eq!(k.declared_type.as_deref(), Some("Rate"));
    assert_eq!(k.unit.as_deref(), Some("1/s"));
    assert_eq!((k.min, k.max), (Some(0.0), Some(100.0)));
    let err = simulate(&fmu, &SimSpec { parameters: vec![("k".into(), "-1".into())], ..me() }).unwrap_err();
    assert!(err.to_string().contains("below its minimum 0"), "{err}");
}

#[test]
fn aliases_share_a_value_reference_and_read_the_same() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("decay", cache.path());
    let (x, alias) = (fmu.description.variable("x").unwrap(), fmu.description.variable("xAlias").unwrap());
    assert_eq!(x.value_reference, alias.value_reference);
    let r = simulate(&fmu, &SimSpec { outputs: vec!["x".into(), "xAlias".into()], ..me() }).unwrap();
    assert_eq!(r.columns[0], r.columns[1]);
}

#[test]
fn enumeration_parameters_accept_names_and_values() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("decay", cache.path());
    let v = fmu.description.variable("crashMode").unwrap();
    assert_eq!((v.var_type, v.start.clone()), (VarType::Enumeration, Some(Value::Integer(1))));
    for value in ["none", "1"] {
        simulate(&fmu, &SimSpec { parameters: vec![("crashMode".into(), value.into())], ..me() }).unwrap();
    }
    let err = simulate(&fmu, &SimSpec { parameters: vec![("crashMode".into(), "7".into())], ..me() }).unwrap_err();
    assert!(err.to_string().contains("not a value of its enumeration"), "{err}");
    let err =
        simulate(&fmu, &SimSpec { parameters: vec![("crashMode".into(), "explode".into())], ..me() }).unwrap_err();
    assert!(err.to_string().contains("not one of none, error, abort, segfault, hang"), "{err}");
}

#[test]
fn fmu_error_mid_simulation_names_time_and_message_then_instance_recovers() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("decay", cache.path());
    for interface in [Interface::ModelExchange, Interface::CoSimulation] {
        let mut sim = Simulator::new(&fmu, Some(interface)).unwrap();
        let failing = SimSpec {
            interface: Some(interface),
            parameters: vec![("crashMode".into(), "error".into()), ("crashTime".into(), "0.5".into())],
            ..Default::default()
        };
        let err = sim.run(&failing).unwrap_err();
        let text = err.to_string();
        let SimError::Fmu(FmuError::Call { time, .. }) = err else { panic!("{interface}: unexpected error {text}") };
        // CS reports the start of the failing step (0.49); ME the evaluation time past 0.5.
        assert!((0.49..0.6).contains(&time), "{interface}: error reported at t={time}: {text}");
        assert!(text.contains("crashMode=error reached"), "{interface}: FMU message missing: {text}");
        let ok = sim.run(&SimSpec { interface: Some(interface), ..Default::default() }).unwrap();
        assert_eq!(ok.time.len(), 201, "{interface}: instance did not recover");
    }
}

#[test]
fn instantiate_only_once_per_process_is_honoured() {
    let tmp = tempfile::tempdir().unwrap();
    let once = common::once_per_process("furuta", tmp.path());
    let fmu = common::load(&once, &tmp.path().join("cache"));
    let first = Instance::new(&fmu, Interface::ModelExchange, "a").unwrap();
    match Instance::new(&fmu, Interface::CoSimulation, "b") {
        Err(FmuError::OnlyOncePerProcess { .. }) => {}
        other => panic!("second instance allowed: {:?}", other.map(|_| ())),
    }
    drop(first);
    let mut sim = Simulator::new(&fmu, Some(Interface::CoSimulation)).unwrap();
    sim.run(&SimSpec::default()).unwrap();
    sim.run(&SimSpec::default()).unwrap();
}

#[test]
fn second_load_reuses_the_unpacked_directory() {
    let cache = tempfile::tempdir().unwrap();
    let first = common::load_example("furuta", cache.path());
    let marker = first.dir.join("marker-left-by-test");
    std::fs::write(&marker, b"x").unwrap();
    let second = Fmu::load_with(
        &common::example("furuta"),
        &fmucal_shared::fmu::LoadOptions { cache_dir: cache.path().to_owned(), limits: Default::default() },
    )
    .unwrap();
    assert_eq!(first.dir, second.dir);
    assert_eq!(first.sha256.len(), 64);
    assert!(marker.exists(), "the archive was unpacked again");
    assert_eq!(std::fs::read_dir(cache.path()).unwrap().count(), 1);
}

#[test]
fn failed_reset_falls_back_to_a_fresh_instance() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load(&fmucal_models::Fixture::ResetFails.path(), cache.path());
    for interface in [Interface::ModelExchange, Interface::CoSimulation] {
        let mut sim = Simulator::new(&fmu, Some(interface)).unwrap();
        let spec = SimSpec { interface: Some(interface), ..Default::default() };
        let first = sim.run(&spec).unwrap();
        let second = sim.run(&spec).unwrap();
        assert_eq!(first.columns, second.columns, "{interface}: re-instantiated run differs");
    }
}
