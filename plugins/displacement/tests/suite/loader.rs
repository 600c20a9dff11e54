//! Set-up tables the loader must reject, each with an error naming the offending key.

use mtcal_displacement::load;
use mtcal_instrument::SetupContext;
use mtcal_kinematics::Machine;

fn machine() -> Machine {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../machines/mcv754-zfyx.urdf"
    );
    mtcal_machine::load_machine(path, Default::default())
        .expect("shipped machine")
        .machine
}

/// Loads `text` and expects an error naming `key` whose message contains `says`.
fn check(text: &str, key: &str, says: &str) {
    let m = machine();
    let t: toml::Table = toml::from_str(text).expect("valid toml");
    match load(&t, &SetupContext { machine: &m }) {
        Ok(s) => panic!("accepted {text:?}: {s:?}"),
        Err(e) => {
            assert_eq!(e.key, key, "{text:?}: {e}");
            assert!(e.message.contains(says), "{text:?}: {e}");
        }
    }
}

#[test]
fn bad_top_level_keys_and_values_are_rejected() {
    check(
        "positon = [0, 0, 0]\n[sensors]\na = \"X\"\n",
        "positon",
        "unknown key",
    );
    check("", "sensors", "missing");
    check("sensors = {}\n", "sensors", "no sensors");
    check("sensors = \"X\"\n", "sensors", "table of sensors");
    check(
        "position = [1, 2]\n[sensors]\na = \"X\"\n",
        "position",
        "three numbers",
    );
    check(
        "position = \"0\"\n[sensors]\na = \"X\"\n",
        "position",
        "three numbers",
    );
    check("sigma_um = 0.0\n[sensors]\na = \"X\"\n", "sigma_um", "> 0");
    check(
        "sigma_um = \"1\"\n[sensors]\na = \"X\"\n",
        "sigma_um",
        "finite number",
    );
    check(
        "sigma_um = nan\n[sensors]\na = \"X\"\n",
        "sigma_um",
        "finite number",
    );
    check(
        "offset_free = 1\n[sensors]\na = \"X\"\n",
        "offset_free",
        "true or false",
    );
}

#[test]
fn bad_directions_are_rejected_naming_the_sensor() {
    check("[sensors]\na = \"Q\"\n", "sensors.a", "unknown direction");
    check("[sensors]\na = \"x\"\n", "sensors.a", "unknown direction");
    check("[sensors]\na = \"--X\"\n", "sensors.a", "unknown direction");
    check("[sensors]\na = [0, 0, 0]\n", "sensors.a", "nonzero");
    check("[sensors]\na = [1e300, 1e300, 0]\n", "sensors.a", "nonzero");
    check("[sensors]\na = [1, inf, 0]\n", "sensors.a", "three numbers");
    check("[sensors]\na = [1, 0]\n", "sensors.a", "three numbers");
    check(
        "[sensors]\na = [1, \"0\", 0]\n",
        "sensors.a",
        "three numbers",
    );
    check("[sensors]\na = 1.0\n", "sensors.a", "expected a direction");
    check("[sensors]\na = true\n", "sensors.a", "expected a direction");
    check("[sensors]\n\"a b\" = \"X\"\n", "sensors.a b", "sensor name");
    check("[sensors]\n\"\" = \"X\"\n", "sensors.", "sensor name");
}

#[test]
fn bad_keys_inside_a_sensor_table_are_rejected_with_their_path() {
    check(
        "[sensors]\na = { direction = \"X\", sigma = 0.3 }\n",
        "sensors.a.sigma",
        "unknown key",
    );
    check(
        "[sensors]\na = { direction = 1.0 }\n",
        "sensors.a.direction",
        "expected a direction",
    );
    check(
        "[sensors]\na = { direction = [0, 0, 0] }\n",
        "sensors.a.direction",
        "nonzero",
    );
    check(
        "[sensors]\na = { direction = \"X\", sigma_um = \"0.3\" }\n",
        "sensors.a.sigma_um",
        "finite number",
    );
    check(
        "[sensors]\na = { direction = \"X\", sigma_um = -1 }\n",
        "sensors.a.sigma_um",
        "> 0",
    );
    check(
        "[sensors]\na = { direction = \"X\", at = \"top\" }\n",
        "sensors.a.at",
        "three numbers",
    );
    check(
        "[sensors]\na = { direction = \"X\", at = [0, 0] }\n",
        "sensors.a.at",
        "three numbers",
    );
    check(
        "[sensors]\na = { at = [0, 0, 50] }\n",
        "sensors.a.at",
        "needs a `direction`",
    );
}

/// Replaces every value of a full set-up, at the top and inside every sensor, with one of
/// the wrong type, as the conformance harness does for the top level only.
#[test]
fn every_key_at_every_depth_rejects_a_value_of_the_wrong_type() {
    let text = r#"
        position = [1.0, 2.0, 3.0]
        sigma_um = 0.5
        offset_free = false
        [sensors]
        a = "X"
        b = [0.0, 1.0, 1.0]
        c = {}
        d = { direction = "Y", sigma_um = 0.3, at = [0.0, 0.0, 50.0] }
        e = { direction = [1.0, 0.0, 0.0], sigma_um = 0.2 }
        f = { sigma_um = 0.4 }
    "#;
    let full: toml::Table = toml::from_str(text).expect("valid");
    let m = machine();
    let ctx = SetupContext { machine: &m };
    load(&full, &ctx).expect("the full set-up loads");
    let wrong = |v: &toml::Value| match v {
        toml::Value::String(_) => toml::Value::Array(vec![true.into()]),
        _ => "not-a-valid-value".into(),
    };
    let mut cases = Vec::new();
    for (key, value) in &full {
        let mut t = full.clone();
        t.insert(key.clone(), wrong(value));
        cases.push((key.clone(), t));
    }
    let sensors = full["sensors"].as_table().expect("table");
    for (name, value) in sensors {
        let mut s = sensors.clone();
        s.insert(name.clone(), wrong(value));
        let mut t = full.clone();
        t.insert("sensors".into(), s.into());
        cases.push((format!("sensors.{name}"), t));
        for (key, inner) in value.as_table().into_iter().flatten() {
            let mut sensor = value.as_table().expect("table").clone();
            sensor.insert(key.clone(), wrong(inner));
            let mut s = sensors.clone();
            s.insert(name.clone(), sensor.into());
            let mut t = full.clone();
            t.insert("sensors".into(), s.into());
            cases.push((format!("sensors.{name}.{key}"), t));
        }
    }
    // 4 top-level keys, 6 sensors, 6 keys inside sensor tables.
    assert_eq!(cases.len(), 4 + 6 + 6);
    for (key, t) in cases {
        match load(&t, &ctx) {
            Ok(_) => panic!("`{key}` with a value of the wrong type was accepted"),
            Err(e) => assert_eq!(e.key, key, "{e}"),
        }
    }
}
